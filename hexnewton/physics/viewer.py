"""Rendering through Newton's viewers: an interactive window, headless ``.mp4`` videos and recordings.

One :class:`RolloutViewer` binds a batched :class:`~hexnewton.physics.world.World` (every robot in one Newton model, each in
its own lane) to one of Newton's viewers (``newton.viewer``):

- ``gl``: ``ViewerGL``, an OpenGL window; with ``headless=True`` it renders off-screen through EGL, which on a
  machine without a GPU is Mesa's software rasteriser (llvmpipe). ``video=PATH.mp4`` grabs every rendered frame
  (``ViewerGL.get_frame``), draws the time and the task into it (Pillow) and encodes it with ffmpeg from
  ``imageio-ffmpeg``;
- ``usd``, ``rerun``, ``file``: ``ViewerUSD`` (``.usd``/``.usda``/``.usdc``, opens in usdview or Omniverse),
  ``ViewerRerun`` (``.rrd``, opens in the Rerun viewer) and ``ViewerFile`` (``.json``/``.bin``, Newton's own
  recording, replayed by ``ViewerFile.load_recording``): the model and the body poses of every frame, for offline
  inspection and replay;
- ``viser``: ``ViewerViser``, a web page (viser) that any browser opens, for machines without a display: the server
  binds to 127.0.0.1 unless told otherwise (reach it through ``ssh -L 8080:localhost:8080 host``); with ``out=PATH.viser``
  it also writes a recording that plays back in the browser (:func:`check_port` fails at once on a port in use, which
  viser itself would wait on);
- ``null``: ``ViewerNull``, nothing drawn (timing, tests).

Only the first ``robots`` lanes are shown (``ViewerBase.set_visible_worlds``), where the simulation put them: the
viewer's automatic world offsets are switched off. The shown robots' goals are drawn as points (``log_points``): each
one's goal now green, the rest of its waypoint course white (an env's ``goals``, ``mdp/terms/goals.py``). A follow camera looks at the mean base position of the shown
robots from behind and to the side. ``RolloutViewer.add`` has the signature of the rollout recorders
(:func:`hexnewton.analysis.rollout.rollout`), so a viewer rides along any rollout.

Headless OpenGL needs ``PYGLET_HEADLESS=1`` before pyglet is first imported (:func:`make_viewer` sets it) and, on a
machine without a GPU driver, Mesa's EGL and software rasteriser (Debian: ``libegl1 libegl-mesa0 libgl1-mesa-dri
libgl1 libgbm1``).
"""

from __future__ import annotations

import importlib.util
import math
import os
import socket
import sys
import time

import numpy as np

VIEWERS = ("gl", "viser", "usd", "rerun", "file", "null")
#: recording viewers -> the file endings their ``--out`` takes
RECORDINGS = {"usd": (".usd", ".usda", ".usdc"), "rerun": (".rrd",), "file": (".json", ".bin")}
#: live viewers that can also record (``--out`` optional) -> the file endings
LIVE_RECORDINGS = {"viser": (".viser",)}
#: viewer -> (module it needs, pip package)
_NEEDS = {"gl": ("pyglet", "pyglet"), "viser": ("viser", "viser"), "usd": ("pxr", "usd-core"),
          "rerun": ("rerun", "rerun-sdk")}
#: where the browser viewer listens unless told otherwise: this machine only
DEFAULT_HOST, DEFAULT_PORT = "127.0.0.1", 8080
VIDEO_EXTENSIONS = (".mp4",)


def has_display() -> bool:
    """Whether a window can open: a desktop session (X11 or Wayland on Linux; always on macOS and Windows)."""
    if sys.platform in ("darwin", "win32"):
        return True
    return bool(os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY"))


def default_viewer(video: str | None, out: str | None) -> str:
    """The viewer a command line without ``--viewer`` gets: the recording ``out``'s file ending names, else ``gl``
    for a video or with a display, else ``null``."""
    for viewer, ends in {**RECORDINGS, **LIVE_RECORDINGS}.items():
        if out is not None and out.endswith(ends):
            return viewer
    if video or has_display():
        return "gl"
    return "null"


def _require(viewer: str) -> None:
    module, package = _NEEDS.get(viewer, (None, None))
    if module is None:
        return
    if importlib.util.find_spec(module) is None:
        raise ValueError(f"--viewer {viewer} needs {package}: pip install -e \".[viewer]\" (or pip install {package})")


def check_viewer_args(viewer: str, headless: bool, video: str | None, out: str | None, host: str = DEFAULT_HOST,
                      port: int = DEFAULT_PORT) -> None:
    """Fail before any simulation, with one line, on a combination of viewer flags that cannot work (for ``viser``,
    also on a ``host:port`` it cannot listen on: :func:`check_port`)."""
    if viewer not in VIEWERS:
        raise ValueError(f"unknown viewer '{viewer}': choose from {', '.join(VIEWERS)}")
    if video is not None:
        if not video.endswith(VIDEO_EXTENSIONS):
            raise ValueError(f"{video}: a video must be a {' or '.join(VIDEO_EXTENSIONS)} file")
        if viewer != "gl":
            raise ValueError(f"--video renders through ViewerGL: use --viewer gl (not {viewer}), or --out for a "
                             "recording")  # fmt: skip
        if importlib.util.find_spec("imageio_ffmpeg") is None:
            raise ValueError("writing .mp4 needs ffmpeg from imageio-ffmpeg: pip install -e \".[viewer]\"")
    if viewer in RECORDINGS:
        ends = RECORDINGS[viewer]
        if out is None:
            raise ValueError(f"--viewer {viewer} records to a file: give --out PATH{ends[0]}")
        if not out.endswith(ends):
            raise ValueError(f"{out}: a {viewer} recording must be a {' or '.join(ends)} file")
        if out.endswith(".bin"):
            if importlib.util.find_spec("cbor2") is None:
                raise ValueError(f"{out}: a .bin recording needs cbor2 (pip install cbor2), or write .json")
    elif viewer in LIVE_RECORDINGS and out is not None:
        if not out.endswith(LIVE_RECORDINGS[viewer]):
            raise ValueError(f"{out}: a {viewer} recording must be a {' or '.join(LIVE_RECORDINGS[viewer])} file")
    elif out is not None:
        raise ValueError(f"--out is the file of a recording: use it with --viewer "
                         f"{', '.join([*RECORDINGS, *LIVE_RECORDINGS])}")  # fmt: skip
    if viewer == "gl" and not headless and video is None and not has_display():
        raise ValueError("--viewer gl opens a window but there is no display (DISPLAY is unset): add --headless "
                         "--video PATH.mp4, or record with --viewer usd --out PATH.usd")  # fmt: skip
    _require(viewer)
    if viewer == "viser":
        check_port(host, port)


def check_port(host: str, port: int) -> None:
    """One line instead of a hang when the browser viewer's ``host:port`` cannot be listened on (in use, or not an
    address of this machine)."""
    if not 0 < port < 65536:
        raise ValueError(f"--port {port}: choose a port in 1-65535")
    with socket.socket(socket.AF_INET6 if ":" in host else socket.AF_INET, socket.SOCK_STREAM) as sock:
        sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)  # as the server does: a closed one's port is free
        try:
            sock.bind((host, port))
        except OSError as exc:
            why = "is in use" if exc.errno in (98, 48, 10048) else f"cannot be listened on ({exc.strerror})"
            raise ValueError(f"{host}:{port} {why}: choose another with --port (or --host)") from None


def make_viewer(viewer: str, out: str | None = None, headless: bool = False, width: int = 960, height: int = 540,
                fps: float = 50.0, num_frames: int | None = None, host: str = DEFAULT_HOST, port: int = DEFAULT_PORT,
                title: str = ""):  # fmt: skip
    """One of Newton's viewers (``VIEWERS``), as Newton's examples make them (``newton.examples.init``)."""
    if viewer == "gl" and headless:
        os.environ["PYGLET_HEADLESS"] = "1"  # read once, when pyglet is first imported
        if "pyglet" in sys.modules:  # imported already: its options count until its GL module loads
            sys.modules["pyglet"].options["headless"] = True
    import newton.viewer

    if viewer == "gl":
        return newton.viewer.ViewerGL(width=width, height=height, headless=headless, vsync=False)
    if viewer == "viser":
        return newton.viewer.ViewerViser(host=host, port=port, label=title or "hexnewton", verbose=False,
                                         record_to_viser=out)  # fmt: skip
    if viewer == "usd":
        return newton.viewer.ViewerUSD(output_path=out, fps=max(1, round(fps)), num_frames=num_frames)
    if viewer == "rerun":
        return newton.viewer.ViewerRerun(record_to_rrd=out, serve_web_viewer=False)
    if viewer == "file":
        return newton.viewer.ViewerFile(out, auto_save=False)
    return newton.viewer.ViewerNull(num_frames=num_frames or 1 << 30)


# ----------------------------------------------------------------------------------------------- frame overlay
def _font(size: int):
    from PIL import ImageFont

    try:
        return ImageFont.load_default(size=size)
    except TypeError:  # Pillow < 10.1: one bitmap size
        return ImageFont.load_default()


def draw_caption(frame: np.ndarray, lines: list[str]) -> np.ndarray:
    """``frame`` (H, W, 3) uint8 with ``lines`` written at its top left on a dark band."""
    from PIL import Image, ImageDraw

    img = Image.fromarray(frame)
    draw = ImageDraw.Draw(img)
    size = max(12, frame.shape[0] // 30)
    font = _font(size)
    pad, step = size // 2, int(size * 1.3)
    width = max(draw.textlength(line, font=font) for line in lines) if lines else 0
    draw.rectangle((0, 0, int(width) + 2 * pad, pad + step * len(lines)), fill=(20, 20, 20))
    for i, line in enumerate(lines):
        draw.text((pad, pad // 2 + i * step), line, fill=(255, 255, 255), font=font)
    return np.asarray(img)


class VideoWriter:
    """Frames (H, W, 3) uint8 into an H.264 ``.mp4`` through imageio-ffmpeg's ffmpeg."""

    def __init__(self, path: str, fps: float):
        import imageio_ffmpeg

        self.path, self.fps, self.frames = path, fps, 0
        self._gen = None
        self._ffmpeg = imageio_ffmpeg

    def add(self, frame: np.ndarray) -> None:
        if self._gen is None:
            h, w = frame.shape[:2]
            self._gen = self._ffmpeg.write_frames(self.path, (w, h), fps=self.fps, codec="libx264", quality=7,
                                                  macro_block_size=2, ffmpeg_log_level="error")  # fmt: skip
            self._gen.send(None)
        self._gen.send(np.ascontiguousarray(frame))
        self.frames += 1

    def close(self) -> None:
        if self._gen is not None:
            self._gen.close()
            self._gen = None


# ----------------------------------------------------------------------------------------------- the viewer
GROUND_COLOR, TORSO_COLOR, LEG_COLOR = (0.62, 0.58, 0.50), (0.93, 0.55, 0.15), (0.22, 0.24, 0.28)
GOAL_COLOR, WAYPOINT_COLOR, GOAL_RADIUS = (0.10, 0.80, 0.25), (0.95, 0.95, 0.95), 0.04


def paint(model) -> None:
    """Colour the model's shapes for the viewers (``Model.shape_color``, display only): the terrain sand, each
    robot's torso orange, its legs dark grey."""
    if getattr(model, "shape_color", None) is None:
        return
    body = model.shape_body.numpy()
    bodies_per_robot = max(1, model.body_count // max(1, model.world_count))
    colors = np.empty((len(body), 3), np.float32)
    colors[:] = LEG_COLOR
    colors[body < 0] = GROUND_COLOR
    colors[(body >= 0) & (body % bodies_per_robot == 0)] = TORSO_COLOR
    model.shape_color.assign(colors)


class RolloutViewer:
    """Shows a batched world's first ``robots`` robots through a Newton viewer, every ``stride`` control steps.

    ``viewer``: one of ``VIEWERS``; ``out``: the recording's file (usd, rerun, file, viser); ``video``: an ``.mp4``
    written from ViewerGL's frames (headless or in a window), each captioned with ``title`` and the time; ``host`` and
    ``port``: where the browser viewer (viser) listens, its page captioned likewise; ``realtime``: one drawn frame per
    control step of wall time at most, so ``stride`` times real time (a live view one can watch). :meth:`add` is a rollout
    recorder's hook; :meth:`close` finishes the video or recording."""

    def __init__(self, viewer: str = "gl", *, headless: bool = False, video: str | None = None, out: str | None = None,
                 robots: int = 3, stride: int = 1, title: str = "", width: int = 960, height: int = 540,
                 control_dt: float = 0.02, host: str = DEFAULT_HOST, port: int = DEFAULT_PORT,
                 realtime: bool = False):  # fmt: skip
        check_viewer_args(viewer, headless, video, out, host, port)
        self.kind, self.robots, self.stride, self.title = viewer, robots, max(1, stride), title
        self.video_path, self.out = video, out
        self.fps = 1.0 / (self.stride * control_dt)
        self.viewer = make_viewer(viewer, out, headless, width, height, self.fps, host=host, port=port, title=title)
        self.video = VideoWriter(video, self.fps) if video else None
        self.caption = self.viewer.server.gui.add_markdown(title) if viewer == "viser" else None
        self.realtime, self.control_dt, self._next_frame = realtime, control_dt, None
        self.world = None
        self.frames = 0
        self._k = 0
        self._cam: np.ndarray | None = None
        self.closed_by_user = False

    @property
    def url(self) -> str | None:
        """The browser viewer's address (viser), else None."""
        return self.viewer.url if self.kind == "viser" else None

    # -- set-up
    def attach(self, world) -> None:
        """Give the viewer ``world``'s model, its first ``robots`` lanes shown where they are."""
        self.world = world
        v = self.viewer
        paint(world.model)
        v.set_model(world.model)
        v.set_world_offsets((0.0, 0.0, 0.0))  # the lanes already keep the robots apart
        self.shown = min(self.robots, world.num_envs)
        if self.shown < world.num_envs:
            v.set_visible_worlds(list(range(self.shown)))

    def follow(self, base: np.ndarray) -> None:
        """Put the camera behind and beside ``base`` (the shown robots' base positions, (R, 3)), looking at their
        mean, as far back as the robot is large (the task's ``length_scale``); the target is smoothed so that the
        picture does not shake with the gait."""
        target = base.mean(axis=0)
        self._cam = target if self._cam is None else self._cam + 0.15 * (target - self._cam)
        spread = float(np.ptp(base[:, 1])) if len(base) > 1 else 0.0
        size = self.world.cfg.task.length_scale if self.world is not None else 1.0
        dist = max(1.1 * size, 0.9 * spread + 0.7 * size)
        direction = np.array([0.75, 0.55, -0.38])  # the view direction: forward (+x), across the lanes, down
        direction /= np.linalg.norm(direction)
        pos = self._cam - dist * direction
        pitch = math.degrees(math.asin(direction[2]))
        yaw = math.degrees(math.atan2(direction[1], direction[0]))
        if self.kind in ("gl", "viser"):
            self.viewer.set_camera(pos.tolist(), pitch, yaw)

    # -- per frame
    def goal_marks(self, env) -> tuple[np.ndarray, np.ndarray] | None:
        """The shown robots' goals (R, 2) and waypoint courses (R, K, 2) in the world from ``env``'s goals (None for
        an env without them)."""
        goals = getattr(env, "goals", None)
        if goals is None or self.world is None:
            return None
        return goals.goal.numpy()[: self.shown].astype(np.float64), goals.waypoints_world()[: self.shown]

    def draw_goals(self, world, marks) -> None:
        """The goals as points on the ground: the goal now green, the other waypoints white."""
        import warp as wp

        from hexnewton.terrain.query import terrain_height_np

        for name, xy, color in (("goals", marks[0], GOAL_COLOR), ("waypoints", marks[1].reshape(-1, 2), WAYPOINT_COLOR)):
            if not len(xy):
                continue
            z = terrain_height_np(world.terrain.grid, xy[:, 0], xy[:, 1]) + GOAL_RADIUS
            device = getattr(self.viewer, "device", None) or world.device
            points = wp.array(np.c_[xy, z].astype(np.float32), dtype=wp.vec3, device=device)
            colors = wp.full(len(xy), wp.vec3(*color), dtype=wp.vec3, device=device)
            self.viewer.log_points(name, points, GOAL_RADIUS if name == "goals" else 0.6 * GOAL_RADIUS, colors)

    def render(self, world, t: float, goals=None) -> None:
        """Draw ``world``'s current state at simulated time ``t`` (and ``goals``, :meth:`goal_marks`' arrays)."""
        if self.world is not world:
            self.attach(world)
        v = self.viewer
        if self.kind == "gl" and not v.is_running():  # the window was closed: the rollout goes on unseen
            self.closed_by_user = True
            return
        base = world.state_0.body_q.numpy().reshape(world.num_envs, -1, 7)[: self.shown, 0, :3]
        self.follow(base)
        if self.realtime:  # wait for the frame's wall time
            now = time.perf_counter()
            self._next_frame = now if self._next_frame is None else max(self._next_frame, now - 1.0)
            time.sleep(max(0.0, self._next_frame - now))
            self._next_frame += self.control_dt  # one control step of wall time per drawn frame: stride x real time
        v.begin_frame(t)
        v.log_state(world.state_0)
        if goals is not None:
            self.draw_goals(world, goals)
        if self.caption is not None:
            self.caption.content = "  \n".join(line for line in (self.title, f"t = {t:6.2f} s") if line)
        v.end_frame()
        self.frames += 1
        if self.video is not None:
            frame = v.get_frame().numpy()
            self.video.add(draw_caption(frame, [line for line in (self.title, f"t = {t:6.2f} s") if line]))

    def add(self, env, t: float, q=None, rpy=None, done=None) -> None:
        """The rollout hook: every ``stride``-th control step, draw ``env``'s world."""
        if self._k % self.stride == 0:
            if self.world is not env.world:
                self.attach(env.world)
            self.render(env.world, t, self.goal_marks(env))
        self._k += 1

    def close(self) -> None:
        """Finish the video or recording (and close the window)."""
        if self.video is not None:
            self.video.close()
        if self.kind != "null":
            self.viewer.close()  # writes a recording's file; stops viser's server


# ----------------------------------------------------------------------------------------------- during training
class _TrainingEnvView:
    """A training env (rsl-rl VecEnv) seen through a viewer: everything but ``step`` and this class's own attributes
    is the wrapped env's (read from and written to it)."""

    def __init__(self, env, **attrs):
        for name, value in dict(attrs, env=env).items():
            object.__setattr__(self, name, value)

    def __getattr__(self, name: str):
        return getattr(self.env, name)

    def __setattr__(self, name: str, value) -> None:
        if name in self.__dict__:
            object.__setattr__(self, name, value)
        else:
            setattr(self.env, name, value)


class LiveEnv(_TrainingEnvView):
    """A training env whose first ``robots`` robots are drawn live in the browser (:class:`RolloutViewer` with
    ``viser``) every ``stride`` control steps while training runs; the page says the iteration."""

    def __init__(self, env, stride: int, steps_per_iteration: int, robots: int = 3, title: str = "",
                 host: str = DEFAULT_HOST, port: int = DEFAULT_PORT):  # fmt: skip
        viewer = RolloutViewer("viser", robots=robots, title=title, control_dt=env.cfg.task.control_dt, host=host,
                               port=port)  # fmt: skip
        super().__init__(env, viewer=viewer, stride=max(1, stride), steps_per_iteration=steps_per_iteration,
                         title=title, first_iteration=0, _step=0)  # fmt: skip

    @property
    def url(self) -> str:
        return self.viewer.url

    def step(self, actions):
        out = self.env.step(actions)
        if self._step % self.stride == 0:
            iteration = self.first_iteration + self._step // self.steps_per_iteration
            self.viewer.title = f"{self.title}iteration {iteration}"
            if self.viewer.world is not self.env.world:
                self.viewer.attach(self.env.world)
            self.viewer.render(self.env.world, self._step * self.env.cfg.task.control_dt,
                               self.viewer.goal_marks(self.env))  # fmt: skip
        self._step += 1
        return out

    def close(self) -> None:
        self.viewer.close()


class VideoEnv(_TrainingEnvView):
    """A training env that records a clip every ``interval`` iterations (Isaac Lab's and mjlab's ``--video``): from
    the first control step of iterations 0, ``interval``, 2 ``interval``, ... the next ``length`` control steps go
    through a headless :class:`RolloutViewer` into ``folder/iteration_<k>.mp4``."""

    def __init__(self, env, folder: str, interval: int, length: int, steps_per_iteration: int, robots: int = 3,
                 title: str = "", width: int = 960, height: int = 540):  # fmt: skip
        check_viewer_args("gl", True, "clip.mp4", None)
        os.makedirs(folder, exist_ok=True)
        super().__init__(env, folder=folder, interval=interval, length=length, steps_per_iteration=steps_per_iteration,
                         robots=robots, title=title, size=(width, height), first_iteration=0, clips=[], _step=0,
                         _recorder=None, _left=0)  # fmt: skip

    def step(self, actions):
        out = self.env.step(actions)
        period = self.interval * self.steps_per_iteration
        if self._recorder is None and self._step % period == 0:
            iteration = self.first_iteration + self._step // self.steps_per_iteration
            path = os.path.join(self.folder, f"iteration_{iteration}.mp4")
            self._recorder = RolloutViewer("gl", headless=True, video=path, robots=self.robots, width=self.size[0],
                                           height=self.size[1], control_dt=self.env.cfg.task.control_dt,
                                           title=f"{self.title}iteration {iteration}")  # fmt: skip
            self._left = self.length
        if self._recorder is not None:
            if self._recorder.world is not self.env.world:
                self._recorder.attach(self.env.world)
            self._recorder.render(self.env.world, (self.length - self._left) * self.env.cfg.task.control_dt,
                                  self._recorder.goal_marks(self.env))  # fmt: skip
            self._left -= 1
            if self._left <= 0:
                self.close()
        self._step += 1
        return out

    def close(self) -> None:
        """Finish the clip being recorded, if any."""
        if self._recorder is not None:
            self._recorder.close()
            self.clips.append(self._recorder.video_path)
            object.__setattr__(self, "_recorder", None)

"""Headless rollout videos (``play.py --video out.mp4``): matplotlib draws the robots on the terrain, no display.

Each frame shows the terrain around the robots (its exact height grid, shaded by height) and every recorded
robot as its torso box and legs (hip, knee, foot of each leg, from the simulated body poses). ``.mp4`` is
written with ffmpeg from the ``imageio-ffmpeg`` package (``pip install -e ".[video]"``), ``.gif`` with
Pillow (always available with matplotlib).
"""

from __future__ import annotations

import numpy as np

VIDEO_EXTENSIONS = (".mp4", ".gif")


def check_video_path(path: str) -> None:
    """Fail before any simulation on a file name we cannot write a video to."""
    if not path.endswith(VIDEO_EXTENSIONS):
        raise ValueError(f"{path}: a video must be a {' or '.join(VIDEO_EXTENSIONS)} file")
    if path.endswith(".mp4"):
        try:
            import imageio_ffmpeg  # noqa: F401
        except ImportError:
            raise ValueError("writing .mp4 needs ffmpeg from imageio-ffmpeg: pip install -e \".[video]\" (or use .gif)")


def _rotate(q: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Rotate vectors v (..., 3) by unit quaternions q (..., 4) in (x, y, z, w) order."""
    u, w = q[..., :3], q[..., 3:4]
    t = 2.0 * np.cross(u, v)
    return v + w * t + np.cross(u, t)


def robot_points(body_q: np.ndarray, torso_size, tibia_length: float) -> tuple[np.ndarray, np.ndarray]:
    """From one robot's 19 body poses (torso, then coxa/femur/tibia per leg; (19, 7) position + quaternion):
    the torso's 8 corners (8, 3) and each leg's hip, femur root, knee and foot (6, 4, 3)."""
    p, q = body_q[:, :3], body_q[:, 3:7]
    sx, sy, sz = (s / 2 for s in torso_size)
    corners = np.array([[x, y, z] for x in (-sx, sx) for y in (-sy, sy) for z in (-sz, sz)])
    torso = p[0] + _rotate(np.broadcast_to(q[0], (8, 4)), corners)
    legs = np.zeros((6, 4, 3))
    for leg in range(6):
        coxa, femur, tibia = 1 + 3 * leg, 2 + 3 * leg, 3 + 3 * leg
        foot = p[tibia] + _rotate(q[tibia], np.array([0.0, 0.0, -tibia_length]))
        legs[leg] = [p[coxa], p[femur], p[tibia], foot]
    return torso, legs


_EDGES = [(0, 1), (2, 3), (4, 5), (6, 7), (0, 2), (1, 3), (4, 6), (5, 7), (0, 4), (1, 5), (2, 6), (3, 7)]


class VideoRecorder:
    """Collects the body poses of the first ``robots`` envs every ``stride`` control steps (``rollout`` calls
    :meth:`add`), then :meth:`save` renders them, ``speed`` times faster than real time."""

    def __init__(self, robots: int = 4, stride: int = 2, speed: int = 1):
        self.robots, self.stride, self.speed = robots, stride * speed, speed
        self.frames: list[np.ndarray] = []
        self.times: list[float] = []
        self._k = 0
        self.env = None

    def add(self, env, t: float, q, rpy, done) -> None:
        if self._k % self.stride == 0:
            self.env = env
            n = min(self.robots, env.num_envs)
            body_q = env.world.state_0.body_q.numpy().reshape(env.num_envs, -1, 7)[:n]
            self.frames.append(body_q.copy())
            self.times.append(t)
        self._k += 1

    def save(self, path: str, title: str = "") -> None:
        if not self.frames:
            raise ValueError("no frames recorded")
        env = self.env
        cfg = env.cfg
        fps = self.speed / (self.stride * cfg.task.control_dt)
        render(path, np.stack(self.frames), np.asarray(self.times), env.world.terrain.grid, cfg.robot.torso_size,
               cfg.robot.tibia_length, fps, title)  # fmt: skip


def render(path: str, frames: np.ndarray, times: np.ndarray, grid, torso_size, tibia_length: float, fps: float,
           title: str = "") -> None:  # fmt: skip
    """Write ``frames`` (T, R, 19, 7) body poses as a video over the terrain ``grid`` (``HeightGrid``)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib import animation

    check_video_path(path)
    if path.endswith(".mp4"):
        import imageio_ffmpeg

        matplotlib.rcParams["animation.ffmpeg_path"] = imageio_ffmpeg.get_ffmpeg_exe()
        writer = animation.FFMpegWriter(fps=fps, bitrate=2400)
    else:
        writer = animation.PillowWriter(fps=fps)
    pos = frames[:, :, 0, :3]
    lo, hi = pos.min(axis=(0, 1)) - 0.4, pos.max(axis=(0, 1)) + 0.4
    # the terrain patch the robots cross, at most ~120 x 120 samples
    xs = np.arange(lo[0], hi[0], max((hi[0] - lo[0]) / 120, grid.res))
    ys = np.arange(lo[1], hi[1], max((hi[1] - lo[1]) / 120, grid.res))
    from .terrain import terrain_height_np

    X, Y = np.meshgrid(xs, ys, indexing="ij")
    Z = terrain_height_np(grid, X, Y)
    fig = plt.figure(figsize=(8, 6), dpi=100)
    ax = fig.add_subplot(projection="3d")
    fig.subplots_adjust(left=0, right=1, bottom=0, top=0.95)
    span = 0.55  # metres of terrain in view around the robots' centre
    ax.computed_zorder = False  # draw order = call order: robots over the terrain surface

    def draw(k: int):
        ax.cla()
        ax.computed_zorder = False
        c = pos[k].mean(axis=0)
        sel = (np.abs(X - c[0]) < span) & (np.abs(Y - c[1]) < span)
        ix = np.where(sel.any(axis=1))[0]
        iy = np.where(sel.any(axis=0))[0]
        if len(ix) > 1 and len(iy) > 1:
            zs = Z[ix[0]:ix[-1] + 1, iy[0]:iy[-1] + 1]
            ax.plot_surface(X[ix[0]:ix[-1] + 1, iy[0]:iy[-1] + 1], Y[ix[0]:ix[-1] + 1, iy[0]:iy[-1] + 1], zs,
                            cmap="terrain", linewidth=0, antialiased=False, alpha=0.8, vmin=-0.05,
                            vmax=max(0.1, float(Z.max())))  # fmt: skip
        for r in range(frames.shape[1]):
            torso, legs = robot_points(frames[k, r], torso_size, tibia_length)
            for a, b in _EDGES:
                ax.plot(*zip(torso[a], torso[b]), color="k", lw=1.2)
            for leg in legs:
                ax.plot(leg[:, 0], leg[:, 1], leg[:, 2], color="tab:red" if r == 0 else "tab:blue", lw=2)
                ax.scatter(*leg[-1], color="k", s=6)
        ax.set_xlim(c[0] - span, c[0] + span)
        ax.set_ylim(c[1] - span, c[1] + span)
        ax.set_zlim(c[2] - 0.25, c[2] + 0.25)
        ax.set_box_aspect((1, 1, 0.5 / (2 * span)))
        ax.view_init(elev=28, azim=-55)
        ax.set_xlabel("x [m]")
        ax.set_ylabel("y [m]")
        ax.set_title(f"{title}  t = {times[k]:.2f} s", fontsize=9)
        return []

    anim = animation.FuncAnimation(fig, draw, frames=len(frames), blit=False)
    anim.save(path, writer=writer)
    plt.close(fig)

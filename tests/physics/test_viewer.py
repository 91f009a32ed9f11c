"""play.py through Newton's viewers on CPU: a headless ViewerGL video (Mesa's software OpenGL through EGL) decoded
back and looked at, a USD recording opened with pxr, Newton's own recording replayed, and one-line errors."""

import ctypes.util
import importlib.util
import os
import subprocess
import sys

import numpy as np
import pytest

from hexnewton.physics.viewer import TORSO_COLOR, check_viewer_args, default_viewer, draw_caption

ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), "..", ".."))
# a short fixed-CPG rollout on flat ground: 2 robots, 24 control steps, a frame every 2nd step -> 12 frames
ROLLOUT = ["--controller", "cpg", "--terrain", "flat", "--num_envs", "2", "--steps", "24", "--video_speed", "2",
           "--device", "cpu", "--no-progress"]  # fmt: skip
FRAMES = 12


def _gl_missing() -> str | None:
    """Why headless OpenGL cannot run here (None when it can)."""
    if importlib.util.find_spec("pyglet") is None:
        return "pyglet is not installed (pip install -e '.[test]')"
    for lib in ("EGL", "GL"):
        if ctypes.util.find_library(lib) is None:
            return f"lib{lib} is missing: apt-get install libegl1 libegl-mesa0 libgl1-mesa-dri libgl1 (README, Tests)"
    return None


needs_gl = pytest.mark.skipif(_gl_missing() is not None, reason=f"no headless OpenGL: {_gl_missing()}")


def _play(*args: str, timeout: int = 300) -> subprocess.CompletedProcess:
    env = {k: v for k, v in os.environ.items() if k not in ("DISPLAY", "WAYLAND_DISPLAY")}
    return subprocess.run([sys.executable, "play.py", *args], capture_output=True, text=True, timeout=timeout,
                          cwd=ROOT, env=env)  # fmt: skip


def _decode(path) -> np.ndarray:
    """Every frame of an .mp4 as (T, H, W, 3) uint8, read back with imageio-ffmpeg's ffmpeg."""
    import imageio_ffmpeg

    reader = imageio_ffmpeg.read_frames(str(path))
    meta = next(reader)
    w, h = meta["size"]
    return np.stack([np.frombuffer(f, np.uint8).reshape(h, w, 3) for f in reader])


@pytest.mark.slow  # end to end: 15 s or more on a 2-core CPU
@needs_gl
def test_headless_video_shows_the_robots_moving(tmp_path):
    """ViewerGL headless -> .mp4: >= 10 frames, each with the robots' orange torsos on the ground and the caption,
    and the picture changes as they walk."""
    out = tmp_path / "walk.mp4"
    proc = _play(*ROLLOUT, "--headless", "--video", str(out))
    assert proc.returncode == 0, proc.stderr[-3000:]
    assert f"viewer gl: {FRAMES} frames in ViewerGL (headless), video written to" in proc.stdout, proc.stdout
    frames = _decode(out)
    assert len(frames) >= 10 and frames.shape[1:] == (540, 960, 3)
    torso = np.asarray(TORSO_COLOR) * 255
    for f in frames:
        assert f.std() > 20  # not one flat colour
        orange = np.abs(f.astype(float) - torso).max(axis=-1) < 60
        assert orange.sum() > 500, "no robot torso in the frame"  # the robots stand out from ground and sky
        assert f[:20, :60].mean() < 120 and f[5:15, 10:60].max() > 200  # the caption: white text on its dark band
    change = [np.abs(a.astype(int) - b.astype(int)).mean() for a, b in zip(frames[:-1], frames[1:])]
    assert min(change) > 0.05 and np.abs(frames[-1].astype(int) - frames[0].astype(int)).mean() > 1.0


@pytest.mark.slow  # end to end: 15 s or more on a 2-core CPU
@needs_gl
def test_headless_video_draws_the_goals(tmp_path):
    """Each shown robot's goal is drawn as a green point on the ground (GOAL_COLOR): the paper's goal 3.5 m ahead, or
    with ``--waypoints`` the course's first waypoint 0.76 m away (bigger in the picture), the rest of it white."""
    counts = []
    for extra in ([], ["--waypoints", "0.7,0.3", "1.2,-0.3"]):
        out = tmp_path / f"goals{len(extra)}.mp4"
        proc = _play(*ROLLOUT, "--headless", "--video", str(out), *extra)
        assert proc.returncode == 0, proc.stderr[-3000:]
        f = _decode(out)[-1].astype(int)
        green = (f[..., 1] > 150) & (f[..., 0] < 100) & (f[..., 2] < 120)
        counts.append(int(green.sum()))
    assert counts[0] > 50 and counts[1] > 2 * counts[0], counts


@pytest.mark.slow  # end to end: 15 s or more on a 2-core CPU
def test_usd_recording_opens_in_pxr(tmp_path):
    """--viewer usd --out: the same rollout as a USD stage that pxr opens, one time sample per frame, the first robot's
    torso walking forward (+x) over them."""
    pytest.importorskip("pxr", reason="usd-core is not installed (pip install -e '.[test]')")
    from pxr import Usd, UsdGeom

    out = tmp_path / "walk.usda"
    proc = _play(*ROLLOUT, "--viewer", "usd", "--out", str(out))
    assert proc.returncode == 0, proc.stderr[-3000:]
    assert f"viewer usd: {FRAMES} frames to {out}" in proc.stdout
    stage = Usd.Stage.Open(str(out))
    assert stage is not None and stage.GetEndTimeCode() - stage.GetStartTimeCode() + 1 == FRAMES
    torso = UsdGeom.Xformable(stage.GetPrimAtPath("/root/model/shapes/shape_0/instance_0"))
    x = [torso.ComputeLocalToWorldTransform(t).ExtractTranslation()[0] for t in (0, FRAMES - 1)]
    assert 0.03 < x[1] - x[0] < 0.5, x


@pytest.mark.slow  # end to end: 15 s or more on a 2-core CPU
def test_file_recording_replays(tmp_path):
    """--viewer file --out: Newton's own recording loads back (ViewerFile) with the model and every frame."""
    from newton.viewer import ViewerFile

    out = tmp_path / "walk.json"
    proc = _play(*ROLLOUT, "--viewer", "file", "--out", str(out))
    assert proc.returncode == 0, proc.stderr[-3000:]
    replay = ViewerFile(str(out))
    replay.load_recording()
    assert replay.has_model() and replay.get_frame_count() == FRAMES


@pytest.mark.parametrize("args, message", [
    (["--video", "walk.avi"], "a video must be a .mp4 file"),
    (["--viewer", "usd"], "--viewer usd records to a file: give --out PATH.usd"),
    (["--viewer", "usd", "--out", "walk.mp4"], "a usd recording must be a .usd or .usda or .usdc file"),
    (["--viewer", "gl", "--out", "walk.usd"], "--out is the file of a recording"),
    (["--viewer", "usd", "--out", "walk.usd", "--video", "walk.mp4"], "--video renders through ViewerGL"),
    (["--viewer", "gl"], "there is no display"),
    (["--viewer", "vulkan"], "invalid choice"),
    (["--viewer", "usd", "--out", "/nonexistent-dir/walk.usd"], "cannot write"),
])  # fmt: skip
def test_bad_viewer_flags_are_one_line(args, message):
    proc = _play(*args, "--device", "cpu")
    err = [line for line in proc.stderr.splitlines() if line.strip() and "Warp CUDA" not in line]
    assert proc.returncode == 2 and len(err) == 1 and message in err[0], proc.stderr


def test_viewer_choice_and_caption(monkeypatch):
    monkeypatch.delenv("DISPLAY", raising=False)
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    assert default_viewer(None, None) == "null" and default_viewer("a.mp4", None) == "gl"
    assert default_viewer(None, "a.usdc") == "usd" and default_viewer(None, "a.rrd") == "rerun"
    check_viewer_args("gl", True, "a.mp4", None)
    frame = np.full((240, 320, 3), 90, np.uint8)
    out = draw_caption(frame, ["task complex", "t = 1.00 s"])
    assert out.shape == frame.shape and (out != frame).any() and (out[120:] == frame[120:]).all()


@needs_gl
def test_training_clips_at_an_interval(tmp_path):
    """train.py --video's env: a clip of ``length`` steps from the first step of every ``interval``-th iteration,
    named by iteration; everything else reads and writes the wrapped env."""
    import torch

    from hexnewton.learning.policy import fixed_cpg_actions
    from hexnewton.mdp.env import make_env
    from hexnewton.physics.viewer import VideoEnv
    from hexnewton.tasks import course

    env = make_env(course("flat", None, {}, 2, "cpu", 0, seed=0), "cpg")
    videos = VideoEnv(env, str(tmp_path / "videos"), interval=2, length=3, steps_per_iteration=2, width=320,
                      height=240)  # fmt: skip
    videos.first_iteration = 10  # a resumed run
    videos.episode_length_buf = torch.zeros_like(env.episode_length_buf)
    assert videos.episode_length_buf is env.episode_length_buf and videos.num_envs == 2
    actions = fixed_cpg_actions(env)
    with torch.inference_mode():
        for _ in range(8):  # iterations 10..13: clips at 10 (steps 0-2) and 12 (steps 4-6)
            videos.step(actions)
    videos.close()
    assert [os.path.basename(c) for c in videos.clips] == ["iteration_10.mp4", "iteration_12.mp4"]
    for clip in videos.clips:
        frames = _decode(clip)
        assert frames.shape == (3, 240, 320, 3) and frames.std() > 20

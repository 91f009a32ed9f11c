"""The browser viewer in a real browser: ``play.py --viewer viser`` on the CPU, its page loaded in headless Chromium
(Selenium driving the system's Chromium and ChromeDriver), screenshots a few seconds apart: the robots are drawn
(pixels change as they walk, the robots' orange torsos and the terrain's sand are on the page). It runs on its own
(``HEXNEWTON_BROWSER_TEST=1``, after the suite: .ci/run and the README); without Chromium, ChromeDriver, Selenium or
viser it skips, saying which is missing (CI installs them: .ci/run)."""

import importlib.util
import os
import queue
import shutil
import socket
import subprocess
import sys
import threading
import time

import numpy as np
import pytest

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser") or shutil.which("google-chrome")
CHROMEDRIVER = shutil.which("chromedriver")
#: RGB ranges of the terrain's sand and the robots' orange torsos as the page shades them (viewer.GROUND_COLOR, ...)
SAND, ORANGE = ((95, 85, 65), (235, 225, 205)), ((150, 70, 0), (255, 175, 90))
#: the 3D view below the browser's notices and left of viser's panel (whose text changes with the time)
SCENE = np.s_[160:, :460]


def _lines(proc) -> queue.Queue:
    """``proc``'s stdout lines as a thread reads them (None at its end): a ``select`` on the pipe would miss the lines
    that an earlier ``readline`` left in the file's buffer (viser's banner and the address can come in one read)."""
    lines: queue.Queue = queue.Queue()

    def read():
        for line in proc.stdout:
            lines.put(line)
        lines.put(None)

    threading.Thread(target=read, daemon=True).start()
    return lines


def _drain(lines: queue.Queue) -> list[str]:
    """The lines read so far (without waiting for more)."""
    out = []
    while True:
        try:
            line = lines.get_nowait()
        except queue.Empty:
            return out
        if line is None:
            return out
        out.append(line)


def _helper():
    """scripts/browser_screenshot.py (headless Chromium through Selenium), loaded by path."""
    spec = importlib.util.spec_from_file_location("browser_screenshot",
                                                  os.path.join(ROOT, "scripts", "browser_screenshot.py"))
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def _missing() -> str | None:
    if os.environ.get("HEXNEWTON_BROWSER_TEST") != "1":
        return ("the browser test runs on its own, not beside the other tests (software WebGL on a busy 2-core machine "
                "falls behind): HEXNEWTON_BROWSER_TEST=1 python -m pytest -n 0 tests/apps/test_browser_viewer.py")
    for what, ok in (("chromium", CHROMIUM), ("chromedriver", CHROMEDRIVER),
                     ("selenium", importlib.util.find_spec("selenium")), ("viser", importlib.util.find_spec("viser"))):
        if not ok:
            return f"{what} is not installed (.ci/run installs the browser test's packages)"
    return None


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _wait_for_line(lines: queue.Queue, prefix: str, timeout: float) -> str:
    """The first line of ``lines`` (:func:`_lines`) that starts with ``prefix`` (what came before it on failure)."""
    seen, end = [], time.time() + timeout
    while time.time() < end:
        try:
            line = lines.get(timeout=1.0)
        except queue.Empty:
            continue
        if line is None:
            break
        seen.append(line)
        if line.startswith(prefix):
            return line
    raise AssertionError(f"no '{prefix}' line within {timeout} s:\n" + "".join(seen[-30:]))


def _share(img: np.ndarray, lo, hi) -> float:
    """The share of pixels whose RGB lies in [lo, hi] per channel."""
    return float(np.all((img >= lo) & (img <= hi), axis=-1).mean())


@pytest.mark.skipif(_missing() is not None, reason=str(_missing()))
def test_play_in_a_browser_draws_the_walking_robots(tmp_path):
    from selenium.common.exceptions import TimeoutException

    port = _free_port()  # 90000 steps: the page is served (in real time) until the test ends it
    cmd = [sys.executable, "play.py", "--controller", "cpg", "--terrain", "stepped", "--num_envs", "3", "--steps",
           "90000", "--device", "cpu", "--viewer", "viser", "--port", str(port), "--no-progress"]
    proc = subprocess.Popen(cmd, cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
                            env=dict(os.environ, PYTHONUNBUFFERED="1"))  # fmt: skip
    driver, lines = None, _lines(proc)
    try:
        line = _wait_for_line(lines, "viewer viser: open ", 600)
        url = line.split("open ", 1)[1].split()[0]
        assert url == f"http://127.0.0.1:{port}"
        helper = _helper()
        driver = helper.browser(800, 500)  # the stairs and a small page: software WebGL keeps up on a busy machine
        try:
            driver.get(url)
        except TimeoutException:  # a busy machine: the page goes on loading; the screenshots below tell
            pass
        deadline = time.time() + 300  # the client loads and receives the scene (slowly on a busy 2-core machine)
        first = helper.screenshot(driver).astype(int)
        while _share(first, *SAND) < 0.05 and time.time() < deadline:
            time.sleep(5)
            first = helper.screenshot(driver).astype(int)
        changed, deadline = 0.0, time.time() + 180  # the robots walk on (slowly on a busy machine)
        while changed <= 0.002 and time.time() < deadline:
            time.sleep(6)
            second = helper.screenshot(driver).astype(int)
            changed = float((np.abs(first - second)[SCENE].sum(axis=-1) > 30).mean())
        if changed <= 0.002 or _share(first, *SAND) < 0.05:  # what the browser showed, for the failure below
            from PIL import Image

            for name, img in (("first", first), ("second", second)):
                Image.fromarray(img.astype(np.uint8)).save(os.path.join(str(tmp_path), f"{name}.png"))
            print(f"screenshots in {tmp_path}; play.py: " + "".join(_drain(lines))[-2000:])
        assert changed > 0.002, f"the page did not change while the robots walked ({changed:.4f} of its pixels)"
        sand = max(_share(img, *SAND) for img in (first, second))
        orange = max(_share(img, *ORANGE) for img in (first, second))
        assert sand > 0.05, f"no terrain on the page ({sand:.4f} sand-coloured)"
        assert orange > 1e-4, f"no robot torso on the page ({orange:.5f} orange)"
    finally:
        if driver is not None:
            driver.quit()
        proc.terminate()
        try:
            proc.wait(timeout=30)
        except subprocess.TimeoutExpired:
            proc.kill()


def test_a_port_in_use_is_one_line(capsys):
    """viser itself would block on a port it cannot bind: the command says so at once."""
    from hexnewton.apps.cli import run
    from hexnewton.apps.play import main

    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        s.listen()
        port = s.getsockname()[1]
        assert run(main, "python play.py", ["--viewer", "viser", "--port", str(port), "--device", "cpu"]) == 2
    err = capsys.readouterr().err
    assert f"127.0.0.1:{port} is in use" in err and len(err.strip().splitlines()) == 1


@pytest.mark.slow  # end to end: 15 s or more on a 2-core CPU
def test_training_draws_its_first_robots_for_the_browser(tmp_path, capsys):
    """train.py --viewer viser: the page's address, the warning that every interface listens, frames drawn every
    --viewer_stride control steps of the training robots."""
    from hexnewton.apps.cli import run
    from hexnewton.apps.train import main

    pytest.importorskip("viser")
    argv = ["--task", "flat", "--num_envs", "4", "--max_iterations", "1", "--device", "cpu", "--log_dir",
            str(tmp_path), "--viewer", "viser", "--viewer_stride", "6", "--robots_shown", "2", "--host", "0.0.0.0",
            "--port", str(_free_port()), "--agent.validation_rounds", "0"]  # fmt: skip
    assert run(main, "python train.py", argv) == 0
    out = capsys.readouterr().out
    assert "viewer viser: open http://localhost:" in out and "listening on every interface (0.0.0.0)" in out
    assert "viewer viser: 4 frames of the training robots drawn" in out  # 24 control steps, every 6th


def test_viser_flags_are_checked_before_any_simulation():
    from hexnewton.physics.viewer import check_viewer_args, default_viewer

    pytest.importorskip("viser")
    assert default_viewer(None, "walk.viser") == "viser"
    check_viewer_args("viser", False, None, "walk.viser", port=_free_port())
    check_viewer_args("viser", False, None, None, port=_free_port())
    for args, msg in ((("viser", False, None, "walk.usd"), "a viser recording must be a .viser file"),
                      (("viser", False, "walk.mp4", None), "--video renders through ViewerGL"),
                      (("null", False, None, "walk.viser"), "--out is the file of a recording")):
        with pytest.raises(ValueError, match=msg):
            check_viewer_args(*args)

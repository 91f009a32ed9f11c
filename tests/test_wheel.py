"""A non-editable install works from any directory: ``pip install .`` into a fresh virtual environment (the system's
packages seen, so nothing is downloaded), then ``hexnewton-play`` from a temporary folder plays the policy the wheel
carries (``hexnewton/assets/``, package data), never the source tree's. Slow (a build and a rollout, over a minute on a
2-core CPU): ``python -m pytest -q -m slow tests/test_wheel.py``."""

import os
import shutil
import subprocess
import sys

import pytest

pytestmark = pytest.mark.slow

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def test_installed_wheel_plays_the_shipped_policy_from_any_directory(tmp_path):
    venv, work, src = tmp_path / "venv", tmp_path / "work", tmp_path / "src"
    work.mkdir()
    # built from a copy of the package's sources (pip builds in the tree it is given: no build/ left in this one)
    shutil.copytree(ROOT, src, symlinks=True, ignore=shutil.ignore_patterns(
        ".git", "studies", "results", "tests", "logs", "build", "dist", "*.egg-info", "__pycache__", ".*cache"))
    # without a pip of its own: the system's pip, setuptools and wheel (seen through --system-site-packages) install
    # into it; the venv's bundled setuptools would lack bdist_wheel
    subprocess.run([sys.executable, "-m", "venv", "--system-site-packages", "--without-pip", str(venv)], check=True, timeout=300)
    pip = subprocess.run([str(venv / "bin" / "python"), "-m", "pip", "install", "-q", "--no-deps",
                          "--no-build-isolation", "--no-warn-script-location", str(src)], capture_output=True, text=True,
                         timeout=600, cwd=work)  # fmt: skip
    assert pip.returncode == 0, pip.stdout[-2000:] + pip.stderr[-3000:]
    env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}  # the installed package, not this tree
    where = subprocess.run([str(venv / "bin" / "python"), "-c", "import hexnewton; print(hexnewton.__file__)"],
                           capture_output=True, text=True, timeout=120, cwd=work, env=env)  # fmt: skip
    assert where.returncode == 0 and where.stdout.strip().startswith(str(venv)), where.stdout + where.stderr
    proc = subprocess.run([str(venv / "bin" / "hexnewton-play"), "--steps", "200", "--num_envs", "2", "--device", "cpu",
                           "--viewer", "null", "--no-progress", "--log_dir", str(work / "no_logs")],
                          capture_output=True, text=True, timeout=900, cwd=work, env=env)  # fmt: skip
    assert proc.returncode == 0, proc.stdout[-2000:] + proc.stderr[-3000:]
    assert "cpg_rl_complex.pt" in proc.stdout and str(venv) in proc.stdout, proc.stdout[-2000:]
    assert "[cpg_rl (" in proc.stdout, proc.stdout[-2000:]

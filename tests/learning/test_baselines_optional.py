"""skrl is optional (pyproject.toml's ``baselines`` extra; the ``test`` extra keeps it, so the baselines' own tests run):
nothing in the package imports it before a baseline is built, and without it the baselines' command, or a baseline
checkpoint played, says in one line what to install (exit status 2). A missing skrl is simulated by
``sys.modules["skrl"] = None``, which makes every ``import skrl`` fail as an absent package does."""

import json
import os
import subprocess
import sys
import tomllib

import pytest

from hexnewton.errors import HexnewtonError

ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), "..", ".."))
INSTALL = 'pip install -e ".[baselines]"'

#: runs argv[1] (a command module) with argv[2:] and skrl missing; prints its exit status and stderr as JSON
PROBE = """
import contextlib, io, json, runpy, sys
sys.modules["skrl"] = None
module, argv = sys.argv[1], sys.argv[2:]
sys.argv = [module, *argv]
err, code = io.StringIO(), 0
with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(err):
    try:
        runpy.run_module(module, run_name="__main__", alter_sys=True)
    except SystemExit as exc:
        code = exc.code
print(json.dumps({"code": code, "stderr": err.getvalue(), "skrl": sys.modules.get("skrl") is not None}))
"""


def _without_skrl(module: str, *argv: str) -> dict:
    proc = subprocess.run([sys.executable, "-c", PROBE, module, *argv], capture_output=True, text=True, cwd=ROOT,
                          timeout=300)  # fmt: skip
    assert proc.returncode == 0, proc.stderr[-3000:]
    return json.loads(proc.stdout.strip().splitlines()[-1])


def test_the_baselines_command_without_skrl_says_what_to_install(tmp_path):
    out = _without_skrl("hexnewton.apps.baselines", "--algo", "sac", "--num_envs", "2", "--device", "cpu",
                        "--log_dir", str(tmp_path))  # fmt: skip
    lines = out["stderr"].strip().splitlines()
    assert out["code"] == 2 and len(lines) == 1 and "Traceback" not in out["stderr"], out
    assert lines[0].startswith("python -m hexnewton.apps.baselines: error: ") and INSTALL in lines[0], lines
    assert not os.listdir(tmp_path), "nothing is built or written before the check"


def test_the_baselines_help_needs_no_skrl():
    out = _without_skrl("hexnewton.apps.baselines", "--algo", "sac", "--help")
    assert out["code"] == 0 and out["stderr"] == "", out


def test_no_module_of_the_package_imports_skrl_at_import_time():
    """Every module of hexnewton imports with skrl missing (a module failing for another optional package, ROS 2's
    rclpy, is not this test's: only errors that name skrl count)."""
    code = """
import importlib, json, pkgutil, sys
sys.modules["skrl"] = None
import hexnewton
bad = []
for m in pkgutil.walk_packages(hexnewton.__path__, "hexnewton."):
    try:
        importlib.import_module(m.name)
    except Exception as exc:
        if "skrl" in repr(exc):
            bad.append(f"{m.name}: {exc!r}")
print(json.dumps(bad))
"""
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=ROOT, timeout=600)
    assert proc.returncode == 0, proc.stderr[-3000:]
    assert json.loads(proc.stdout.strip().splitlines()[-1]) == []


def test_building_a_baseline_without_skrl_is_one_line(monkeypatch):
    """What play.py and evaluate reach with a baseline checkpoint (the agent, its networks, the env adapter)."""
    from hexnewton.learning.baselines import agent_config, make_agent, make_models, require_skrl, wrap_env

    monkeypatch.setitem(sys.modules, "skrl", None)
    for build in (require_skrl, lambda: make_agent("sac", agent_config("sac", "scale"), None, None, "cpu", 1),
                  lambda: make_models("td3", agent_config("td3", "scale"), None, None, "cpu"), lambda: wrap_env(None)):
        with pytest.raises(HexnewtonError) as exc:
            build()
        assert INSTALL in str(exc.value) and "\n" not in str(exc.value)


def test_skrl_is_an_extra():
    with open(os.path.join(ROOT, "pyproject.toml"), "rb") as f:
        project = tomllib.load(f)["project"]
    assert not any(d.startswith("skrl") for d in project["dependencies"])
    extras = project["optional-dependencies"]
    assert "skrl==2.1.*" in extras["baselines"] and "skrl==2.1.*" in extras["test"]

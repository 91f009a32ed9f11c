"""``--robot NAME|FILE`` on every command line: a bad robot file (a leg missing, a leg of two joints, a continuous
joint, no such file) is one stderr line and exit status 2 from each; a policy on another robot than its own is one
line too (it names ``train.py --init``); the fixed CPG walks another robot in play.py."""

import importlib
import os
import subprocess
import sys

import pytest

from hexnewton.apps.cli import run

ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), "..", ".."))
POLICY = os.path.join(ROOT, "results", "policies", "cpg_rl_complex.pt")
BUNDLE = os.path.join(ROOT, "results", "controllers", "cpg_rl_complex")
#: each command line with --robot, before it builds anything: (module, its other arguments)
COMMANDS = {
    "train": ["--num_envs", "2", "--max_iterations", "1", "--device", "cpu"],
    "play": ["--controller", "cpg", "--steps", "1", "--num_envs", "1", "--viewer", "null"],
    "evaluate": ["--controllers", "cpg", "--rounds", "1", "--terrains", "flat"],
    "export": ["--checkpoint", POLICY],
    "sim2sim": [BUNDLE, "--rounds", "1"],
    "bench": ["--device", "cpu", "--num_envs", "1", "--terrain", "flat"],
    "baselines": ["--algo", "sac", "--task", "flat", "--num_envs", "2", "--total_steps", "2", "--device", "cpu"],
}


def _bad_urdf(tmp_path, case: str) -> str:
    """A copy of the MX-Phoenix's URDF with one fault (``case``), or a path that does not exist."""
    import xml.etree.ElementTree as ET

    from hexnewton.robot.mx_phoenix import URDF

    root = ET.parse(URDF).getroot()
    joints = {j.get("name"): j for j in root.iter("joint")}
    if case == "missing leg":
        for e in [e for e in root if e.get("name", "").startswith("lm_")]:
            root.remove(e)
    elif case == "two-joint leg":
        joints["rm_tibia_joint"].set("type", "fixed")
    elif case == "continuous joint":
        joints["lf_femur_joint"].set("type", "continuous")
        joints["lf_femur_joint"].remove(joints["lf_femur_joint"].find("limit"))
    else:
        return str(tmp_path / "nowhere.urdf")
    path = tmp_path / f"{case.replace(' ', '_')}.urdf"
    ET.ElementTree(root).write(path)
    return str(path)


SAYS = {"missing leg": "found 5 legs", "two-joint leg": "has 2 revolute joints",
        "continuous joint": "is continuous", "bad path": "robot file not found"}


def _run(name: str, argv: list[str], out: str, capsys) -> tuple[int, list[str]]:
    module = importlib.import_module(f"hexnewton.apps.{name}")
    if name in ("evaluate", "export", "sim2sim"):
        argv = argv + ["--out", out]
    if name == "baselines":
        argv = argv + ["--log_dir", out]
    code = run(module.main, f"hexnewton-{name}", argv)
    return code, capsys.readouterr().err.strip().splitlines()


@pytest.mark.parametrize("case", list(SAYS))
@pytest.mark.parametrize("name", list(COMMANDS))
def test_bad_robot_file_is_one_line_and_exit_2(tmp_path, capsys, name, case):
    if name == "baselines":
        pytest.importorskip("skrl")  # the baselines extra
    argv = COMMANDS[name] + ["--robot", _bad_urdf(tmp_path, case)]
    code, err = _run(name, argv, str(tmp_path / "out"), capsys)
    assert code == 2 and len(err) == 1 and SAYS[case] in err[0], err
    assert not os.path.exists(tmp_path / "out")


@pytest.mark.parametrize("name", ["play", "evaluate", "export", "sim2sim"])
def test_a_policy_on_another_robot_is_one_line(tmp_path, capsys, name):
    argv = {"play": ["--checkpoint", POLICY, "--steps", "1", "--viewer", "null"],
            "evaluate": ["--controllers", "cpg", "cpg_rl", "--checkpoint", f"cpg_rl={POLICY}", "--rounds", "1"],
            "export": ["--checkpoint", POLICY], "sim2sim": [BUNDLE, "--rounds", "1"]}[name]
    code, err = _run(name, argv + ["--robot", "mx_phoenix"], str(tmp_path / "out"), capsys)
    assert code == 2 and len(err) == 1, err
    assert "trained on robot paper, not mx_phoenix" in err[0], err
    assert ("--init" in err[0]) == (name != "sim2sim"), err  # train.py --init takes a checkpoint, not a bundle


def test_resume_keeps_its_robot_and_robot_joints_need_a_file(tmp_path, capsys):
    code, err = _run("train", ["--resume", POLICY, "--robot", "mx_phoenix"], "", capsys)
    assert code == 2 and len(err) == 1, err
    code, err = _run("play", ["--controller", "cpg", "--robot_joints", *["j"] * 18], "", capsys)
    assert code == 2 and err == ["hexnewton-play: error: --robot_joints names the joints of a --robot FILE"], err
    code, err = _run("play", ["--controller", "cpg", "--robot", "phantom"], "", capsys)
    assert code == 2 and "unknown robot 'phantom': choose one of paper, mx_phoenix" in err[0], err


def test_play_walks_the_second_robot_with_the_fixed_cpg():
    """``python play.py --robot mx_phoenix --controller cpg``: 4 s on flat ground, no episode ends."""
    proc = subprocess.run([sys.executable, "play.py", "--robot", "mx_phoenix", "--controller", "cpg", "--num_envs", "2",
                           "--steps", "200", "--viewer", "null", "--no-progress"], capture_output=True, text=True,
                          cwd=ROOT, timeout=600)  # fmt: skip
    assert proc.returncode == 0, proc.stderr[-2000:]
    assert "first episodes ended: none" in proc.stdout, proc.stdout

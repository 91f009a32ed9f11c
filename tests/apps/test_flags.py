"""Every command line's flags are spelt out in full (hexnewton/apps/cli.py's ArgumentParser, ``allow_abbrev=False``):
an abbreviated or misspelt flag never runs as another one (``python train.py --num_env 4`` once trained with
``--num_envs 4`` through argparse's prefix matching); it is one stderr line naming the closest flag, exit status 2, no
traceback, and it goes before any other usage error (a required flag's)."""

import argparse
import glob
import importlib
import os
import subprocess
import sys

import pytest

from hexnewton.apps.cli import ArgumentParser, unknown_flag

ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), "..", ".."))

#: (command module, argv, the flag it names, the flag it suggests)
CASES = [
    ("train", ["--num_env", "4"], "--num_env", "--num_envs"),
    ("train", ["--task", "rugged", "--max_iter=3"], "--max_iter", "--max_iterations"),
    ("train", ["--env.reward.w_tlt", "10"], "--env.reward.w_tlt", "--env.reward.w_tilt"),
    ("train", ["--agent.algorithm.learning_rat", "5e-4"], "--agent.algorithm.learning_rat",
     "--agent.algorithm.learning_rate"),
    ("play", ["--num_env", "4", "--steps", "10"], "--num_env", "--num_envs"),
    ("play", ["--checkpont", "x.pt"], "--checkpont", "--checkpoint"),
    ("evaluate", ["--terrains", "rugged", "--round", "8"], "--round", "--rounds"),
    ("export", ["--checkpoin", "x.pt", "--out", "bundle"], "--checkpoin", "--checkpoint"),
    ("export", ["--out", "bundle", "--steps", "3", "--checkpiont", "x.pt"], "--checkpiont", "--checkpoint"),
    ("deploy", ["bundle", "--tol", "1e-3"], "--tol", "--tolerance"),
    ("sim2sim", ["bundle", "--round", "3"], "--round", "--rounds"),
    ("bench", ["--num_env", "16"], "--num_env", "--num_envs"),
    ("ros", ["robot", "bundle", "--round", "3"], "--round", "--rounds"),
    ("ros", ["node", "bundle", "--stat", "s.json"], "--stat", "--stats"),
    ("baselines", ["--algo", "sac", "--num_env", "4"], "--num_env", "--num_envs"),
    ("baselines", ["--alg", "sac"], "--alg", "--algo"),
    ("curves", ["run", "--label", "a"], "--label", "--labels"),
]


def _answer(module: str, argv: list[str], capsys) -> tuple[int, str]:
    """(exit status, stderr) of ``python -m hexnewton.apps.<module> ARGV``, in this process (parsing comes first)."""
    from hexnewton.apps.cli import run

    main = importlib.import_module(f"hexnewton.apps.{module}").main
    try:
        code = run(main, module, argv)
    except SystemExit as exc:
        code = exc.code
    return code, capsys.readouterr().err


@pytest.mark.parametrize("module,argv,flag,suggested", CASES, ids=[f"{c[0]}{c[2]}" for c in CASES])
def test_an_unknown_flag_is_one_line_naming_the_closest(module, argv, flag, suggested, capsys):
    code, err = _answer(module, argv, capsys)
    lines = err.strip().splitlines()
    assert code == 2 and len(lines) == 1 and "Traceback" not in err, err
    assert lines[0].endswith(f": error: unknown flag {flag} (did you mean {suggested}?)"), err


def test_python_train_py_num_env_fails_before_training():
    """The issue's command, as a user types it: one line, exit status 2, at once."""
    proc = subprocess.run([sys.executable, "train.py", "--num_env", "4"], capture_output=True, text=True, cwd=ROOT,
                          timeout=300)  # fmt: skip
    assert proc.returncode == 2 and proc.stdout == "", proc.stdout[-2000:]
    assert proc.stderr == "python train.py: error: unknown flag --num_env (did you mean --num_envs?)\n", proc.stderr


def test_every_parser_of_the_package_is_the_strict_one():
    """No command line builds argparse's own parser (which prefix-matches): each is cli.ArgumentParser, whose
    subcommands inherit it."""
    for path in glob.glob(os.path.join(ROOT, "hexnewton", "**", "*.py"), recursive=True):
        text = open(path).read()
        assert "argparse.ArgumentParser(" not in text and "ArgumentParser as " not in text, path
    assert ArgumentParser().allow_abbrev is False
    sub = ArgumentParser(prog="p").add_subparsers(dest="c").add_parser("node")
    assert isinstance(sub, ArgumentParser) and sub.allow_abbrev is False


def test_a_flag_is_never_a_prefix_of_another():
    p = ArgumentParser(prog="p")
    p.add_argument("--num_envs", type=int)
    with pytest.raises(SystemExit):
        p.parse_args(["--num_env", "4"])
    assert p.parse_args(["--num_envs", "4"]).num_envs == 4
    assert p.parse_args(["--num_envs=-4"]).num_envs == -4  # values, negative ones too, are no flags


def test_the_message():
    known = ["-h", "--help", "--num_envs", "--steps", "--env.reward.w_tilt"]
    assert unknown_flag("--num", known) == "unknown flag --num (did you mean --num_envs?)"  # an abbreviation
    assert unknown_flag("--stpes=3", known) == "unknown flag --stpes (did you mean --steps?)"
    assert unknown_flag("--zzzz", known) == "unknown flag --zzzz (--help lists the flags)"


def test_other_usage_errors_stay_as_argparse_words_them(capsys):
    p = ArgumentParser(prog="p")
    p.add_argument("--n", type=int, required=True)
    for argv, says in ((["--n", "x"], "invalid int value"), ([], "required: --n"), (["--n", "1", "extra"],
                                                                                      "unrecognized arguments: extra")):
        with pytest.raises(SystemExit) as exc:
            p.parse_args(argv)
        assert exc.value.code == 2 and says in capsys.readouterr().err
    q = ArgumentParser(prog="q")  # an option that takes the rest of the line (ros node --ros-args -p NAME:=VALUE)
    q.add_argument("--ros-args", nargs=argparse.REMAINDER, default=[])
    assert q.parse_args(["--ros-args", "-p", "a:=1"]).ros_args == ["-p", "a:=1"]
    with pytest.raises(SystemExit):
        q.parse_args(["--ros-arg"])
    assert "unknown flag --ros-arg (did you mean --ros-args?)" in capsys.readouterr().err

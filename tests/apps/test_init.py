"""``train.py --init POLICY.pt``: the actor and its observation normaliser start from another policy (here the shipped
flat policy, a Gaussian one, on the MX-Phoenix), the critic new and learning alone for
``--agent.init_critic_iterations`` iterations, then both; the run records where it started; a policy of other shapes,
another distribution or beside ``--resume`` is one error line."""

import glob
import os

import pytest
import torch

from hexnewton.apps import train
from hexnewton.apps.cli import run

ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), "..", ".."))
FLAT = os.path.join(ROOT, "results", "policies", "cpg_rl_flat.pt")
COMPLEX = os.path.join(ROOT, "results", "policies", "cpg_rl_complex.pt")
TINY = ["--num_envs", "4", "--device", "cpu", "--agent.validation_rounds", "0", "--no-build_beside_imports"]


def _same(a: dict, b: dict) -> bool:
    return a.keys() == b.keys() and all(torch.equal(a[k].cpu(), b[k].cpu()) for k in a)


def test_init_starts_the_actor_and_the_critic_learns_first(tmp_path, capsys):
    code = run(train.main, "python train.py", ["--robot", "mx_phoenix", "--init", FLAT, "--max_iterations", "3",
                                                "--agent.init_critic_iterations", "2", "--agent.save_interval", "1",
                                                "--agent.distribution.name", "gaussian", "--log_dir", str(tmp_path),
                                                *TINY])  # fmt: skip
    out = capsys.readouterr().out
    assert code == 0, out[-2000:]
    assert f"started from {FLAT}: its actor and observation normaliser, a new critic; the critic learns alone for 2 " \
           "iterations, then both" in out and "iteration 2: the actor learns from here on" in out
    run_dir = glob.glob(str(tmp_path / "hexnewton_flat_mx_phoenix" / "*"))[0]
    init = torch.load(FLAT, map_location="cpu", weights_only=True)["actor_state_dict"]
    saved = {k: torch.load(os.path.join(run_dir, f"model_{k}.pt"), map_location="cpu", weights_only=True)
             for k in (0, 1, 2)}  # fmt: skip
    assert _same(saved[0]["actor_state_dict"], init) and _same(saved[1]["actor_state_dict"], init)
    assert not _same(saved[2]["actor_state_dict"], init)  # the actor learns from iteration 2 on
    assert not _same(saved[0]["critic_state_dict"], saved[1]["critic_state_dict"])  # the critic from the first
    meta = saved[2]["infos"]["hexnewton"]
    assert meta["robot"] == "mx_phoenix" and meta["init"]["checkpoint"] == FLAT and meta["init"]["robot"] == "paper"
    assert meta["config"]["robot"]["name"] == "mx_phoenix" and meta["config"]["task"]["height_scale"] > 1.6


@pytest.mark.parametrize("argv, says", [
    (["--init", COMPLEX], "expects 62 observations; this environment has 59"),
    (["--init", FLAT, "--resume", FLAT], "--init starts a new run from a policy, --resume continues a run"),
    (["--init", FLAT], "acts through a gaussian distribution, this run through a beta one"),
    (["--init", os.path.join(ROOT, "results", "policies")], "--init"),
])  # fmt: skip
def test_bad_init_is_one_line(tmp_path, capsys, argv, says):
    code = run(train.main, "python train.py", argv + ["--max_iterations", "1", "--log_dir", str(tmp_path), *TINY])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1 and says in err[0], err

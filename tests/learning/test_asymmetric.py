"""The asymmetric critic and the actor's gyro and last actions end to end on the CPU (``--env.obs.*``): train.py trains
with them, its critic reading the groups ``policy`` and ``critic``; the checkpoints record them; validation and export
run the actor in envs without the critic group; the bundle replays through the runtime and walks closed loop in C
MuJoCo, its gyro read from the MJCF's sensor; a resume that would change the critic's inputs is one clear error."""

import contextlib
import glob
import io
import json
import os

import numpy as np
import pytest
import torch

from hexnewton.mdp.terms import CRITIC_DIM

SWITCHES = ["--env.obs.gyro", "true", "--env.obs.last_action", "true", "--env.obs.critic", "true"]
NUM_OBS = 59 + 3 + 15  # the paper's, the gyro, the last actions


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    """Two iterations of the flat task with every switch on, 8 robots, validation on 2 rounds of 10 steps."""
    from hexnewton.apps import train

    logs = tmp_path_factory.mktemp("asymmetric")
    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        code = train.main(["--task", "flat", "--num_envs", "8", "--device", "cpu", "--max_iterations", "2",
                           "--agent.num_steps_per_env", "8", "--agent.validation_rounds", "2",
                           "--agent.validation_steps", "10", "--log_dir", str(logs), *SWITCHES])  # fmt: skip
    assert code == 0, out.getvalue()[-2000:]
    (run_dir,) = glob.glob(str(logs / "hexnewton_flat" / "*"))
    return run_dir, out.getvalue()


def test_training_with_the_asymmetric_critic(run):
    """The actor reads the policy group (77 inputs), the critic the policy and critic groups (77 + 106); the
    checkpoints record the switches; validation chose a result and the exported ONNX policy takes 77 inputs."""
    import onnx

    run_dir, out = run
    ckpt = torch.load(os.path.join(run_dir, "model_1.pt"), weights_only=True)
    assert ckpt["infos"]["hexnewton"]["config"]["obs"] == {"gyro": True, "last_action": True, "critic": True}
    assert ckpt["infos"]["hexnewton"]["num_obs"] == NUM_OBS
    assert ckpt["actor_state_dict"]["mlp.0.weight"].shape[1] == NUM_OBS
    assert ckpt["critic_state_dict"]["mlp.0.weight"].shape[1] == NUM_OBS + CRITIC_DIM["cpg"]
    train_cfg = json.load(open(os.path.join(run_dir, "config.json")))["train"]
    assert train_cfg["obs_groups"] == {"actor": ["policy"], "critic": ["policy", "critic"]}
    assert "deterministic validation, 2 rounds of the flat course" in out and "the result: " in out
    model = onnx.load(os.path.join(run_dir, "policy.onnx"))
    assert model.graph.input[0].type.tensor_type.shape.dim[1].dim_value == NUM_OBS


def test_a_resume_keeps_the_critic_inputs(run):
    from hexnewton.apps import train

    run_dir, _ = run
    with pytest.raises(ValueError, match=f"critic reads {NUM_OBS + CRITIC_DIM['cpg']} values; this environment gives "
                                         f"it {NUM_OBS}"):  # fmt: skip
        train.main(["--resume", os.path.join(run_dir, "model_1.pt"), "--num_envs", "2", "--device", "cpu",
                    "--max_iterations", "1", "--log_dir", os.path.join(run_dir, "resumed"), "--env.obs.critic",
                    "false"])  # fmt: skip


def test_the_new_actor_deploys_and_walks_in_mujoco(run, tmp_path):
    """The result exported as a bundle (its layout ends with the gyro and the last actions), replayed by the runtime
    within 1e-4, then closed loop in C MuJoCo for a few steps: the runtime reads the MJCF's gyro and keeps the
    actions it gave."""
    from hexnewton.analysis.sim2sim import Rounds
    from hexnewton.apps import export
    from hexnewton.deploy.runtime import replay

    run_dir, _ = run
    bundle = str(tmp_path / "bundle")
    with contextlib.redirect_stdout(io.StringIO()):
        assert export.main(["--checkpoint", os.path.join(run_dir, "model_result.pt"), "--out", bundle, "--steps", "20",
                            "--robots", "2"]) == 0  # fmt: skip
    spec = json.load(open(os.path.join(bundle, "controller.json")))
    assert spec["num_obs"] == NUM_OBS and [row[0] for row in spec["obs_layout"]][-2:] == ["gyro", "last_action"]
    assert {"gyro", "last_action"} <= set(spec["obs_notes"])
    r = replay(bundle)
    assert r["steps"] > 0 and r["max_obs_diff"] < 1e-4 and r["max_target_diff_rad"] < 1e-4
    pytest.importorskip("mujoco")
    rounds = Rounds(bundle, "flat", 2)
    seen = []
    for _ in range(15):
        rounds.control_step()
        seen.append(rounds.sensors()["gyro"])
    assert np.isfinite(rounds.d.qpos).all() and np.abs(np.asarray(seen)).max() > 1e-3
    assert np.abs(rounds.ctrl.last_actions).max() > 0 and (np.abs(rounds.ctrl.last_actions) <= 1).all()

"""The environment on another robot than the paper's: the MX-Phoenix (hexnewton.robot.mx_phoenix, 1.6 times the
paper robot's legs, 1.7 times its mass) stands and walks with the fixed CPG, its heights observed as the paper robot's
read; its robot file does the same; a config whose robot scales are not its robot's is one error line."""

import dataclasses

import numpy as np
import pytest
import torch

from hexnewton.config import HexConfig, SimConfig, TerrainConfig
from hexnewton.errors import HexnewtonError
from hexnewton.mdp.env import make_env
from hexnewton.robot import stand_height
from hexnewton.robot.mx_phoenix import URDF
from hexnewton.robot.registry import ROBOTS, resolve_robot, with_robot

STEPS = 250  # 5 s of 20 ms control steps


def _walk(robot, steps: int = STEPS):
    cfg = with_robot(HexConfig(sim=SimConfig(num_envs=2, device="cpu"), terrain=TerrainConfig(name="flat")), robot)
    env = make_env(dataclasses.replace(cfg, task=dataclasses.replace(cfg.task, reset_yaw=0.0)), "cpg")
    fixed = torch.as_tensor(np.tile(cfg.cpg.fixed_params(), (2, 1)), dtype=torch.float32)
    lo, hi = (torch.as_tensor(b, dtype=torch.float32) for b in cfg.cpg.param_ranges())
    actions = 2.0 * (fixed - lo) / (hi - lo) - 1.0
    x0 = env.world.joint_q[:, 0].clone()
    ended, z = 0, []
    for _ in range(steps):
        obs, _, done, _ = env.step(actions)
        ended += int(done.sum())
        z.append(env.world.joint_q[:, 2].clone())
    return env, obs["policy"], float((env.world.joint_q[:, 0] - x0).min()), ended, torch.stack(z[steps // 2:])


@pytest.mark.parametrize("robot", ["mx_phoenix", "urdf"])
def test_second_robot_walks_with_the_fixed_cpg(robot):
    """5 s on flat ground: no episode ends, the torso at its standing height (within 15 %), more than 1 m walked; the
    observed target height reads as the paper robot's standing one (-0.13 m), the torso standing 0.22 m high."""
    r = ROBOTS["mx_phoenix"] if robot == "mx_phoenix" else resolve_robot(URDF)
    env, obs, walked, ended, z = _walk(r)
    assert ended == 0 and walked > 1.0, (ended, walked)
    assert float((z - stand_height(r)).abs().max()) < 0.15 * stand_height(r)
    target_col = 36 + 2  # the target's z (layout cpg: 18 + 18 joint columns, then target x, y, z)
    assert float(obs[:, target_col].mean()) == pytest.approx(-0.13, abs=0.012)
    assert env.cfg.task.height_scale == pytest.approx(stand_height(r) / stand_height(ROBOTS["paper"]))


def test_robot_scales_are_checked():
    cfg = dataclasses.replace(HexConfig(sim=SimConfig(num_envs=1, device="cpu")), robot=ROBOTS["mx_phoenix"])
    with pytest.raises(HexnewtonError, match="not robot mx_phoenix's"):
        make_env(cfg, "cpg")

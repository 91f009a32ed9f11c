"""A golden CPU rollout: a few tasks' envs (flat; complex with the terrain curriculum, randomisation and the body
posture; the joint action mode on stairs; Table 1's reward), stepped with fixed seeded actions, must give the
observations, rewards, reward terms, episode statuses and done flags stored in ``golden_rollout.npz`` bit for bit.

The episodes are short and the end thresholds tight, so every kind of episode end, the resets, the curriculum's lane
changes and the pushes happen within the rollout. Regenerate the file (only for a change meant to alter the step):
``HEXNEWTON_WRITE_GOLDEN=1 python -m pytest -q -n 0 tests/mdp/test_golden.py``.

The bits depend on the simulator packages and, since Warp compiles the CPU kernels for the host, on the processor's
vector instructions: the file records both (:func:`platform_key`). Where the key matches, the rollout must repeat the
file bit for bit; elsewhere its floats must agree within a float32 tolerance (:data:`RTOL`, :data:`ATOL`) and its
statuses and done flags exactly. ``test_tolerance_path`` takes the second path on every machine."""

import dataclasses
import os
import platform
from importlib.metadata import version

import numpy as np
import pytest
import torch

from hexnewton.mdp.env import make_env
from hexnewton.tasks import task

PATH = os.path.join(os.path.dirname(os.path.abspath(__file__)), "golden_rollout.npz")
#: the float32 tolerance of a machine whose platform key differs from the file's: a few thousand ulps of the rollout's
#: largest values, far below any change the step is meant to make
RTOL, ATOL = 1e-4, 1e-5
NUM_ENVS, STEPS = 4, 20
#: name: (task, its env's changes {section: {field: value}})
CASES = {
    "flat": ("flat", {"task": dict(max_episode_steps=12, goal_distance=0.52, max_tilt=0.03, max_abs_y=0.004)}),
    "complex": ("complex", {"task": dict(max_episode_steps=12, max_tilt=0.06, max_joint_speed=30.0),
                            "randomization": dict(push_interval=0.1)}),
    "joint_stairs": ("complex-joint", {"task": dict(max_episode_steps=10, min_height=0.105, max_tilt=0.15),
                                       "terrain": dict(name="stepped", levels=3, start_levels=2)}),
    "paper": ("paper", {"task": dict(max_episode_steps=10, max_abs_y=0.01, max_joint_speed=17.0),
                        "terrain": dict(name="flat")}),
}


def platform_key() -> str:
    """The packages and the processor features the rollout's bits depend on."""
    packages = ", ".join(f"{name} {version(name)}" for name in ("warp-lang", "newton", "mujoco-warp", "numpy"))
    flags = set()
    if os.path.exists("/proc/cpuinfo"):
        with open("/proc/cpuinfo") as f:
            flags = set(next((line.split(":", 1)[1].split() for line in f if line.startswith("flags")), []))
    return f"{packages}; {platform.machine()} {' '.join(sorted(flags & {'avx2', 'avx512f', 'fma'}))}"


def _config(name: str):
    task_name, changes = CASES[name]
    t = task(task_name)
    cfg = dataclasses.replace(t.env, sim=dataclasses.replace(t.env.sim, num_envs=NUM_ENVS, device="cpu"))
    for section, fields in changes.items():
        cfg = dataclasses.replace(cfg, **{section: dataclasses.replace(getattr(cfg, section), **fields)})
    return cfg, t.action_mode


def rollout(name: str) -> dict[str, np.ndarray]:
    """``STEPS`` control steps of case ``name`` with seeded actions in [-1.5, 1.5] (some clamped)."""
    cfg, mode = _config(name)
    env = make_env(cfg, mode)
    rng = np.random.default_rng(sum(map(ord, name)))
    out = {"obs0": env.get_observations()["policy"].numpy()}
    rows = []
    for _ in range(STEPS):
        actions = torch.from_numpy(rng.uniform(-1.5, 1.5, (NUM_ENVS, env.num_actions)).astype(np.float32))
        obs, rew, done, extras = env.step(actions)
        rows.append((obs["policy"].numpy(), rew.numpy(), env.terms.numpy().copy(), env.status.numpy().copy(),
                     done.numpy(), extras["time_outs"].numpy()))
    for key, values in zip(("obs", "reward", "terms", "status", "done", "time_out"), zip(*rows)):
        out[key] = np.stack(values)
    return out


@pytest.mark.skipif(os.environ.get("HEXNEWTON_WRITE_GOLDEN") != "1", reason="writes the golden file")
def test_write_golden():
    arrays = {f"{name}/{key}": value for name in CASES for key, value in rollout(name).items()}
    np.savez_compressed(PATH, platform=np.array(platform_key()), **arrays)


def check_golden(name: str, got: dict[str, np.ndarray], golden, exact: bool) -> None:
    """``got`` (case ``name``'s rollout) against the file: bit for bit where ``exact``, else floats within
    ``RTOL``/``ATOL`` and every other array exactly (same keys and dtypes either way)."""
    assert sorted(got) == sorted(k.split("/", 1)[1] for k in golden.files if k.startswith(name + "/"))
    for key, value in got.items():
        want = golden[f"{name}/{key}"]
        assert value.dtype == want.dtype and value.shape == want.shape, f"{name}/{key}: {value.dtype} {value.shape}"
        if exact or not np.issubdtype(value.dtype, np.floating):
            assert np.array_equal(value, want, equal_nan=True), f"{name}/{key} differs"
        else:
            close = np.isclose(value, want, rtol=RTOL, atol=ATOL, equal_nan=True)
            worst = np.nanmax(np.abs(value.astype(np.float64) - want)) if value.size else 0.0
            beyond = np.count_nonzero(~close)
            assert close.all(), f"{name}/{key}: {beyond} values beyond the tolerance (max |diff| {worst:.3g})"


@pytest.mark.parametrize("name", list(CASES))
def test_rollout_matches_golden(name):
    """Bit for bit on the file's platform; within the float32 tolerance on any other."""
    golden = np.load(PATH)
    check_golden(name, rollout(name), golden, exact=str(golden["platform"]) == platform_key())


def test_tolerance_path():
    """The comparison of another platform, taken here on purpose: the flat case's rollout passes within the tolerance;
    the file's floats moved by a few ulps pass, by far more than the tolerance fail, and a changed status fails."""
    golden = np.load(PATH)
    got = rollout("flat")
    check_golden("flat", got, golden, exact=False)
    noisy = {k: golden[f"flat/{k}"] for k in got}
    noisy.update({k: np.nextafter(np.nextafter(v, np.inf), np.inf) for k, v in noisy.items() if v.dtype.kind == "f"})
    check_golden("flat", noisy, golden, exact=False)
    with pytest.raises(AssertionError, match="differs"):
        check_golden("flat", noisy, golden, exact=True)
    reward = noisy["reward"]
    moved = dict(noisy, reward=reward + np.float32(100 * ATOL) + np.abs(reward) * np.float32(10 * RTOL))
    with pytest.raises(AssertionError, match="flat/reward: .* beyond the tolerance"):
        check_golden("flat", moved, golden, exact=False)
    status = noisy["status"].copy()
    status.flat[0] += 1
    with pytest.raises(AssertionError, match="flat/status differs"):
        check_golden("flat", dict(noisy, status=status), golden, exact=False)

"""The frame profile's bookkeeping on the CPU: activity names to kernels, kernels to the stack's parts."""

import importlib.util
import os

import pytest

pytestmark = pytest.mark.slow

spec = importlib.util.spec_from_file_location("frame_profile", os.path.join(os.path.dirname(__file__),
                                                                             "frame_profile.py"))  # fmt: skip
fp = importlib.util.module_from_spec(spec)
spec.loader.exec_module(fp)


def test_an_activity_name_gives_its_kernel():
    assert fp.kernel_key("forward kernel hopf_step_kernel_1a2b3c4d") == "hopf_step_kernel"
    assert fp.kernel_key("forward kernel _update_gradient_grad__locals__kernel_6b3af6f7") == \
        "_update_gradient_grad__locals__kernel"  # fmt: skip
    assert fp.kernel_key("forward kernel no_hash") == "no_hash"


def test_each_module_has_its_part():
    assert fp.part_of("mujoco_warp._src.solver") == "solver (MuJoCo-Warp)"
    assert fp.part_of("newton._src.geometry.narrow_phase") == "collision (Newton)"
    assert fp.part_of("newton._src.solvers.mujoco.kernels") == "solver glue (Newton's MuJoCo solver)"
    assert fp.part_of("hexnewton.kernels.cpg") == "CPG and mapping (hexnewton.physics)"
    assert fp.part_of("hexnewton.mdp.terms.rewards") == "MDP terms (hexnewton.mdp)"
    assert fp.part_of("somewhere.else") == "other"


def test_the_phases_are_the_control_steps_calls_in_its_order():
    """PHASES names HexapodEnv._control_step's calls as the step makes them: a phase renamed or added there fails
    here."""
    import inspect
    import re

    from hexnewton.mdp.env import HexapodEnv

    body = inspect.getsource(HexapodEnv._control_step)
    assert tuple(re.findall(r"self\.(_\w+)\(", body)) == fp.PHASES


def test_the_loaded_kernels_name_their_modules():
    import hexnewton.kernels.cpg  # noqa: F401  (its kernels)

    modules = fp.kernel_modules()
    ours = {m for m in modules.values() if m.startswith("hexnewton.kernels")}
    assert ours, "no hexnewton.kernels kernel found among the live wp.Kernel objects"


def test_without_a_gpu_it_says_so_in_one_line(capsys):
    import warp as wp

    if wp.is_cuda_available():
        pytest.skip("a GPU is present")
    assert fp.main(["--out", "/tmp/unused_profile"]) == 2
    assert capsys.readouterr().err.count("\n") == 1

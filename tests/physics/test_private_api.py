"""The private names of Warp, Newton and mujoco_warp that hexnewton uses (hexnewton/physics/private_api.py) exist in
the installed versions: an upgrade that moves one fails here, naming the package, its version and the name."""

import importlib
from importlib.metadata import version

import pytest

from hexnewton.physics import private_api

PACKAGES = {"warp": "warp-lang", "newton": "newton", "mujoco_warp": "mujoco-warp"}
MODULES = sorted(set(private_api.STEP_MODULES + private_api.SOLVER_MODULES + private_api.NARROW_PHASE_SOURCES
                     + (private_api.CONTACT_REDUCTION,)))  # fmt: skip


def _moved(name: str, exc: Exception) -> str:
    package = PACKAGES[name.split(".")[0]]
    return (f"{name} is not in {package} {version(package)} ({type(exc).__name__}: {exc}): "
            "hexnewton/physics/private_api.py needs its new name")  # fmt: skip


@pytest.mark.parametrize("name", MODULES)
def test_private_module_exists(name):
    try:
        importlib.import_module(name)
    except ImportError as exc:
        pytest.fail(_moved(name, exc))


@pytest.mark.parametrize("func, name", [(private_api.warp_user_modules, "warp._src.context.user_modules"),
                                        (private_api.warp_started, "warp._src.context.runtime"),
                                        (private_api.export_reduced_contacts_block_dim,
                                         "newton._src.geometry.contact_reduction_global"),
                                        (private_api.mesh_watertight_flag,
                                         "newton._src.geometry.flags.MeshProperties.WATERTIGHT")])  # fmt: skip
def test_private_name_exists(func, name):
    try:
        value = func()
    except (ImportError, AttributeError) as exc:
        pytest.fail(_moved(name, exc))
    assert isinstance(value, {"warp._src.context.user_modules": dict, "warp._src.context.runtime": bool}.get(name, int))


def test_warp_struct_type_is_what_wp_struct_makes():
    import warp as wp

    try:
        struct_type = private_api.WarpStruct
    except (ImportError, AttributeError) as exc:
        pytest.fail(_moved("warp._src.codegen.Struct", exc))

    @wp.struct
    class Pair:
        a: wp.float32
        b: wp.int32

    assert isinstance(Pair, struct_type) and wp.types.type_is_struct(Pair)
    assert private_api.warp_struct_type() is struct_type
    with pytest.raises(AttributeError, match="no attribute 'Nothing'"):
        private_api.Nothing  # noqa: B018


def test_reduction_overflow_is_the_contacts_own_flag():
    """Newton's ``Contacts`` keeps the contact reduction's overflow flag (one int32, cleared with the counters)."""
    import newton
    import warp as wp

    contacts = newton.Contacts(4, 0, device="cpu")
    try:
        flag = private_api.reduction_overflow(contacts)
    except AttributeError as exc:
        pytest.fail(_moved("newton._src.sim.contacts.Contacts._reduction_overflow", exc))
    assert isinstance(flag, wp.array) and flag.dtype == wp.int32 and flag.shape == (1,)
    assert int(flag.numpy()[0]) == 0


def test_a_moved_name_fails_with_one_clear_line():
    exc = ImportError("No module named 'newton._src.sim.collide'")
    line = _moved("newton._src.sim.collide", exc)
    assert "\n" not in line and f"newton {version('newton')}" in line and "private_api.py" in line


def test_mesh_boundary_flags_are_timed_where_the_builder_finds_them():
    """Newton's ``compute_mesh_boundary_flags`` is where ``ModelBuilder.finalize`` imports it from at finalize time;
    timed, a call of it is counted, and Newton's own comes back."""
    import inspect

    import numpy as np
    import warp as wp

    try:
        module = importlib.import_module(private_api.MESH_BOUNDARY_FLAGS)
        real = module.compute_mesh_boundary_flags
        builder = importlib.import_module("newton._src.sim.builder")
    except (ImportError, AttributeError) as exc:
        pytest.fail(_moved(private_api.MESH_BOUNDARY_FLAGS + ".compute_mesh_boundary_flags", exc))
    assert "from ..geometry.sdf_contact import compute_mesh_boundary_flags" in inspect.getsource(builder), \
        f"newton {version('newton')}'s ModelBuilder.finalize no longer imports it from sdf_contact"  # fmt: skip
    seconds: list = []
    assert private_api.time_mesh_boundary_flags(seconds) is real
    try:
        points = wp.array(np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0]], np.float32), dtype=wp.vec3, device="cpu")
        mesh = wp.Mesh(points=points, indices=wp.array(np.array([0, 1, 2], np.int32), device="cpu"))
        module.compute_mesh_boundary_flags(mesh)
    finally:
        private_api.untime_mesh_boundary_flags(real)
    assert len(seconds) == 1 and module.compute_mesh_boundary_flags is real
    assert private_api.mesh_boundary_flags(mesh).any()  # one triangle: every edge open

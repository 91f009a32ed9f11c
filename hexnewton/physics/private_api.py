"""Every private name of Warp, Newton and mujoco_warp that hexnewton's physics uses, in one place: none of the three
has a public API for these. ``tests/physics/test_private_api.py`` imports each of them and fails, naming the package
and its version, when an upgrade moves one.

- the Python modules that define the Warp modules a step and the solver's set-up launch (``newton._src``,
  ``mujoco_warp._src`` and ``warp._src`` module names), which :mod:`hexnewton.physics.precompile` compiles ahead;
- Warp's registry of modules (:func:`warp_user_modules`) and whether Warp has started (:func:`warp_started`);
- the block size of Newton's contact reduction export (:func:`export_reduced_contacts_block_dim`);
- the flag Newton's contact reduction raises when it drops candidates (:func:`reduction_overflow`; ``Contacts``
  keeps it as one slot of ``contact_counters``, whose layout it does not document);
- Warp's struct type (``WarpStruct``, :func:`warp_struct_type`), for the MDP's configuration structs: ``wp.struct``
  makes one, ``warp.types.type_is_struct`` tests for one, no public name holds the class;
- Newton's mesh boundary flags, which ``ModelBuilder.finalize`` computes for each mesh shape: the studies time them
  (:func:`time_mesh_boundary_flags`; studies/startup_mesh, studies/navigate), the terrain tests read them for a
  mesh (:func:`mesh_boundary_flags`), and the bit of a mesh shape's properties that marks it watertight, so that
  ``finalize`` skips them (:func:`mesh_watertight_flag`).

What each name is for is said where it is used (``precompile.py``, ``device.py``, ``world.py``,
``mdp/terms/structs.py``)."""

from __future__ import annotations

#: Warp modules (defined at import time) that a World's step launches, as listed by a CPU run
STEP_MODULES = (
    "newton._src.geometry.broad_phase_nxn", "newton._src.geometry.bvh", "newton._src.geometry.narrow_phase",
    "newton._src.sim.articulation", "newton._src.sim.collide", "newton._src.solvers.mujoco.kernels",
    "mujoco_warp._src.constraint", "mujoco_warp._src.derivative", "mujoco_warp._src.forward",
    "mujoco_warp._src.passive", "mujoco_warp._src.set_const", "mujoco_warp._src.smooth",
    "mujoco_warp._src.solver", "mujoco_warp._src.support", "newton._src.geometry.contact_reduction_global",
)  # fmt: skip
#: Warp modules (defined at import time) that building the MuJoCo solver launches
SOLVER_MODULES = ("mujoco_warp._src.smooth", "mujoco_warp._src.set_const", "newton._src.solvers.mujoco.kernels",
                  "warp._src.coloring")  # fmt: skip
#: Newton's collision modules whose generated kernels its narrow phase launches with its own block sizes on CUDA
NARROW_PHASE_SOURCES = ("newton._src.geometry.narrow_phase", "newton._src.geometry.contact_reduction_global")
CONTACT_REDUCTION = "newton._src.geometry.contact_reduction_global"
#: Newton's module whose ``compute_mesh_boundary_flags`` ``ModelBuilder.finalize`` imports for each mesh shape
MESH_BOUNDARY_FLAGS = "newton._src.geometry.sdf_contact"


def warp_user_modules() -> dict:
    """Warp's registry of the modules defined so far, ``{module name: warp Module}``."""
    from warp._src.context import user_modules

    return user_modules


def warp_started() -> bool:
    """Whether ``wp.init()`` has run in this process (Warp's runtime exists)."""
    from warp._src import context

    return context.runtime is not None


def reduction_overflow(contacts):
    """Newton's flag (a Warp array of one int32) that a collision pass which filled ``contacts`` (a
    ``newton.Contacts``) sets when its global contact reduction dropped candidates."""
    return contacts._reduction_overflow


def warp_struct_type() -> type:
    """The class of Warp's struct types (what ``@wp.struct`` returns)."""
    from warp._src.codegen import Struct

    return Struct


def __getattr__(name: str):
    """``WarpStruct``: :func:`warp_struct_type`, imported when first named (``import hexnewton`` loads no Warp)."""
    if name == "WarpStruct":
        return warp_struct_type()
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def export_reduced_contacts_block_dim() -> int:
    """The block size Newton launches its contact reduction's export with on CUDA."""
    from newton._src.geometry.contact_reduction_global import EXPORT_REDUCED_CONTACTS_BLOCK_DIM

    return EXPORT_REDUCED_CONTACTS_BLOCK_DIM


def time_mesh_boundary_flags(seconds: list):
    """From now on every call of Newton's ``compute_mesh_boundary_flags`` (``ModelBuilder.finalize``, once per mesh
    shape) appends its CPU seconds to ``seconds``; returns Newton's own function (:func:`untime_mesh_boundary_flags`
    puts it back)."""
    import importlib
    import time

    module = importlib.import_module(MESH_BOUNDARY_FLAGS)
    real = module.compute_mesh_boundary_flags

    def timed(mesh):
        t = time.process_time()
        out = real(mesh)
        seconds.append(time.process_time() - t)
        return out

    module.compute_mesh_boundary_flags = timed
    return real


def mesh_boundary_flags(mesh):
    """Newton's seam analysis of a Warp mesh (``compute_mesh_boundary_flags``, what ``ModelBuilder.finalize`` runs for
    each mesh shape): its boundary flags, nonzero where an edge is open."""
    import importlib

    return importlib.import_module(MESH_BOUNDARY_FLAGS).compute_mesh_boundary_flags(mesh)


def mesh_watertight_flag() -> int:
    """The bit of a finalized model's per-mesh-shape properties that marks a watertight mesh (Newton's
    ``MeshProperties.WATERTIGHT``: ``finalize`` then skips the mesh's boundary flags)."""
    from newton._src.geometry.flags import MeshProperties

    return int(MeshProperties.WATERTIGHT)


def untime_mesh_boundary_flags(real) -> None:
    """Newton's ``compute_mesh_boundary_flags`` (what :func:`time_mesh_boundary_flags` returned) back in place."""
    import importlib

    importlib.import_module(MESH_BOUNDARY_FLAGS).compute_mesh_boundary_flags = real

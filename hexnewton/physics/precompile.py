"""Parallel compilation of the Warp modules a physics step launches, before the first step.

A physics step launches two kinds of Warp modules: those defined when their Python modules are imported
(``STEP_MODULES``, hexnewton's own) and the kernels that mujoco_warp generates for the model on first use
(closures of its kernel builders, one module each, created by the call that launches them). Both are compiled here,
on parallel threads, on CUDA (NVRTC) and on the CPU (LLVM) alike:

``precompile_solver(device)`` compiles, before the MuJoCo solver is built, the import-time modules its set-up
launches (building the solver keeps those compiled variants: tests/physics/test_world.py); ``precompile(device)``
compiles the import-time modules; ``precompile(device, solver, since)`` (``SimConfig.precompile`` "generated") also
the generated kernels; on CUDA, given the collision pipeline, Newton's generated narrow-phase kernels and contact
reduction at each block size it launches them with (each size is a variant of its own). ``precompile`` runs once the
solver and the collision pipeline exist (both create kernels for this model). First
mujoco_warp's ``step`` runs on a scratch ``Data`` of the solver's sizes whose world count reads 0, inside a graph
capture that is thrown away: every launch has an empty grid, which Warp returns from before loading the module, so
the generated kernels are created without being compiled (the same objects the real step takes from mujoco_warp's
kernel cache: their builders' arguments are the model's and the sizes'), and the capture makes the solver's
iteration loop record its body once. Then the import-time modules and mujoco_warp's kernels created since ``since``
(:func:`live_kernel_ids`, taken before the model was built) that are not loaded yet are compiled together.

A module missing here only costs its compile time at the first step, never correctness: the first step compiles
whatever is not loaded.

Ahead of time: ``hexnewton/physics/aot/warp-<version>-sm<arch>.tar.xz`` holds the step's modules compiled for one GPU
architecture (sm_90: H100, H200), each a module folder of Warp's kernel cache (its ``.meta`` and cubin), built with
``scripts/precompile.py`` (its ship mode) from Warp's NVRTC without a GPU and from a GPU machine's cache.
:func:`install_shipped_modules` (each World, before any module loads) copies the folders Warp's cache lacks into it,
so that a fresh machine of that architecture compiles only what changed since (a module's folder name holds the hash
of its source and options: a stale one is never loaded, the module compiles as without the archive).
"""

from __future__ import annotations

import gc
import hashlib
import logging
import os
import pathlib
import shutil
import tarfile
import tempfile
from concurrent.futures import ThreadPoolExecutor

import warp as wp

from hexnewton.physics.private_api import (
    CONTACT_REDUCTION,
    NARROW_PHASE_SOURCES,
    SOLVER_MODULES,
    STEP_MODULES,
    export_reduced_contacts_block_dim,
    warp_user_modules,
)

log = logging.getLogger("hexnewton")

# STEP_MODULES: the Warp modules (defined at import time) that a World's step launches, as listed by a CPU run.
# SOLVER_MODULES: those that building the MuJoCo solver launches: mujoco_warp's set_const and smooth (the model's
# constants), Newton's MuJoCo conversion kernels, Warp's graph colouring. Compiled in parallel before it
# (:func:`precompile_solver`); building the solver compiled them one after another (23 s of a cold build on 2 CPU
# cores, where the parallel compile and the build take 19 s; a fresh H100 spent 54 s in the solver's set-up).
# NARROW_PHASE_SOURCES: Newton's collision modules whose generated kernels its narrow phase launches with its own block
# sizes on CUDA (NarrowPhase's block_dim, split_convex_block_dim, mesh_triangle_block_dim and the contact reducer's
# export size), and of the import-time modules the contact reduction (CONTACT_REDUCTION; at the narrow phase's block
# size and Warp's default; the import-time narrow phase itself only at the default): on a fresh H100 the first step
# compiled those variants one after another (146.8 s, studies/time_to_skill/report.md, "What a fresh machine
# compiles"). Their names are the packages' private module paths: hexnewton/physics/private_api.py holds them.

# Generated kernels that mujoco_warp launches with a block size of its model's ``block_dim`` settings (the field
# named here) rather than Warp's default; on CUDA each block size is a variant compiled of its own. Keyed by the
# kernel builder's name (mujoco_warp 3.17's smooth.py, constraint.py, solver.py). CPU launches use one thread per
# block whatever is asked.
TILED_BLOCK_DIMS = {
    "_small_cholesky_factorize_block": "small_cholesky", "_small_cholesky_solve_block": "small_cholesky",
    "_small_cholesky_factorize_solve_block": "small_cholesky", "_tile_cholesky_factorize_block": "cholesky_factorize",
    "_tile_cholesky_factorize_solve_block": "cholesky_factorize_solve", "_efc_contact_jac_dense": "contact_jac_tiled",
    "_efc_contact_jac_dense_flex": "contact_jac_tiled", "_solve_LD_sparse_fused": "solve_LD_sparse_fused",
    "_update_gradient_JTDAJ_dense_tiled": "update_gradient_JTDAJ_dense",
    "_update_gradient_JTDAJ_dense_tiled_compact": "update_gradient_JTDAJ_dense",
    "_update_gradient_cholesky": "update_gradient_cholesky",
    "_update_gradient_cholesky_blocked": "update_gradient_cholesky_blocked",
    "_cholesky_factorize_solve_blocked": "update_gradient_cholesky_blocked",
    "_update_gradient_grad": "update_gradient_grad", "_linesearch_iterative_kernel": "linesearch_iterative",
}  # fmt: skip


#: the archives of modules compiled ahead of time, one per Warp version and GPU architecture
SHIPPED_DIR = pathlib.Path(__file__).with_name("aot")


def shipped_archive_name(arch: int, version: str | None = None) -> str:
    """``warp-<version>-sm<arch>.tar.xz``: the archive of Warp ``version`` (default the running one) for ``arch``."""
    return f"warp-{version or wp.__version__}-sm{arch}.tar.xz"


def shipped_archive(device: str) -> pathlib.Path | None:
    """The shipped archive for ``device``: a CUDA device whose architecture has one for the running Warp and that loads
    cubins (Warp's default where the driver is older than its compiler; where it would emit PTX, cubin is chosen
    unless ``wp.config.cuda_output`` says otherwise, so that the archive applies); else None."""
    d = wp.get_device(device)
    if not d.is_cuda or not d.is_cubin_supported:
        return None
    path = SHIPPED_DIR / shipped_archive_name(d.arch)
    if not path.is_file():
        return None
    if d.get_cuda_output_format() != "cubin":
        if wp.config.cuda_output is not None:
            return None
        wp.config.cuda_output = "cubin"
    return path


def install_shipped_modules(device: str, archive: pathlib.Path | None = None, cache_dir: str | None = None) -> int:
    """Copy the module folders of ``archive`` (default :func:`shipped_archive` of ``device``) that ``cache_dir``
    (default Warp's kernel cache) lacks into it; returns how many. Once an archive's content is installed a marker file
    (``.hexnewton-<archive sha256>``) skips it on later starts. Each folder is unpacked beside the cache and renamed
    into place, as Warp writes its own, so that processes starting together never see half a module."""
    archive = archive or shipped_archive(device)
    if archive is None:
        return 0
    cache = pathlib.Path(cache_dir or wp.config.kernel_cache_dir)
    digest = hashlib.sha256(archive.read_bytes()).hexdigest()[:16]
    marker = cache / f".hexnewton-{digest}"
    if marker.exists():
        return 0
    cache.mkdir(parents=True, exist_ok=True)
    installed = 0
    with tempfile.TemporaryDirectory(dir=cache, prefix=".hexnewton-") as tmp, tarfile.open(archive) as tar:
        members = tar.getmembers()
        names = {m.name.split("/", 1)[0] for m in members}
        missing = {n for n in names if not (cache / n).exists()}
        tar.extractall(tmp, members=[m for m in members if m.name.split("/", 1)[0] in missing], filter="data")
        for name in sorted(missing):
            try:
                os.rename(os.path.join(tmp, name), cache / name)
                installed += 1
            except OSError:  # another process put it in place first
                shutil.rmtree(os.path.join(tmp, name), ignore_errors=True)
    marker.touch()
    log.info("installed %d of %d modules compiled ahead of time (%s)", installed, len(names), archive.name)
    return installed


def _workers(max_workers: int | None) -> int:
    return max_workers or os.cpu_count() or 1


def _live_kernels() -> list[wp.Kernel]:
    return [o for o in gc.get_objects() if type(o) is wp.Kernel]  # type(): no attribute lookups on lazy objects


def compiles_generated(setting: str, is_cuda: bool) -> bool:
    """``SimConfig.precompile``: whether a World also compiles the kernels mujoco_warp generates for its model
    (``"auto"``: on a CUDA device, where the first step would otherwise compile them one by one; on the CPU a cold
    2-core build is faster without)."""
    return setting == "generated" or (setting == "auto" and is_cuda)


def live_kernel_ids() -> set[int]:
    """The ids of the Warp kernels that exist now: :func:`precompile` compiles those created after."""
    return {id(k) for k in _live_kernels()}


def imported_modules() -> list[wp.Module]:
    """The Warp modules of ``STEP_MODULES`` and hexnewton's own that hold kernels."""
    return [m for m in list(warp_user_modules().values())
            if m.kernels and (m.name in STEP_MODULES or m.name.startswith("hexnewton."))]  # fmt: skip


def create_step_kernels(device: str, solver) -> bool:
    """Create, without compiling them, the kernels mujoco_warp generates for ``solver``'s model in a step (the
    module docstring); False (logged) if the dry step failed, which only leaves them to the first step."""
    import mujoco_warp

    data = solver.mjw_data
    try:
        with wp.ScopedDevice(device):
            scratch = mujoco_warp.put_data(solver.mj_model, solver.mj_data, nworld=1,
                                           nconmax=max(1, data.naconmax // max(1, data.nworld)),
                                           njmax=data.njmax)  # fmt: skip
            scratch.nworld = 0  # every per-world launch gets an empty grid: Warp creates, never loads, its kernel
            scratch.naconmax = 0  # the same for the per-contact launches
            with wp.ScopedCapture(force_module_load=False):
                mujoco_warp.step(solver.mjw_model, scratch)
    except Exception as exc:  # noqa: BLE001 - an optimisation only: the first step compiles what is missing
        log.warning("precompile: the dry step for mujoco_warp's generated kernels failed (%s: %s); they compile at "
                    "the first step", type(exc).__name__, exc)  # fmt: skip
        return False
    return True


def narrow_phase_block_dims(pipeline, device: str) -> tuple[int, ...]:
    """The block sizes ``pipeline``'s (a ``newton.CollisionPipeline``) narrow phase launches with on ``device`` besides
    Warp's default: none on the CPU, where a launch runs one thread per block."""
    narrow = getattr(pipeline, "narrow_phase", None)
    if narrow is None or not wp.get_device(device).is_cuda:
        return ()
    sizes = {getattr(narrow, name, None) for name in ("block_dim", "split_convex_block_dim", "mesh_triangle_block_dim")}
    return tuple(sorted(b for b in sizes | {export_reduced_contacts_block_dim()} if b))


def _block_dims(module: wp.Module, device: str, block_dims, narrow_dims: tuple[int, ...]) -> list[int | None]:
    """The block sizes ``module``'s launches ask for on ``device`` (None: Warp's default): a mujoco_warp tiled kernel
    its model's ``block_dim`` field; Newton's generated narrow-phase kernels and its contact reduction the default and
    each of ``narrow_dims``."""
    if not wp.get_device(device).is_cuda:
        return [None]
    kernels = list(module.kernels.values())
    generated_narrow = module.name not in NARROW_PHASE_SOURCES and any(k.func.__module__ in NARROW_PHASE_SOURCES
                                                                       for k in kernels)  # fmt: skip
    if narrow_dims and (module.name == CONTACT_REDUCTION or generated_narrow):
        return [None, *narrow_dims]
    if block_dims is not None:
        for kernel in kernels:
            builder = kernel.func.__qualname__.split(".<locals>")[0]
            if builder in TILED_BLOCK_DIMS:
                return [getattr(block_dims, TILED_BLOCK_DIMS[builder], None)]
    return [None]


def generated_modules(device: str, since: set[int]) -> list[wp.Module]:
    """The modules of mujoco_warp's kernels created after ``since`` and of the unique-module kernels of
    ``STEP_MODULES``' Python modules, those not loaded on ``device`` yet (kernels Newton creates for features this
    scene leaves unused stay out)."""
    context = wp.get_device(device).context
    named = {id(m) for m in imported_modules()}
    found: dict[int, wp.Module] = {}
    for kernel in _live_kernels():
        module = kernel.module
        if id(module) in named or any(ctx == context for ctx, _ in module.execs):
            continue
        source = kernel.func.__module__
        if (id(kernel) not in since and source.startswith("mujoco_warp.")) or source in STEP_MODULES:
            found[id(module)] = module
    return list(found.values())


def loaded_variants(device: str) -> set[tuple[str, int | None, int]]:
    """(module name, block size, module id) of every Warp module variant loaded on ``device`` now, the import-time
    modules and the generated kernels' own: taken before and after a step, the difference is what that step compiled
    (or took from Warp's cache)."""
    context = wp.get_device(device).context
    modules = {id(m): m for m in list(warp_user_modules().values())}
    modules.update({id(k.module): k.module for k in _live_kernels()})
    return {(m.name, block_dim, id(m)) for m in modules.values() for ctx, block_dim in list(m.execs) if ctx == context}


def variant_names(variants) -> list[str]:
    """Sorted readable names of :func:`loaded_variants` entries (``name`` or ``name@block_dim``)."""
    return sorted(name if block_dim is None else f"{name}@{block_dim}" for name, block_dim, _ in variants)


def _load(device: str, module: wp.Module, block_dim: int | None) -> None:
    wp.force_load(device=device, modules=[module], block_dim=block_dim, max_workers=0)


def compile_modules(device: str, jobs: list[tuple[wp.Module, int | None]], max_workers: int | None = None) -> None:
    """Compile and load each (module, block size) of ``jobs`` on ``device``, one thread each (default: one per CPU
    core); what Warp's cache holds is loaded from it. A job whose parallel load failed is loaded once more alone: one
    module's load can mark another modified while a thread hashes it (Warp 1.19's ``Module.load`` then raises
    ``KeyError`` on its cleared hashes, about 1 run in 12 of :func:`precompile_solver` on 2 CPU cores). A job that
    fails alone too is logged and left to the first launch, which compiles whatever is not loaded."""
    with ThreadPoolExecutor(max_workers=_workers(max_workers)) as pool:
        futures = [(m, b, pool.submit(_load, device, m, b)) for m, b in jobs]
    for module, block_dim, future in futures:
        if future.exception() is None:
            continue
        try:
            _load(device, module, block_dim)
        except Exception as exc:  # noqa: BLE001 - an optimisation only: the first launch compiles what is missing
            log.warning("precompile: %s (block size %s) did not load (%s: %s); it compiles at its first launch",
                        module.name, block_dim, type(exc).__name__, exc)  # fmt: skip


def precompile_solver(device: str, max_workers: int | None = None) -> list[str]:
    """Compile :data:`SOLVER_MODULES` on parallel threads before the MuJoCo solver is built (building it leaves their
    module hashes as they are, so the step reuses them); returns the module names."""
    import importlib

    for name in SOLVER_MODULES:
        importlib.import_module(name)
    user_modules = warp_user_modules()
    modules = [user_modules[name] for name in SOLVER_MODULES if name in user_modules]
    compile_modules(device, [(m, None) for m in modules], max_workers)
    return [m.name for m in modules]


def preload(device: str, max_workers: int | None = None) -> list[str]:
    """The modules a World loads whatever its model, loaded now: :data:`SOLVER_MODULES` (:func:`precompile_solver`)
    and :func:`imported_modules` at Warp's default block size (the variants :func:`precompile` also loads; the
    model's generated kernels and other block sizes wait for the solver and the collision pipeline). ``ModelBuild``
    runs it while Newton's finalize ends in its thread; returns the module names."""
    names = precompile_solver(device, max_workers)
    modules = imported_modules()
    compile_modules(device, [(m, None) for m in modules], max_workers)
    return names + [m.name for m in modules]


def precompile(device: str, solver=None, since: set[int] | None = None, max_workers: int | None = None,
               pipeline=None) -> list[str]:
    """Compile :func:`imported_modules` on parallel threads (default: one per CPU core); given ``solver``, first create
    mujoco_warp's generated step kernels (:func:`create_step_kernels`) and compile them and every other kernel created
    after ``since`` that is not loaded yet with them (``SimConfig.precompile`` "generated"); given ``pipeline`` (the
    collision pipeline), Newton's generated narrow-phase kernels and contact reduction also at the block sizes it
    launches them with. Returns the module names."""
    modules = imported_modules()
    if solver is not None:
        create_step_kernels(device, solver)
        modules += generated_modules(device, since or set())
    block_dims = getattr(solver.mjw_model, "block_dim", None) if solver is not None else None
    narrow_dims = narrow_phase_block_dims(pipeline, device) if pipeline is not None else ()
    compile_modules(device, [(m, b) for m in modules for b in _block_dims(m, device, block_dims, narrow_dims)],
                    max_workers)
    return [m.name for m in modules]

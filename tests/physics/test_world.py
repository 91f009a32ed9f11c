"""The batched world on CPU: standing on every terrain, walking on flat, overflow reporting, resets, torch views."""

import subprocess
import sys

import numpy as np
import pytest
import torch
import warp as wp

from hexnewton.config import TERRAINS, HexConfig, SimConfig, TerrainConfig
from hexnewton.errors import HexnewtonError
from hexnewton.kernels.cpg import CPGController
from hexnewton.physics.device import resolve_device
from hexnewton.robot import stand_height
from hexnewton.terrain import max_terrain_height_np
from hexnewton.physics.model_build import ModelBuild
from hexnewton.physics.world import ContactOverflowError, World, contacts_per_world

N = 4


def _world(terrain: str, collision: str = "mesh", **sim) -> World:
    return World(HexConfig(sim=SimConfig(num_envs=N, device="cpu", **sim),
                           terrain=TerrainConfig(name=terrain, collision=collision)))  # fmt: skip


def _upright(q: np.ndarray) -> np.ndarray:
    """z component of the torso's up axis, from quaternions (x, y, z, w)."""
    return 1.0 - 2.0 * (q[:, 3] ** 2 + q[:, 4] ** 2)


# the default physics (10 ms frame = 4 x 2.5 ms) and the 20 ms frame = 4 x 5 ms the shipped complex policy was
# trained under (studies/throughput/report.md): both must pass the stability checks
PHYSICS = [pytest.param({}, id="10ms"), pytest.param({"frame_dt": 0.02, "substeps": 4}, id="20ms")]
# a narrower contact band with Newton's speculative contacts (SimConfig.terrain_gap, speculative_gap)
SPECULATIVE = {"rigid_gap": 0.002, "terrain_gap": 0.0, "speculative_gap": 0.01}


# TerrainConfig.collision = "mesh_boxes" (boxes for the constant-height strips) on the terrains it changes most
MESH_BOXES = [pytest.param(t, {"collision": "mesh_boxes"}, id=f"{t}-mesh_boxes") for t in ("stepped", "complex")]


@pytest.mark.parametrize("physics", PHYSICS + [pytest.param(SPECULATIVE, id="speculative")])
@pytest.mark.parametrize("terrain, ground", [pytest.param(t, {}, id=t) for t in TERRAINS] + MESH_BOXES)
def test_stands_two_seconds(terrain, ground, physics):
    world = _world(terrain, **ground, **physics)
    frames = int(round(2.0 / world.frame_dt))
    lowest = np.full(N, np.inf)
    for _ in range(10):
        world.step(frames // 10)
        q = world.numpy_q()
        assert np.isfinite(q).all(), "NaN/Inf in the physics state"
        ground = max_terrain_height_np(world.terrain.grid, q[:, 0], q[:, 1], 0.5 * world.cfg.robot.torso_size[0])
        lowest = np.minimum(lowest, q[:, 2] - ground)
        assert (_upright(q) > 0.95).all(), f"robot tipped over on {terrain}"
    # torso (half height 2.5 cm) stays clear of the highest terrain under it, near the standing height
    assert (lowest > 0.06).all(), lowest
    assert world.sim_time == pytest.approx(2.0)
    assert world.check_contacts(on_overflow="raise").ok
    if terrain in ("flat", "stepped"):  # level ground under the robot: the exact standing height
        np.testing.assert_allclose(q[:, 2], stand_height(world.cfg.robot), atol=0.01)


@pytest.mark.parametrize("physics", PHYSICS + [pytest.param(SPECULATIVE, id="speculative")])
def test_tripod_walks_forward_on_flat(physics):
    world = _world("flat", **physics)
    world.set_controller(CPGController(world))  # the fixed tripod: 1.5 Hz, hip 0.3, knee 0.5, ankle 0.5
    x0 = world.base_pos().copy()
    world.step(int(3.0 / world.frame_dt))
    q = world.numpy_q()
    dx = q[:, 0] - x0[:, 0]
    assert (dx > 0.5).all(), dx  # ~0.24 m/s
    assert (np.abs(q[:, 1] - world.spawn_xy[:, 1]) < 0.1).all()
    assert (_upright(q) > 0.9).all()
    assert world.check_contacts(on_overflow="raise").ok


def test_tripod_walks_on_mesh_boxes_as_on_the_mesh():
    """The fixed tripod over the stepped terrain's run-up: its legs (too short a lift for 6 cm) stop at the first
    riser, the first box's side, just where they stop at the single mesh's wall (~0.32 m). No terrain part collides
    with another (static pairs are not candidates)."""
    dx = {}
    for collision in ("mesh", "mesh_boxes"):
        world = _world("stepped", collision=collision)
        world.set_controller(CPGController(world))
        x0 = world.base_pos().copy()
        world.step(int(2.0 / world.frame_dt))
        q = world.numpy_q()
        dx[collision] = q[:, 0] - x0[:, 0]
        assert (_upright(q) > 0.9).all() and world.check_contacts(on_overflow="raise").ok
        static = world.model.shape_body.numpy() < 0
        pairs = world.model.shape_contact_pairs.numpy()
        assert not (static[pairs[:, 0]] & static[pairs[:, 1]]).any()
    assert (dx["mesh_boxes"] > 0.3).all(), dx
    np.testing.assert_allclose(dx["mesh_boxes"], dx["mesh"], atol=0.005)


def test_speculative_contacts_narrow_the_band():
    """Standing on rugged blocks, the speculative settings find fewer contact candidates than the default band (two
    5 mm gaps), and bad gaps are one-line errors."""
    counts = {}
    for name, sim in (("default", {}), ("speculative", SPECULATIVE)):
        world = _world("rugged", **sim)
        world.step(50)
        counts[name] = int(world.contacts.rigid_contact_count.numpy()[0])
    assert 0 < counts["speculative"] < counts["default"], counts
    with pytest.raises(HexnewtonError, match="sim.speculative_gap must be a non-negative"):
        _world("flat", speculative_gap=-0.01)


def test_torch_views_are_zero_copy():
    world = _world("flat")
    target = world.joint_target
    assert target.shape == (N, 18) and world.joint_q.shape == (N, 25) and world.joint_qd.shape == (N, 24)
    target[:, 0] = 0.25  # R1 hip of every robot
    ctrl = world.control.joint_target_q.numpy().reshape(N, 25)
    assert np.all(ctrl[:, 7] == np.float32(0.25))
    world.step(40)
    assert torch.all(world.joint_q[:, 7] > 0.15)  # the hip followed the target written through torch


def test_overflow_is_reported_never_silent():
    world = _world("rugged", contacts_per_env=4, min_contact_pool=0, constraints_per_env=40)
    world.set_controller(CPGController(world))
    world.step(20)
    with pytest.warns(RuntimeWarning, match="overflowed"):
        report = world.check_contacts()
    assert not report.ok and report.worlds == N and world.overflow_frames == 20
    assert "raise sim." in report.describe() and "rigid_gap" in report.describe()  # the fix is in the warning
    world.step(5)
    with pytest.raises(ContactOverflowError, match="nconmax"):
        world.check_contacts(on_overflow="raise")


def test_contact_pool_holds_a_few_robots():
    """A few robots get a pool of at least ``min_contact_pool`` contacts (four on blocks took up to 274 against 4 x
    64); thousands keep ``contacts_per_env`` each; a negative pool is a one-line error."""
    sim = SimConfig()
    assert contacts_per_world(sim, 4) == 1024 and contacts_per_world(sim, 1) == 4096
    assert contacts_per_world(sim, 4096) == sim.contacts_per_env and contacts_per_world(sim, 100) == 64
    assert contacts_per_world(SimConfig(min_contact_pool=0), 4) == 64
    world = _world("flat")
    assert world.solver.get_max_contact_count() >= sim.min_contact_pool
    with pytest.raises(HexnewtonError, match="sim.min_contact_pool must be >= 0"):
        _world("flat", min_contact_pool=-1)


def test_nonfinite_env_is_reset_and_counted():
    world = _world("flat")
    world.step(10)
    q = world.joint_q
    q[1, 9] = float("nan")
    assert world.reset_nonfinite() == 1
    assert world.nonfinite_resets == 1
    assert torch.isfinite(world.joint_q).all()
    world.step(10)
    assert np.isfinite(world.numpy_q()).all()


def test_reset_restores_spawn_pose():
    world = _world("flat")
    world.set_controller(CPGController(world))
    world.step(100)
    mask = np.array([True, False, True, False])
    before = world.numpy_q().copy()
    world.reset(mask)
    after = world.numpy_q()
    spawn = np.column_stack([world.spawn_xy, world.spawn_z])
    assert np.allclose(after[mask, 0:3], spawn[mask])
    assert np.array_equal(after[~mask], before[~mask])
    body_q = world.state_0.body_q.numpy().reshape(N, -1, 7)
    assert np.allclose(body_q[mask, 0, :3], spawn[mask], atol=1e-6)  # FK refreshed


def test_envs_start_in_spread_lanes():
    world = _world("rugged")
    np.testing.assert_allclose(world.spawn_xy[:, 1], np.linspace(-0.5, 0.5, N))
    np.testing.assert_allclose(world.numpy_q()[:, :2], world.spawn_xy, atol=1e-6)


def test_model_built_beside_is_the_model_built_at_once():
    """train.py builds the terrain and the model in a thread beside its imports (ModelBuild(beside=True)): the world
    on it is the world built at once, the wait is the start-up phase "model build", the thread's phases a note."""
    from hexnewton import startup

    cfg = HexConfig(sim=SimConfig(num_envs=N, device="cpu"),
                    terrain=TerrainConfig(name="rugged", collision="mesh_boxes"))
    startup.restart()
    assert startup.phases() == {} and startup.notes() == {}
    build = ModelBuild(cfg, beside=True)
    beside = World(cfg, build=build)
    assert set(build.seconds) == {"terrain", "scene", "finalize"} and "model build" in startup.phases()
    assert "finalize" not in startup.phases()  # the thread's phases are a note, not phases of the command
    assert startup.notes()["model_build_beside_s"] == build.seconds
    at_once = World(cfg)
    np.testing.assert_array_equal(beside.numpy_q(), at_once.numpy_q())
    np.testing.assert_array_equal(beside.spawn_z, at_once.spawn_z)
    assert beside.model.shape_count == at_once.model.shape_count
    for w in (beside, at_once):
        w.set_controller(CPGController(w))
        w.step(20)
    np.testing.assert_allclose(beside.numpy_q(), at_once.numpy_q(), atol=1e-5)
    with pytest.raises(ValueError, match="another config"):
        World(HexConfig(sim=SimConfig(num_envs=N + 1, device="cpu")), build=build)


def test_model_build_with_the_scene_first_finalizes_beside():
    """scene_first (train.py's default): the terrain and the scene built at once, their phases the command's; only the
    finalize in the thread, its phase the note; the same world as built at once."""
    from hexnewton import startup

    cfg = HexConfig(sim=SimConfig(num_envs=N, device="cpu"),
                    terrain=TerrainConfig(name="rugged", collision="mesh_boxes"))
    startup.restart()
    build = ModelBuild(cfg, beside=True, scene_first=True)
    assert {"terrain", "scene"} <= set(startup.phases())
    beside = World(cfg, build=build)
    assert set(build.seconds) == {"finalize"} and startup.notes()["model_build_beside_s"] == build.seconds
    assert "model build" in startup.phases() and "finalize" not in startup.phases()
    at_once = World(cfg)
    np.testing.assert_array_equal(beside.numpy_q(), at_once.numpy_q())
    assert beside.model.shape_count == at_once.model.shape_count


def test_model_build_preloads_the_world_kernels_while_the_finalize_runs(monkeypatch):
    """preload_kernels (train.py's default): when the World takes the model while the finalize still runs, the
    modules it loads whatever its model are loaded meanwhile, as the phase "kernels beside the build"; off, never."""
    import threading

    from hexnewton import startup
    from hexnewton.physics import model_build

    cfg = HexConfig(sim=SimConfig(num_envs=N, device="cpu"), terrain=TerrainConfig(name="flat"))
    release, loaded, build_model = threading.Event(), [], model_build.ModelBuild._build

    def held_build(self):  # the finalize still running when the World takes the model
        release.wait(60)
        build_model(self)

    def preload(device):
        loaded.append(device)
        release.set()
        return ["a", "b"]

    monkeypatch.setattr(model_build.ModelBuild, "_build", held_build)
    monkeypatch.setattr(model_build, "preload", preload)
    for on in (True, False):
        startup.restart()
        release.clear()
        build = ModelBuild(cfg, beside=True, scene_first=True, preload_kernels=on)
        if not on:
            release.set()
        World(cfg, build=build)
        assert loaded == ["cpu"] and ("kernels beside the build" in startup.phases()) == on
        assert startup.notes().get("kernels_beside_build") == (2 if on else None)


def test_preload_loads_the_solver_and_step_modules():
    from hexnewton.physics.precompile import SOLVER_MODULES, imported_modules, preload
    from hexnewton.physics.private_api import warp_user_modules

    names = preload("cpu")
    assert names[: len(SOLVER_MODULES)] == list(SOLVER_MODULES)
    assert {m.name for m in imported_modules()} <= set(names)
    modules = warp_user_modules()
    assert all(modules[n].execs for n in names if modules[n].kernels)


@pytest.mark.parametrize("scene_first", [False, True])
def test_model_build_error_is_raised_where_the_world_takes_it(scene_first):
    bad = HexConfig(sim=SimConfig(num_envs=N, device="cpu"), terrain=TerrainConfig(name="rugged", block_size=-1.0))
    build = ModelBuild(bad, beside=True, scene_first=scene_first)  # the build fails; the process goes on
    with pytest.raises(ValueError):
        World(bad, build=build)


def test_device_resolution():
    assert resolve_device(None) == ("cuda:0" if wp.is_cuda_available() else "cpu")
    assert resolve_device("cpu") == "cpu"
    with pytest.raises(HexnewtonError, match="unknown device"):
        resolve_device("tpu")
    if not wp.is_cuda_available():
        with pytest.raises(HexnewtonError, match="no CUDA device"):
            resolve_device("cuda")


def test_bad_num_envs_raises():
    with pytest.raises(HexnewtonError, match="num_envs"):
        World(HexConfig(sim=SimConfig(num_envs=0, device="cpu")))


@pytest.mark.parametrize(
    "args, message",
    [
        (["--terrain", "moon"], "unknown terrain 'moon'"),
        (["--num_envs", "0"], "positive integer"),
        (["--num_envs", "-5"], "positive integer"),
        (["--device", "tpu"], "unknown device"),
        (["--env.terrain.collision", "voxels"], "'voxels' is not one of mesh, mesh_boxes, boxes"),
        (["--terrain", "stepped", "--env.terrain.step_depth", "0.255"], "step_depth"),
    ]
    + ([(["--device", "cuda"], "no CUDA device")] if not wp.is_cuda_available() else []),
)
def test_cli_bad_input_is_one_line(args, message):
    proc = subprocess.run([sys.executable, "-m", "hexnewton.apps.bench", *args], capture_output=True, text=True,
                          timeout=300)  # fmt: skip
    assert proc.returncode == 2
    err = [line for line in proc.stderr.splitlines() if line.strip() and "Warp" not in line and not line.startswith(" ")]
    assert len(err) == 1 and message in err[0], proc.stderr
    assert "Traceback" not in proc.stderr


def test_precompile_finds_every_step_module():
    """The CUDA cold-start list names modules that exist once a World is built (guards against renames)."""
    from hexnewton.physics.precompile import STEP_MODULES, imported_modules

    _world("flat").step(1)
    names = [m.name for m in imported_modules()]
    assert set(STEP_MODULES) <= set(names)
    assert any(n.startswith("hexnewton.") for n in names)


def test_precompile_reads_the_narrow_phase_block_sizes():
    """The block sizes Newton's narrow phase launches with on CUDA are read from its own fields (guards against
    renames); the CPU runs one thread per block whatever is asked, so it compiles no extra variants."""
    from hexnewton.physics.precompile import NARROW_PHASE_SOURCES, imported_modules, narrow_phase_block_dims

    world = _world("rugged")
    narrow = world.pipeline.narrow_phase
    for name in ("block_dim", "split_convex_block_dim", "mesh_triangle_block_dim"):
        assert isinstance(getattr(narrow, name), int)
    assert narrow_phase_block_dims(world.pipeline, world.device) == ()
    modules = {m.name: m for m in imported_modules()}
    assert set(NARROW_PHASE_SOURCES) <= set(modules)


def test_precompile_asks_cuda_for_the_launched_block_sizes(monkeypatch):
    """On CUDA Newton's narrow-phase modules compile at Warp's default and at each size the narrow phase launches with;
    other modules once at the default (the device is faked: the choice is plain Python)."""
    from types import SimpleNamespace

    from hexnewton.physics import precompile as pc
    from hexnewton.physics.private_api import CONTACT_REDUCTION, NARROW_PHASE_SOURCES, SOLVER_MODULES

    world = _world("rugged")
    modules = {m.name: m for m in pc.imported_modules()}
    monkeypatch.setattr(pc.wp, "get_device", lambda device=None: SimpleNamespace(is_cuda=True))
    narrow = world.pipeline.narrow_phase
    dims = pc.narrow_phase_block_dims(world.pipeline, "cuda:0")
    assert dims == tuple(sorted({narrow.block_dim, narrow.split_convex_block_dim, narrow.mesh_triangle_block_dim, 32}))
    reduction = modules[CONTACT_REDUCTION]
    assert pc._block_dims(reduction, "cuda:0", None, dims) == [None, *dims]
    assert pc._block_dims(modules[SOLVER_MODULES[0]], "cuda:0", None, dims) == [None]  # mujoco_warp's smooth
    # the import-time narrow phase launched no other size on the H100; its generated kernels did
    narrow_phase = NARROW_PHASE_SOURCES[0]  # Newton's narrow-phase module
    assert pc._block_dims(modules[narrow_phase], "cuda:0", None, dims) == [None]
    generated = next(k.module for k in pc._live_kernels() if k.func.__module__ == narrow_phase
                     and k.module.name not in pc.NARROW_PHASE_SOURCES)  # fmt: skip
    assert pc._block_dims(generated, "cuda:0", None, dims) == [None, *dims]


def test_precompile_auto_compiles_generated_kernels_on_cuda_only():
    from hexnewton.physics.precompile import compiles_generated

    assert compiles_generated("auto", is_cuda=True) and not compiles_generated("auto", is_cuda=False)
    assert compiles_generated("generated", is_cuda=False) and not compiles_generated("imported", is_cuda=True)


@pytest.mark.slow  # end to end: 15 s or more on a 2-core CPU
def test_precompile_leaves_the_first_step_nothing_to_compile():
    """A built World has every module its first step (and graph capture) launches loaded: mujoco_warp's generated
    kernels included, each compiled once; ``loaded_variants`` (what train.py's timing.json lists as the first step's
    loads) sees them."""
    from hexnewton.physics.precompile import loaded_variants, variant_names

    world = _world("flat", precompile="generated")
    before = loaded_variants(world.device)
    # a generated kernel's module, compiled by the build
    assert any("__locals__" in name for name in variant_names(before))
    assert any(name.startswith("hexnewton.") for name in variant_names(before))
    world.step(2)
    assert variant_names(loaded_variants(world.device) - before) == []


@pytest.mark.slow  # end to end: 15 s or more on a 2-core CPU
def test_bench_reports_sim_env_and_training(tmp_path):
    """One tiny run of every benchmark mode under non-default physics: JSON numbers and the appended Markdown
    table."""
    import json

    out, md = tmp_path / "b.json", tmp_path / "B.md"
    proc = subprocess.run([sys.executable, "-m", "hexnewton.apps.bench", "--device", "cpu", "--terrain", "flat", "--num_envs",
                           "4", "--frames", "5", "--env_steps", "3", "--train_iterations", "1", "--json", str(out),
                           "--append", str(md), "--profile", "--env.sim.frame_dt", "0.02", "--env.sim.substeps", "3",
                           "--agent.algorithm.num_mini_batches", "2"],
                          capture_output=True, text=True, timeout=600)  # fmt: skip
    assert proc.returncode == 0, proc.stderr[-2000:]
    res = json.loads(out.read_text())
    (sim,), (pipe,) = res["sim"], res["pipeline"]
    assert sim["robot_s_per_s"] > 0 and pipe["env_steps_per_s"] > 0 and pipe["train_steps_per_s"] > 0
    assert pipe["env_robot_s_per_s"] == pytest.approx(pipe["env_steps_per_s"] * 0.02)
    text = md.read_text()
    assert "| flat | 4 |" in text and "env / sim" in text and "training / sim" in text
    assert "frame 20 ms = 3 x 6.66667 ms" in text  # one physics setting for all three modes
    (prof,) = res["profile"]  # where an iteration's time goes
    assert prof["env.step"] > 0 and prof["PPO update"] > 0 and prof["logger"] > 0 and "| PPO update |" in text


def test_bench_largest_that_fits(monkeypatch):
    """--largest doubles the env count until an allocation fails; other errors are not swallowed."""
    from hexnewton.analysis import bench

    def fake(terrain, n, device, frames, sim, ground=None, base=None):
        assert ground is None or ground.collision == "mesh_boxes"  # the terrain settings are passed on
        if n > 16:
            raise RuntimeError(f"Warp error: Failed to allocate {n * 10**9} bytes on device 'cuda:0'")
        return bench.BenchResult(terrain=terrain, num_envs=n, **{k: 0 for k in FIELDS})

    FIELDS = [f for f in bench.BenchResult.__dataclass_fields__ if f not in ("terrain", "num_envs")]
    monkeypatch.setattr(bench, "bench_one", fake)
    assert [r.num_envs for r in bench.largest_that_fits("flat", 4, "cuda:0", 5, SimConfig())] == [8, 16]
    boxes = TerrainConfig(collision="mesh_boxes")
    assert len(bench.largest_that_fits("stepped", 4, "cuda:0", 5, SimConfig(), ground=boxes)) == 2
    assert bench.is_out_of_memory(MemoryError()) and bench.is_out_of_memory(RuntimeError("CUDA out of memory"))

    def broken(*a, **k):
        raise RuntimeError("kernel launch failed")

    monkeypatch.setattr(bench, "bench_one", broken)
    with pytest.raises(RuntimeError, match="kernel launch failed"):
        bench.largest_that_fits("flat", 4, "cuda:0", 5, SimConfig())


def test_solver_modules_compiled_before_the_solver_stay_current():
    """The modules the MuJoCo solver's set-up launches are compiled in parallel before it is built; building it (and
    the World's later precompile) must keep those compiled variants, or they would compile again."""
    from warp._src.context import user_modules

    from hexnewton.physics.precompile import SOLVER_MODULES, precompile_solver

    assert precompile_solver("cpu") == list(SOLVER_MODULES)

    def variants() -> dict:
        return {name: {key: id(e) for key, e in list(user_modules[name].execs.items())} for name in SOLVER_MODULES}

    before = variants()
    assert all(before[name] for name in SOLVER_MODULES if user_modules[name].kernels)
    _world("flat").step(1)
    assert variants() == before


def test_a_parallel_load_that_failed_is_loaded_once_more_alone(monkeypatch, caplog):
    """compile_modules: a job whose parallel load raised (Warp's hashes cleared by another module's load) is loaded
    again alone; one that fails alone too is logged and left to its first launch, never raised."""
    from hexnewton.physics import precompile

    calls, failing = [], {"once": 1, "always": 99}

    def load(device, module, block_dim):
        calls.append(module)
        if failing.get(module, 0) > 0:
            failing[module] -= 1
            raise KeyError(1)

    monkeypatch.setattr(precompile, "_load", load)

    class Named(str):
        name = property(lambda self: str(self))

    jobs = [(Named("fine"), None), (Named("once"), None), (Named("always"), 256)]
    with caplog.at_level("WARNING", logger="hexnewton"):
        precompile.compile_modules("cpu", jobs, max_workers=2)
    assert sorted(calls) == ["always", "always", "fine", "once", "once"]
    assert [r.getMessage().split(" (")[0] for r in caplog.records] == ["precompile: always"]
    assert "block size 256" in caplog.records[0].getMessage()

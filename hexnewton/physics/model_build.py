"""The physics model of a config, before the World steps it: the robots' scene and its spawn, the terrain, Newton's
finalize (:class:`ModelBuild`, which ``train.py`` runs beside its imports), and the checks of the physics settings
that come first."""

from __future__ import annotations

import math
import threading
import time
from dataclasses import dataclass

import newton
import numpy as np
import warp as wp
from newton.solvers import SolverMuJoCo

from hexnewton import startup
from hexnewton.config import HexConfig, SimConfig
from hexnewton.errors import HexnewtonError
from hexnewton.physics.device import resolve_device
from hexnewton.physics.precompile import compiles_generated, install_shipped_modules, live_kernel_ids, preload
from hexnewton.robot import BASE_Q, NUM_JOINTS, build_hexapod, footprint, spawn_clearance
from hexnewton.terrain import Terrain, make_terrain, max_terrain_height_np

MAX_ENVS = 1 << 20  # per device; an H100 holds 16384 envs in a few GB (studies/throughput/report.md)


def validate_sim(cfg: SimConfig) -> None:
    if not isinstance(cfg.num_envs, (int, np.integer)) or cfg.num_envs <= 0:
        raise HexnewtonError(f"num_envs must be a positive integer, got {cfg.num_envs}")
    if cfg.num_envs > MAX_ENVS:
        raise HexnewtonError(f"num_envs {cfg.num_envs:,} exceeds the {MAX_ENVS:,} robots one device can hold")
    if cfg.substeps < 1:
        raise HexnewtonError(f"substeps must be >= 1, got {cfg.substeps}")
    if not cfg.frame_dt > 0:
        raise HexnewtonError(f"frame_dt must be > 0, got {cfg.frame_dt}")
    for name in ("rigid_gap", "terrain_gap", "speculative_gap"):
        value = getattr(cfg, name)
        if value is not None and not (math.isfinite(value) and value >= 0):
            raise HexnewtonError(f"sim.{name} must be a non-negative number of metres, got {value}")
    if cfg.min_contact_pool < 0:
        raise HexnewtonError(f"sim.min_contact_pool must be >= 0, got {cfg.min_contact_pool}")


@dataclass
class Spawn:
    """Where the scene stands its robots: env i at x = 0 in its own lane y_i (``xy`` (N, 2)), the lanes evenly spread
    over +-spawn_y_spread so that the robots meet different blocks, its torso ``clearance`` above the highest terrain
    within ``footprint`` of its lane (``z`` (N,))."""

    xy: np.ndarray
    z: np.ndarray
    footprint: float
    clearance: float


def build_scene(cfg: HexConfig, terrain: Terrain) -> tuple[newton.ModelBuilder, Spawn]:
    """The scene: ``cfg.sim.num_envs`` hexapods, each in its own world, standing at their :class:`Spawn`, and the shared
    terrain."""
    sim, n = cfg.sim, cfg.sim.num_envs
    robot = build_hexapod(cfg.robot, gap=sim.rigid_gap)

    scene = newton.ModelBuilder()
    SolverMuJoCo.register_custom_attributes(scene)
    scene.rigid_gap = sim.rigid_gap
    scene.replicate(robot, n)
    terrain_gap = sim.rigid_gap if sim.terrain_gap is None else sim.terrain_gap
    ground_cfg = newton.ModelBuilder.ShapeConfig(mu=cfg.robot.friction, gap=terrain_gap)
    terrain.add_to_builder(scene, ground_cfg)

    xy = np.zeros((n, 2))
    if n > 1:
        xy[:, 1] = np.linspace(-sim.spawn_y_spread, sim.spawn_y_spread, n)
    half, clearance = footprint(cfg.robot), spawn_clearance(cfg.robot)
    z = max_terrain_height_np(terrain.grid, xy[:, 0], xy[:, 1], half) + clearance
    nq = BASE_Q + NUM_JOINTS
    q = np.asarray(scene.joint_q, dtype=np.float32).reshape(n, nq)
    q[:, 0:2] = xy
    q[:, 2] = z
    scene.joint_q[:] = q.reshape(-1).tolist()
    return scene, Spawn(xy, z, half, clearance)


class ModelBuild:
    """The terrain and the finalized Newton model of ``cfg``: the height grid and its meshes, the scene
    (:func:`build_scene`) and Newton's finalize, which for the curriculum's complex course is mostly NumPy over its
    block mesh (the open-edge flags of ~1.1 M faces, ~10 s). None of it needs torch or rsl-rl.

    Made before anything loads a Warp module: it installs the shipped modules first. ``beside=False`` builds at once,
    marking the start-up phases terrain, scene and finalize; ``beside=True`` builds in a thread while the process goes
    on (``train.py`` imports torch and rsl-rl meanwhile), its phases kept as the note ``model_build_beside_s`` and the
    wait for it marked as the phase "model build". With ``scene_first`` (and ``beside``) the terrain and the scene,
    Python that would share the interpreter lock with the imports, are built at once (their phases marked) and only
    the finalize, mostly NumPy, goes to the thread. With ``preload_kernels`` (and ``beside``), when the World takes
    the model while the finalize still runs, the Warp modules it loads whatever its model
    (:func:`~hexnewton.physics.precompile.preload`) are loaded meanwhile, marked as the phase "kernels beside the
    build". :class:`World` takes it (``World(cfg, build=...)``); an error of the build is raised there."""

    def __init__(self, cfg: HexConfig, terrain: Terrain | None = None, beside: bool = False, scene_first: bool = False,
                 preload_kernels: bool = False):
        validate_sim(cfg.sim)
        self.cfg, self.device, self.beside = cfg, resolve_device(cfg.sim.device), beside
        self.preload_kernels = preload_kernels
        startup.mark("python and imports")
        # the modules compiled ahead of time for this GPU (hexnewton/physics/aot/) into Warp's cache, before any loads
        shipped = install_shipped_modules(self.device)
        if shipped or "shipped_modules_installed" not in startup.notes():
            startup.note("shipped_modules_installed", shipped)
        startup.mark("shipped kernels")
        # SimConfig.precompile "generated": the kernels mujoco_warp and Newton generate for this model come after these
        is_cuda = wp.get_device(self.device).is_cuda
        self.since = live_kernel_ids() if compiles_generated(cfg.sim.precompile, is_cuda) else None
        self.seconds: dict[str, float] = {}
        self._terrain, self._out, self._error, self._last = terrain, None, None, time.time()
        self._thread, self._in_thread, self._scene = None, False, None
        if beside and scene_first:
            self._build_scene()
        if beside:
            self._in_thread = True
            self._thread = threading.Thread(target=self._build, name="hexnewton-model-build", daemon=True)
            self._thread.start()
        else:
            self._build()

    def _lap(self, name: str) -> None:
        if self._in_thread:
            now = time.time()
            self.seconds[name], self._last = round(now - self._last, 2), now
        else:
            startup.mark(name)

    def _build_scene(self) -> None:
        try:
            self._terrain = self._terrain if self._terrain is not None else make_terrain(self.cfg.terrain)
            self._lap("terrain")
            self._scene = build_scene(self.cfg, self._terrain)
            self._lap("scene")
        except BaseException as exc:  # raised where the result is taken
            self._error = exc

    def _build(self) -> None:
        if self._scene is None and self._error is None:
            self._build_scene()
        if self._error is not None:
            return
        (scene, spawn), self._scene = self._scene, None  # the builder's lists, not kept beside the model
        try:
            self._last = time.time()
            with wp.ScopedDevice(self.device):
                model = scene.finalize(device=self.device)
            self._lap("finalize")
            self._out = self._terrain, model, spawn
        except BaseException as exc:  # raised in the thread that takes the result
            self._error = exc

    def result(self) -> tuple[Terrain, newton.Model, Spawn]:
        """The terrain, the finalized model and the spawn, once built (waits for a build beside)."""
        if self._thread is not None:  # the wait, 0 if the build ended first
            if self.preload_kernels and self._thread.is_alive():
                startup.note("kernels_beside_build", len(preload(self.device)))
                startup.mark("kernels beside the build")
            self._thread.join()
            self._thread = None
            startup.mark("model build")
            startup.note("model_build_beside_s", self.seconds)
        if self._error is not None:
            raise self._error
        return self._out

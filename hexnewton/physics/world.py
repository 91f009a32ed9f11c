"""A batched Newton world: N hexapods, each in its own world, sharing one terrain.

Model/State/Control as in Newton: ``World.model`` is static, ``World.state`` the current physics state,
``World.control`` the joint targets. One ``World.step()`` advances one physics frame (``frame_dt``): the
collision pipeline runs once, then ``substeps`` MuJoCo (mujoco_warp) steps reuse its contacts. The whole
frame is recorded once into a graph (a CUDA graph on GPU, Warp's own capture on CPU) and replayed.

Tensors (torch, zero-copy over the Warp arrays; writes go straight into the simulation):
  ``joint_q``      (N, 25)  base position xyz, base quaternion xyzw, 18 joint angles
  ``joint_qd``     (N, 24)  base linear, base angular velocity, 18 joint velocities
  ``joint_target`` (N, 18)  PD position targets of the 18 joints (a view into ``control.joint_target_q``)

Contact forces (``track_leg_contacts``, the critic's): Newton's ``SensorContact`` sums MuJoCo's on each lower leg.

Contact capacity: every frame, a kernel folds MuJoCo's per-world overflow bitmask and the collision
pipeline's triangle-pair / contact-reduction counters into sticky flags that ``check_contacts()`` reads and
reports (warning or ``ContactOverflowError``); overflow never passes silently.
"""

from __future__ import annotations

import logging
import warnings
from collections.abc import Callable
from dataclasses import dataclass, replace

import newton
import numpy as np
import warp as wp
from newton.sensors import SensorContact
from newton.solvers import SolverMuJoCo

from hexnewton import startup
from hexnewton.config import HexConfig, SimConfig
from hexnewton.errors import HexnewtonError
from hexnewton.kernels.world import (
    OVERFLOW_BOX_PAIRS,
    OVERFLOW_CONTACT_REDUCTION,
    OVERFLOW_TRIANGLE_PAIRS,
    accumulate_overflow_kernel,
    as_mask,
    nonfinite_envs_kernel,
    spawn_pose_kernel,
    zero_world_rows_kernel,
)
from hexnewton.physics.graphs import capture_graph
from hexnewton.physics.model_build import ModelBuild
from hexnewton.physics.private_api import reduction_overflow
from hexnewton.physics.precompile import (
    precompile,
    precompile_solver,
)
from hexnewton.robot import BASE_Q, BASE_QD, NUM_JOINTS, leg_bounds
from hexnewton.terrain import Terrain
from hexnewton.terrain.box_pairs import TerrainBoxPairs

log = logging.getLogger("hexnewton")

# mujoco_warp's ITERATIONS (1 << 9) and LS_ITERATIONS (1 << 10) flags mean "solver hit its iteration cap",
# not a dropped contact or constraint: counted apart from capacity overflow.
NOT_CONVERGED_BITS = (1 << 9) | (1 << 10)


class ContactOverflowError(HexnewtonError):
    pass


def contacts_per_world(cfg: SimConfig, num_envs: int) -> int:
    """MuJoCo's per-world contact capacity (``nconmax``; mujoco_warp pools it over the worlds): ``contacts_per_env``,
    raised so that the pool holds at least ``min_contact_pool`` contacts."""
    return max(cfg.contacts_per_env, -(-cfg.min_contact_pool // num_envs))


@dataclass
class OverflowReport:
    worlds: int  # worlds whose solver reported a capacity-overflow bit
    bits: int  # union of all capacity-overflow bits seen
    frames_checked: int
    not_converged_worlds: int = 0  # worlds where the MuJoCo solver hit its iteration cap (not an overflow)

    @property
    def ok(self) -> bool:
        return self.bits == 0

    def describe(self) -> str:
        names = []
        b = self.bits
        if b & int(SolverMuJoCo.OverflowBits.CONTACT_PIPELINE):
            names.append("collision pipeline contacts > rigid_contact_max (raise sim.contacts_per_env)")
        if b & int(SolverMuJoCo.OverflowBits.SOLVER_NCONMAX):
            names.append("contacts > MuJoCo nconmax (raise sim.contacts_per_env)")
        if b & 0xFFFF:
            names.append(f"mujoco_warp overflow flags 0x{b & 0xFFFF:x} (raise sim.constraints_per_env)")
        if b & OVERFLOW_TRIANGLE_PAIRS:
            names.append("triangle-pair buffer (raise sim.triangle_pairs_per_env)")
        if b & OVERFLOW_CONTACT_REDUCTION:
            names.append("contact-reduction buffer (raise sim.contacts_per_env)")
        if b & OVERFLOW_BOX_PAIRS:
            names.append("terrain box pairs (terrain.collision boxes): a robot shape overlapped more boxes than its slots")
        return (f"contact buffers overflowed in {self.worlds} world(s), contacts were dropped: " + "; ".join(names)
                + "; or lower sim.rigid_gap (fewer contact candidates)")


class World:
    """N hexapods on one terrain, stepped by SolverMuJoCo with Newton's collision pipeline.

    ``terrain``: a built terrain to use instead of ``cfg.terrain``'s; ``build``: a :class:`ModelBuild` of ``cfg`` made
    earlier (in ``train.py`` beside the imports), instead of building here."""

    def __init__(self, cfg: HexConfig | None = None, terrain: Terrain | None = None, build: ModelBuild | None = None):
        self.cfg = cfg = cfg or HexConfig()
        if build is None:  # the sim config checked and the device resolved there
            build = ModelBuild(cfg, terrain)
        elif build.cfg != cfg or terrain is not None:
            raise ValueError("World: the model build is of another config (or a terrain was given beside it)")
        else:
            startup.mark("python and imports")
        sim = cfg.sim
        self.device = build.device
        self.num_envs = int(sim.num_envs)
        self.frame_dt = sim.frame_dt
        self.sim_dt = sim.frame_dt / sim.substeps
        self.substeps = sim.substeps
        self.terrain, self.model, spawn = build.result()
        self.spawn_xy, self.spawn_z = spawn.xy, spawn.z
        self.footprint, self.spawn_clearance = spawn.footprint, spawn.clearance
        self._init_model_arrays()
        startup.mark("model arrays")
        self._init_physics(build.since)
        self._init_buffers()
        self._bind_views()
        self.sim_time = 0.0
        self.graph = None
        self.controller: Callable[[World], None] | None = None
        wp.synchronize_device(self.device)
        startup.mark("world buffers")

    def _init_model_arrays(self) -> None:
        """The finalized model's states (forward kinematics of the spawn poses) and control."""
        self.model.rigid_gap = self.cfg.sim.rigid_gap

        self.state_0 = self.model.state()
        self.state_1 = self.model.state()
        self.control = self.model.control()
        newton.eval_fk(self.model, self.model.joint_q, self.model.joint_qd, self.state_0)

    def _init_physics(self, since: set[int] | None) -> None:
        """The MuJoCo solver and Newton's collision pipeline with the contact capacity the solver takes; then the
        step's Warp modules, with the kernels generated for this model since ``since``, compiled in parallel
        (``hexnewton.physics.precompile``)."""
        sim = self.cfg.sim
        precompile_solver(self.device)
        startup.mark("solver kernels")
        self.solver = SolverMuJoCo(self.model, use_mujoco_contacts=False, solver=sim.solver, integrator=sim.integrator,
                                   iterations=sim.iterations, ls_iterations=sim.ls_iterations,
                                   nconmax=contacts_per_world(sim, self.num_envs),
                                   njmax=sim.constraints_per_env)  # fmt: skip
        # iteration-cap hits are reported by check_contacts(), not printed per world by mujoco_warp
        self.solver.mjw_model.opt.warn_overflow &= ~NOT_CONVERGED_BITS
        max_contacts = self.solver.get_max_contact_count()
        startup.mark("solver")
        self.box_pairs = self._terrain_box_pairs()
        self.pipeline = newton.CollisionPipeline(
            self.model, shape_pairs_filtered=None if self.box_pairs is None else self.box_pairs.pairs,
            rigid_contact_max=max_contacts, speculative_contact_gap_max=sim.speculative_gap,
            max_triangle_pairs=max(1_000_000, sim.triangle_pairs_per_env * self.num_envs))  # fmt: skip
        self._collide_dt = sim.frame_dt if sim.speculative_gap is not None else None  # speculative: one frame
        self.contacts = self.pipeline.contacts()
        self._reduction_overflow = reduction_overflow(self.contacts)  # set by the contact reduction when it drops
        startup.mark("collision pipeline")
        precompile(self.device, self.solver if since is not None else None, since, pipeline=self.pipeline)
        startup.mark("kernels")
        self.apply_effort_clamp()

    def set_effort_clamp(self, mode: str) -> None:
        """``SimConfig.effort_clamp`` from now on, on the built model (a training curriculum's stage): "actuator"
        moves the servos' effort limits to their actuators (:meth:`apply_effort_clamp`); the joint clamp cannot come
        back within a world (ValueError)."""
        if mode == self.cfg.sim.effort_clamp:
            return
        if mode != "actuator":
            raise ValueError(f"sim.effort_clamp: a built world moves its clamp to the actuators, not back to '{mode}'")
        self.cfg = replace(self.cfg, sim=replace(self.cfg.sim, effort_clamp=mode))
        self.apply_effort_clamp()

    def apply_effort_clamp(self) -> None:
        """``SimConfig.effort_clamp`` "actuator": every servo's effort limit moved from its joint's actuator-force
        range (where Newton puts it) to its actuator's force range, world by world, the joint clamp off. Called again
        after anything hands the model's effort limits to MuJoCo anew (``mdp.events.randomize_physics``)."""
        if self.cfg.sim.effort_clamp != "actuator":
            return
        mw = self.solver.mjw_model
        joint = mw.actuator_trnid.numpy()[:, 0]
        limits = mw.jnt_actfrcrange.numpy().reshape(-1, mw.jnt_actfrcrange.shape[-1], 2)[:, joint]
        forcerange = mw.actuator_forcerange.numpy()
        mw.actuator_forcerange.assign(np.broadcast_to(limits, forcerange.shape).astype(forcerange.dtype))
        mw.actuator_forcelimited.assign(np.ones(mw.actuator_forcelimited.shape, bool))
        mw.jnt_actfrclimited.assign(np.zeros(mw.jnt_actfrclimited.shape, bool))

    def _terrain_box_pairs(self) -> TerrainBoxPairs | None:
        """With terrain collision "boxes": the robot shapes' pairs with the terrain boxes under them, refreshed before
        every detection (:mod:`hexnewton.terrain.box_pairs`); None otherwise."""
        boxes = self.terrain.boxes
        if boxes is None:
            return None
        sim = self.cfg.sim
        shape_body = self.model.shape_body.numpy()
        robot_shapes = np.flatnonzero(shape_body >= 0)
        first = int(np.flatnonzero(shape_body < 0)[0])
        pairs = TerrainBoxPairs(self.model, boxes, self.terrain.grid, robot_shapes, first, first + boxes.count,
                                sim.rigid_gap if sim.terrain_gap is None else sim.terrain_gap)
        pairs.update(self.state_0.body_q)
        # MuJoCo holds the far box only (add_boxes): every box's contacts take its geom (the same contact parameters)
        geom = self.solver.newton_shape_to_mjc_geom.numpy()
        geom[first:first + boxes.count] = geom[first + boxes.count]
        self.solver.newton_shape_to_mjc_geom.assign(geom)
        return pairs

    def _init_buffers(self) -> None:
        """The step's and the resets' buffers: overflow flags, reset masks, the solver's constraint rows per world,
        the spawn poses, the standing pose and joint limits as kernels take them, the non-finite flags."""
        n = self.num_envs
        self.observables = self.solver.observables({SolverMuJoCo.ObservableKind.OVERFLOW})
        self._overflow_world = wp.zeros(n, dtype=wp.int32, device=self.device)
        self._overflow_global = wp.zeros(1, dtype=wp.int32, device=self.device)
        self._frames_since_check = 0
        self.overflow_frames = 0  # frames in which some overflow was reported (upper bound per check)

        self._reset_mask = wp.zeros(n, dtype=wp.bool, device=self.device)
        self._solver_mask = wp.zeros(n + 1, dtype=wp.bool, device=self.device)  # SolverMuJoCo.reset's (+ world -1)
        efc = self.solver.mjw_data.efc
        self._efc_rows = [a.reshape((n, -1)) for a in (efc.J, efc.D, efc.Jqvel, efc.aref, efc.force, efc.frictionloss,
                                                        efc.margin, efc.pos, efc.vel)]  # fmt: skip
        self._spawn_q = wp.clone(self.model.joint_q.reshape((n, BASE_Q + NUM_JOINTS)))  # each env's spawn pose
        # one leg's standing pose and (hip, knee, ankle) limits, as kernels take them
        robot = self.cfg.robot
        lower, upper = leg_bounds(robot)
        self.stand_pose, self.joint_lower, self.joint_upper = (wp.vec3(*robot.stand_pose), wp.vec3(*lower),
                                                               wp.vec3(*upper))  # fmt: skip
        self._bad = wp.zeros(n, dtype=wp.bool, device=self.device)
        self.nonfinite_resets = 0
        self.leg_sensor = self._force_observables = self.lower_legs = None

    def track_leg_contacts(self) -> wp.array:
        """From now on, measure the contact force on each lower leg (the tibia body: shin capsule and foot sphere) at
        each frame's last substep: Newton's ``SensorContact`` over MuJoCo's contact forces (the solver's ``CONTACT_F``
        observable). Returns the (N, 6) forces [N, world frame] on the robot, legs in ``LEG_NAMES`` order, updated
        every frame; sets ``lower_legs``, (N, 6) the tibia bodies' indices."""
        if self.leg_sensor is None:
            n = self.num_envs
            tibia = [k for k, label in enumerate(self.model.body_label) if str(label).endswith("_tibia")]
            if len(tibia) != 6 * n:
                raise HexnewtonError(f"the model has {len(tibia)} lower legs ('*_tibia' bodies), not 6 per robot")
            self.lower_legs = np.asarray(tibia, np.int32).reshape(n, 6)
            self.leg_sensor = SensorContact(self.model, sensing_bodies=tibia, request_contact_attributes=False)
            kinds = {SolverMuJoCo.ObservableKind.OVERFLOW, *SensorContact.solver_observable_kinds}
            self._force_observables = self.solver.observables(kinds, contacts=self.contacts)
            self.graph = None
        return self.leg_sensor.total_force.reshape((self.num_envs, 6))

    def set_controller(self, controller: Callable[[World], None] | None) -> None:
        """Launch ``controller(world)`` before every physics substep (inside the captured graph)."""
        self.controller = controller
        self.graph = None

    # ------------------------------------------------------------------ tensors
    def _bind_views(self) -> None:
        n, nq, nqd = self.num_envs, BASE_Q + NUM_JOINTS, BASE_QD + NUM_JOINTS
        self.joint_q_wp = self.state_0.joint_q.reshape((n, nq))
        self.joint_qd_wp = self.state_0.joint_qd.reshape((n, nqd))
        self.joint_target_wp = self.control.joint_target_q.reshape((n, nq))

    @property
    def joint_q(self):
        return wp.to_torch(self.joint_q_wp)

    @property
    def joint_qd(self):
        return wp.to_torch(self.joint_qd_wp)

    @property
    def joint_target(self):
        """(N, 18) joint position targets (torch view; the base columns of the control array are unused)."""
        return wp.to_torch(self.joint_target_wp)[:, BASE_Q:]

    def numpy_q(self) -> np.ndarray:
        return self.joint_q_wp.numpy()

    # ------------------------------------------------------------------ stepping
    def simulate_frame(self) -> None:
        """One physics frame (collision + substeps), uncaptured: callers may record it into their own graph."""
        if self.box_pairs is not None:
            self.box_pairs.update(self.state_0.body_q)
        self.pipeline.collide(self.state_0, self.contacts, dt=self._collide_dt)
        for i in range(self.substeps):
            if self.controller is not None:
                self.controller(self)
            self.state_0.clear_forces()
            # the last substep also exports the contact forces where the legs' contacts are tracked
            last = i == self.substeps - 1 and self.leg_sensor is not None
            seen = self._force_observables if last else self.observables
            self.solver.step(self.state_0, self.state_1, self.control, self.contacts, self.sim_dt, observables=seen)
            if last:
                self.leg_sensor.update(None, self.contacts, observables=seen)
            wp.launch(accumulate_overflow_kernel, dim=self.num_envs,
                      inputs=[seen.overflow, self._triangle_pair_count(),
                              self.pipeline.narrow_phase.max_triangle_pairs, self._reduction_overflow,
                              self._overflow_world, self._overflow_global], device=self.device)  # fmt: skip
            if self.substeps % 2 == 1 and i == self.substeps - 1:
                self.state_0.assign(self.state_1)
            else:
                self.state_0, self.state_1 = self.state_1, self.state_0

    def _triangle_pair_count(self) -> wp.array:
        c = getattr(self.pipeline.narrow_phase, "triangle_pairs_count", None)
        if c is None:  # no mesh in the scene (flat terrain)
            if not hasattr(self, "_zero_count"):
                self._zero_count = wp.zeros(1, dtype=wp.int32, device=self.device)
            c = self._zero_count
        return c

    def _capture(self) -> None:
        s = self.state_0
        restore = [s.joint_q, s.joint_qd, s.body_q, s.body_qd, self._overflow_world, self._overflow_global]
        self.graph = capture_graph(self.device, self.simulate_frame, restore)

    def step(self, frames: int = 1) -> None:
        """Advance ``frames`` physics frames of ``frame_dt`` each."""
        if self.graph is None and self.cfg.sim.use_graph:
            self._capture()
        for _ in range(frames):
            if self.graph is not None:
                wp.capture_launch(self.graph)
            else:
                self.simulate_frame()
        self.sim_time += frames * self.frame_dt
        self._frames_since_check += frames

    # ------------------------------------------------------------------ resets & health
    def reset(self, mask: np.ndarray | wp.array | None = None) -> None:
        """Put the selected envs (all if ``mask`` is None) back at their spawn pose, at rest, with their joint targets
        on it (:meth:`restart`). The MDP places its robots itself (``hexnewton.mdp.events``) and calls
        :meth:`restart`. Capturable when ``mask`` is a Warp array."""
        m = as_mask(mask, self._reset_mask)
        wp.launch(spawn_pose_kernel, dim=self.num_envs, inputs=[m, self._spawn_q],
                  outputs=[self.joint_q_wp, self.joint_qd_wp, self.joint_target_wp], device=self.device)  # fmt: skip
        self.restart(m)

    def restart(self, mask: wp.array) -> None:
        """Make the physics of the envs in ``mask`` follow the joint state just written into ``joint_q`` /
        ``joint_qd``: their bodies by forward kinematics, MuJoCo's warm start, applied forces and constraint rows
        cleared. Capturable."""
        newton.eval_fk(self.model, self.state_0.joint_q, self.state_0.joint_qd, self.state_0, mask=mask)
        # MuJoCo's per-world warm start and applied forces survive a state reset: after a blow-up they would
        # poison the next step, so clear them for the reset worlds (the joint state was set above: flags 0)
        wp.copy(self._solver_mask, mask, count=self.num_envs)
        self.solver.reset(self.state_0, self._solver_mask, flags=0)
        # ... and so do the constraint rows (mujoco_warp fills only the non-zero Jacobian entries of a new row):
        # zero them, or a NaN left by a blow-up returns a few steps later
        for rows in self._efc_rows:
            wp.launch(zero_world_rows_kernel, dim=self.num_envs, inputs=[mask, rows], device=self.device)

    def reset_nonfinite(self) -> int:
        """Reset every env whose state holds NaN/Inf; returns how many (also counted in nonfinite_resets)."""
        wp.launch(nonfinite_envs_kernel, dim=self.num_envs, inputs=[self.joint_q_wp, self.joint_qd_wp, self._bad],
                  device=self.device)  # fmt: skip
        bad = int(self._bad.numpy().sum())
        if bad:
            self.reset(self._bad)
            self.nonfinite_resets += bad
            log.warning("reset %d env(s) with non-finite physics state", bad)
        return bad

    def check_contacts(self, on_overflow: str = "warn") -> OverflowReport:
        """Read the sticky overflow flags since the last check; warn (or raise) if any buffer overflowed."""
        flags = self._overflow_world.numpy()
        capacity = flags & ~NOT_CONVERGED_BITS
        bits = int(np.bitwise_or.reduce(capacity)) | int(self._overflow_global.numpy()[0])
        if self.box_pairs is not None and self.box_pairs.overflow.numpy()[0]:
            bits |= OVERFLOW_BOX_PAIRS
            self.box_pairs.overflow.zero_()
        report = OverflowReport(worlds=int((capacity != 0).sum()), bits=bits, frames_checked=self._frames_since_check,
                                not_converged_worlds=int(((flags & NOT_CONVERGED_BITS) != 0).sum()))  # fmt: skip
        self._overflow_world.zero_()
        self._overflow_global.zero_()
        self._frames_since_check = 0
        if not report.ok:
            self.overflow_frames += report.frames_checked
            if on_overflow == "raise":
                raise ContactOverflowError(report.describe())
            warnings.warn(report.describe(), RuntimeWarning, stacklevel=2)
        return report

    # ------------------------------------------------------------------ convenience
    def base_pos(self) -> np.ndarray:
        return self.numpy_q()[:, 0:3]


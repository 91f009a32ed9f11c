"""One dataclass config tree for hexnewton.

The paper's values (Huang et al. 2025, "Hierarchical reinforcement learning for enhancing stability and
adaptability of hexapod robots in complex terrains") are the defaults; each carries a comment naming the
section, equation or table it comes from. Values the paper does not give are marked ``# ours`` with the
reason.

Conventions (used everywhere in hexnewton):
  * World frame: z up, the robot starts at the origin facing +x; terrain features lie ahead along +x.
  * Body frame: x forward, y left, z up.
  * Joint order: legs R1, R2, R3, L1, L2, L3 (front to back), each leg hip, knee (femur), ankle (tibia).
  * Joint signs (same on every leg; another robot's: docs/robots.md, its zero angles its own):
      - hip   > 0 swings the foot forward (+x), the hip axis is vertical;
      - knee  > 0 lifts the femur (rotates the leg upward), 0 = femur horizontal;
      - ankle < 0 tucks the foot inward toward the body, 0 = tibia perpendicular to the femur, pointing
        down when the femur is horizontal.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from hexnewton.robot_config import (  # noqa: F401  (the robot's description, part of this tree)
    JOINT_KINDS,
    JOINT_NAMES,
    LEG_NAMES,
    JointConfig,
    LegConfig,
    LinkConfig,
    RobotConfig,
    ShapeConfig,
)

TERRAINS = ("flat", "rugged", "stepped", "complex")
TERRAIN_COLLISIONS = ("mesh", "mesh_boxes", "boxes")
#: what the policy's actions set: the CPG's parameters (the paper's CPG_RL) or the 18 joint targets (pure DRL)
ACTION_MODES = ("cpg", "joint")


@dataclass
class TerrainConfig:
    """The paper's terrains (§3.1). Lengths in metres; +x is the walking direction."""

    name: str = field(default="flat", metadata={"choices": TERRAINS})
    seed: int = 0
    # §3.1: rugged = square blocks of 4 cm^2 (2 cm x 2 cm), heights uniform in [0, 6 cm]
    block_size: float = 0.02
    block_height_max: float = 0.06
    # §3.1: stepped = 15 steps, 6 cm rise, 25 cm deep, 90 cm total rise
    step_count: int = 15
    step_rise: float = 0.06
    step_depth: float = 0.25
    # §3.1: complex = 1.5 m rugged followed by 1.5 m of steps
    complex_rugged_length: float = 1.5
    complex_stepped_length: float = 1.5
    # ours: metres of rugged blocks on the complex terrain's landing after its steps (block_height_max high, on the
    # landing's height, from the block lattice's first edge after the last step, up to x_max); 0: the flat landing of
    # §3.1. Training with them shows a policy blocks near its
    # goal, as the rugged course has them (studies/time_to_skill/recipes/kl_choice).
    complex_landing_blocks: float = 0.0
    # ours: where the steps begin on the stepped terrain (flat run-up so the robot starts on level ground)
    stepped_start_x: float = 0.5
    # ours: extent of the terrain patch: x in [x_min, x_max], |y| <= width / 2. 5 m across the walking
    # direction; the paper ends an episode at |y| > 1.5 m (§2.4.4), so everything reachable is inside.
    # The stepped terrain ends at 0.5 + 15 * 0.25 = 4.25 m, then a landing up to x_max.
    x_min: float = -1.0
    x_max: float = 5.0
    width: float = 5.0
    # ours: rugged blocks cover x in [x_min, rugged_x_max], |y| <= rugged_half_width (flat beyond). The
    # paper's longest task is 3 m (Table 3), so 4 m of blocks is enough and keeps the mesh small.
    rugged_x_max: float = 4.0
    rugged_half_width: float = 2.0
    # resolution of the in-kernel height query grid [m] (must divide block_size and step_depth)
    query_resolution: float = 0.01
    # ours: terrain curriculum (legged_gym style), off at 0. With levels = L > 0 the terrain is L
    # lanes side by side along y, each lane_width wide (replacing ``width``); lane k (0-based) is this
    # terrain with its block heights and step rise scaled by (k + 1) / L, so the last lane is the terrain
    # above (unless lanes go past it: ``levels_past``). Robots move up a lane after reaching the goal and down one
    # after walking less than half of it (mdp/events.py). 3 m = 2 x TaskConfig.max_abs_y: a robot leaves the course
    # as it leaves its lane.
    levels: int = 0
    lane_width: float = 3.0
    # ours: lanes past the course. The last ``levels_past`` of the ``levels`` lanes go beyond the terrain above, in
    # equal steps from it to the hardest lane's step rise, tread and block height (the ``hardest_*`` fields; None: the
    # terrain's own value), treads rounded to the query grid; the lanes before them scale the terrain by
    # (k + 1) / (levels - levels_past), so lane levels - levels_past - 1 is the terrain itself. 0: the last lane is
    # the terrain.
    levels_past: int = 0
    hardest_step_rise: float | None = None
    hardest_step_depth: float | None = None
    hardest_block_height_max: float | None = None
    # ours: when a robot on a lane past the course moves down one lane: "half", as on the others, after an episode that
    # walked less than half the way; "miss", after any episode that missed the goal. "miss" keeps robots near the
    # course's lane unless they master the lanes past it (studies/capability/report.md, 1062 iterations).
    past_down: str = field(default="half", metadata={"choices": ("half", "miss")})
    # ours: the share of episodes played on a lane past the course drawn at random (evenly among the ``levels_past``
    # lanes), whatever the robot's level; such an episode leaves the level as it is. Every robot then meets the
    # hardest lanes, however far it has climbed. 0: off; > 0 needs ``levels_past``
    past_share: float = 0.0
    # ours: lanes a robot moves up after reaching its goal. A robot climbs once per episode (~50 iterations of 24 steps
    # on the complex course), so a run of fewer iterations, e.g. one iteration count split over torchrun ranks, ends on
    # lower lanes (studies/scale_out/report.md: lane 3.3 of 9 after 150 iterations, 5.9 after 300); 2 climbs as fast
    # per iteration at half the iterations.
    climb: int = 1
    # robots start evenly spread over levels 0 .. start_levels - 1 (legged_gym: max_init_terrain_level)
    start_levels: int = 1
    # ours: where a training episode on the lanes starts along its lane: x drawn uniform in [0, start_progress] m
    # ahead of the lane's start, toward the same goal (``TaskConfig.goal_distance`` ahead of the lane's start), at the
    # spawn height above the ground there; a robot moves down a lane after walking less than half of its own way. More,
    # shorter episodes per robot, each lane's far ground met more often (studies/curriculum). 0: every episode starts
    # at the lane's start; evaluation and play always do.
    start_progress: float = 0.0
    # ours: courses trained beside this one. With levels = L > 0 and lane_courses = (c1, ...), the grid holds one group
    # of L lanes per course side by side along y (this terrain's first, then c1, ...; each as ``name`` would be, with
    # its own block seeds), and env i plays group i mod (1 + len(lane_courses)) on its curriculum level. (): this
    # terrain alone. A policy trained on the complex course sees 1.5 m of blocks before the stairs; with "rugged
    # stepped" it also walks the rugged and stepped courses whole, as validation and evaluation do.
    lane_courses: tuple[str, ...] = ()
    # ours: how the terrain collides (flat is always an infinite ground plane). "mesh_boxes" (the default): every
    # strip of constant height across the whole width (of a curriculum lane, with levels > 0) -- run-ups, stair
    # treads, landings, flat ground beyond the blocks -- as one static box, the rugged blocks as one triangle mesh,
    # all down to one common bottom; the same surface as "mesh", one closed triangle mesh of the whole grid, with
    # fewer mesh lookups per robot (none on stepped): 5 % more robot-s/s on complex, 36 % on stepped at 16384 envs
    # on an H100 (studies/time_to_skill/report.md, "Terrain contact"). "boxes": every rectangle of equal-height
    # cells one static box, each 2 cm rugged block one (~50,000 on rugged, the whole patch, as in the C MuJoCo
    # model), each robot shape paired only with the boxes under it (terrain/box_pairs.py): the box edges
    # MuJoCo's feet meet (studies/sim2sim/wedge/report.md).
    collision: str = field(default="mesh_boxes", metadata={"choices": TERRAIN_COLLISIONS})
    # ours: terrain meshes without T-junctions (terrain/mesh.py): every quad edge split at the vertices on it,
    # so each edge lies in exactly two triangles and Newton's finalize skips its mesh-boundary pass (complex task,
    # CPU: finalize 7.8 -> 2.9 CPU s, studies/startup_mesh), for 55 % more triangles of the same surface (nearly all
    # in walls) and twice the mesh build. Newton then signs mesh distances by ray parity instead of pseudo-normals
    # (mesh-mesh and particle contacts only). Off until its A/B on evaluation rounds holds (studies/startup_mesh).
    watertight: bool = False


@dataclass
class SimConfig:
    """Batched physics settings."""

    num_envs: int = 16
    device: str | None = None  # None: CUDA if present, else CPU
    # ours: 10 ms physics frame (collision detection once per frame) split into 4 MuJoCo steps of 2.5 ms.
    # Contacts found at the frame start are re-evaluated (distance, position) at every substep; a new
    # touch-down is caught in time while a shape approaches slower than rigid_gap / frame_dt = 0.5 m/s.
    # Measured on an H100 (studies/throughput/report.md): complex terrain 16384 envs ~5,000 robot-s/s with 5 ms frames,
    # ~6,800 with 10 ms frames; solver iterations barely matter (collision dominates).
    frame_dt: float = 0.010
    substeps: int = 4
    # ours: MuJoCo (mujoco_warp) solver settings
    solver: str = field(default="newton", metadata={"choices": ("newton", "cg")})
    iterations: int = 10
    ls_iterations: int = 10
    integrator: str = field(default="implicitfast", metadata={"choices": ("euler", "implicitfast", "implicit")})
    # ours: contact detection gap [m]. Newton's 0.1 m default overflows every buffer on 2 cm blocks; on the
    # rugged mesh a foot sees one contact per triangle within the gap: measured ~67 contacts per walking
    # robot at 0.01 m, ~39 at 0.005 m, ~26 at 0.002 m.
    rigid_gap: float = 0.005
    # ours: contact detection band of the terrain shape [m]; None: rigid_gap. Newton adds the two shapes' gaps, so
    # the default band between a foot and the terrain is 2 x rigid_gap = 1 cm
    terrain_gap: float | None = None
    # ours: Newton's speculative contacts (None: off). The band grows, for shapes approaching each other, by their
    # closing speed x frame_dt, capped at this [m], so rigid_gap can be small without missing fast touch-downs
    speculative_gap: float | None = None
    # per-world contact capacity handed to MuJoCo (nconmax; mujoco_warp pools it over all worlds) and
    # constraint rows per world (njmax; pyramidal friction cones take 4 rows per contact, plus joint
    # limits). A world may take more than its share of the contact pool: 352 rows overflowed once in
    # 4096 walking robots on complex terrain (H100), so njmax leaves room for ~110 contacts.
    contacts_per_env: int = 64
    # ours: the contact pool's least size, all worlds together (0: contacts_per_env x num_envs exactly). Thousands of
    # robots even out in the pool; a few on blocks do not: 4 walking the rugged course took up to 274 contacts
    # against 4 x 64, and the pool dropped them
    min_contact_pool: int = 4096
    constraints_per_env: int = 480
    # triangle-pair candidates per env for mesh terrain (H100, complex, 16384 envs: 64/env overflowed)
    triangle_pairs_per_env: int = 256
    use_graph: bool = True
    # ours: where each servo's effort limit clamps its torque: "joint" (Newton's way: the joint's actuator-force
    # range) or "actuator" (the controller bundle's MJCF: the actuator's force range). Under the implicitfast
    # integrator they differ: a joint clamp keeps the servo's damping in the implicit update at the limit, an
    # actuator clamp drops it, so a servo at its limit moves faster; C MuJoCo with the joint clamp wedges feet on the
    # rugged blocks as rarely as Newton (studies/sim2sim/wedge/report.md, "Which MuJoCo setting wedges")
    effort_clamp: str = field(default="joint", metadata={"choices": ("joint", "actuator")})
    # ours: which Warp modules a World compiles in parallel before its first step (hexnewton/physics/precompile.py):
    # "imported" those defined at import time, "generated" also the kernels mujoco_warp generates for the model
    # (created by a dry step), "auto" generated on a CUDA device and imported on the CPU. On one H100 with Warp's
    # kernel cache empty (the CUDA driver's JIT cache warm) train.py --task complex reached its first iteration 88 s
    # from process start with "auto", the first step 8.5 s; on a fresh machine 272-308 s with "auto" (260 s with
    # "imported"), the first step compiling the module variants the precompile leaves to it (timing.json lists
    # them); on the 2-core CPU a cold build took 149 s against 60 s (studies/time_to_skill/report.md)
    precompile: str = field(default="auto", metadata={"choices": ("auto", "imported", "generated")})
    # ours: env i starts at (0, y_i), y_i evenly spread over [-spread, spread] [m], so robots meet different
    # rugged blocks; goal and off-course limit (TaskConfig) are relative to each env's start
    spawn_y_spread: float = 0.5


#: The 15 high-level parameters (§2.4.2) in the order the policy emits them.
PARAM_NAMES = ("omega", "A1_R", "A1_L") + tuple(f"A2_{leg}" for leg in LEG_NAMES) + tuple(
    f"A3_{leg}" for leg in LEG_NAMES
)
#: The body-posture parameters (``CPGConfig.posture``, kernels/cpg.py), after the 15.
POSTURE_NAMES = ("P_h", "P_p", "P_r")
#: Oscillator of each leg (R1, R2, R3, L1, L2, L3): tripod {R1, L2, R3} on 0, {L1, R2, L3} on 1 (§2.2).
LEG_OSCILLATOR = (0, 1, 0, 1, 0, 1)


@dataclass
class CPGConfig:
    """Mid level (Eq. 3, two coupled Hopf oscillators) and low level (Eq. 4, mapping function).

    The paper names alpha, mu, omega_sw, omega_st, delta and theta but gives no values (§2.2); ours are
    marked. Frequencies are angular [rad/s]; amplitudes are joint angles [rad] added to the standing pose.
    """

    # ours: convergence rate to the limit cycle [1/s]; radial time constant 1 / (2 alpha mu) = 10 ms.
    # Eq. 3's coupling does not vanish at the lock (Delta_ji = y_i there), so the locked radius is
    # ~sqrt(mu + delta / (2 alpha)): alpha = 50, delta = 5 keep it within 2.5 % of sqrt(mu). RK4 at the
    # 2.5 ms substep stays stable for starts up to |x|, |y| <= 2 sqrt(mu).
    alpha: float = 50.0
    # Eq. 3: mu is the squared limit-cycle radius; 1 makes y/sqrt(mu) = y, as Eq. 4 assumes
    mu: float = 1.0
    # ours: coupling strength delta [1/s]; phase locking time constant ~1 / delta = 0.2 s
    delta: float = 5.0
    # §2.2: phase difference between the two oscillators; pi gives the tripod gait
    theta: float = math.pi
    # ours: duty factor (stance share of a cycle). Eq. 3 names omega_sw / omega_st: omega_sw =
    # omega / (2 (1 - duty)), omega_st = omega / (2 duty), so a cycle lasts 2 pi / omega at any duty.
    # 0.5 makes them equal. It is also the only duty two anti-phase oscillators agree on: at 0.35 or 0.65
    # the coupled pair runs up to 10 % fast at 0.5 Hz.
    duty: float = 0.5
    # ours: steepness of the logistic switch between omega_sw (x > 0: y rising, swing) and omega_st
    steepness: float = 50.0
    # ours: time constant [s] of the first-order filter the 15 parameters pass through at every substep,
    # so a new action never makes the joint targets jump
    param_tau: float = 0.03
    # ours: ranges of the 15 parameters; an action a in [-1, 1] maps to lo + (a + 1) / 2 * (hi - lo)
    omega_range: tuple[float, float] = (math.pi, 5.0 * math.pi)  # 0.5 - 2.5 Hz
    a1_range: tuple[float, float] = (0.0, 0.5)  # hip; the hip limit is pi/6 = 0.52 about the pose's 0
    # knee lift; 0.15 + 1.3 stays inside the knee limit pi/2. Eq. 4 lowers the foot as it reaches forward, so
    # a 6 cm step needs more lift than its height: fixed gaits with A2 <= 0.8 stop at the first or second
    # step, with A2 = 1.1 they climb 12 steps (CPU sweep, studies/physics_screen/report.md). Policies trained with
    # (0, 0.8) keep their ranges: play, evaluate, export and --resume read them from the checkpoint.
    a2_range: tuple[float, float] = (0.0, 1.3)
    a3_range: tuple[float, float] = (0.0, 0.8)  # ankle tuck; 0.15 + 0.8 < pi/3 keeps it inside the limit
    # ours: body posture (kernels/cpg.py), three more parameters after the 15: knee offsets [rad] for height
    # (P_h) and for pitch and roll (P_p, P_r: +-range at the front/rear and right/left legs). Off: the paper's 15
    # parameters; --env.cpg.posture true turns it on. The knee's standing angle is 0.15 above its lower limit.
    posture: bool = False
    posture_height_range: tuple[float, float] = (-0.15, 0.15)
    posture_tilt_range: tuple[float, float] = (-0.3, 0.3)
    # ours: levelling reflex gain [rad of knee per rad of body tilt] on the posture's tilt terms, at every substep
    # (kernels/cpg.py); 0 = off. Only with ``posture``.
    posture_reflex: float = 0.0
    # ours: a way out for a caught foot (kernels/cpg.py, "Stuck response"; studies/sim2sim/wedge/report.md): a robot
    # whose goal distance, read from the policy's own target observation, fell by less than stuck_progress [m] over
    # the last stuck_window control steps walks the next stuck_hold control steps with stuck_lift [rad] more knee
    # amplitude A2 on every leg; then, and while it still gains no ground, again. 0 = off.
    stuck_lift: float = 0.0
    stuck_window: int = 100  # control steps: 2 s at the tasks' 20 ms
    stuck_progress: float = 0.02
    stuck_hold: int = 50  # control steps: 1 s
    # ours: the fixed-parameter "CPG" baseline (§3.3), tuned to walk straight on flat ground
    fixed_omega: float = 3.0 * math.pi  # 1.5 Hz
    fixed_a1: float = 0.3
    fixed_a2: float = 0.5
    fixed_a3: float = 0.5
    # the robot's: the amplitudes above (ranges, fixed gaits, posture, stuck lift) are the paper robot's, scaled per
    # joint kind (hip A1, knee A2 and posture, ankle A3) for a robot whose joints reach less far (robot.geometry.
    # amplitude_scale; 1 for the paper's). Set with the robot (robot.registry.with_robot), no flag of its own
    amplitude_scale: tuple[float, float, float] = field(default=(1.0, 1.0, 1.0), metadata={"flag": False})

    def fixed_params(self, gait: str = "default") -> list[float]:
        """A fixed baseline's 15 parameters in PARAM_NAMES order: ``default`` (the ``fixed_*`` fields) or a gait of
        ``FIXED_GAITS`` (``swept``: the best of the documented sweep, ``studies/cpg_sweep/sweep.py``), its amplitudes
        scaled for the robot (``amplitude_scale``)."""
        omega, a1, a2, a3 = (self.fixed_omega, self.fixed_a1, self.fixed_a2, self.fixed_a3) if gait == "default" \
            else FIXED_GAITS[gait]
        s1, s2, s3 = self.amplitude_scale
        return self.with_posture(gait_params(omega, a1 * s1, a2 * s2, a3 * s3)).tolist()

    def with_posture(self, params):
        """Parameters (..., 15) or (..., num_params) as (..., num_params): a 15-parameter gait gets the neutral
        posture (zeros) when ``posture`` is on."""
        import numpy as np

        p = np.asarray(params, np.float64)
        return np.concatenate([p, np.zeros(p.shape[:-1] + (self.num_params - p.shape[-1],))], axis=-1)

    @property
    def num_params(self) -> int:
        """15 (Eq. 4), or 18 with the body posture."""
        return 18 if self.posture else 15

    @property
    def param_names(self) -> tuple[str, ...]:
        return PARAM_NAMES + (POSTURE_NAMES if self.posture else ())

    def param_ranges(self) -> tuple[list[float], list[float]]:
        """(lower, upper) bounds of the parameters in ``param_names`` order, the amplitudes' scaled for the robot."""
        s1, s2, s3 = self.amplitude_scale
        scale = [1.0] + [s1] * 2 + [s2] * 6 + [s3] * 6 + ([s2] * 3 if self.posture else [])
        rows = [self.omega_range] + [self.a1_range] * 2 + [self.a2_range] * 6 + [self.a3_range] * 6
        if self.posture:
            rows += [self.posture_height_range] + [self.posture_tilt_range] * 2
        return [r[0] * k for r, k in zip(rows, scale)], [r[1] * k for r, k in zip(rows, scale)]

    @property
    def tilt_max(self) -> float:
        """The body posture's largest tilt term [rad of knee], scaled for the robot (the levelling reflex's clamp)."""
        return self.posture_tilt_range[1] * self.amplitude_scale[1]

    @property
    def lift(self) -> float:
        """The stuck response's knee lift [rad], scaled for the robot."""
        return self.stuck_lift * self.amplitude_scale[1]


def gait_params(omega: float, a1: float, a2: float, a3: float) -> list[float]:
    """One fixed gait (the same amplitude on every leg) as the 15 parameters in PARAM_NAMES order."""
    return [omega] + [a1] * 2 + [a2] * 6 + [a3] * 6


#: Fixed CPG gaits (omega [rad/s], A1, A2, A3 [rad]) besides ``CPGConfig.fixed_*``: ``swept`` is the best gait of the
#: sweep in studies/cpg_sweep (``python studies/cpg_sweep/sweep.py``; highest mean success at 3 m over rugged,
#: stepped and complex ground, then the lowest pitch + roll variance), the fair fixed baseline.
FIXED_GAITS = {"swept": (2.0 * math.pi, 0.2, 0.9, 0.3)}


@dataclass
class TaskConfig:
    """Episode definition (§2.4.4) shared by play, evaluation and the RL environment."""

    # ours: one high-level decision every control_dt [s] (a multiple of SimConfig.frame_dt)
    control_dt: float = 0.02
    # each env's goal lies this far ahead of its start along +x: with the 0.5 m goal radius, success means
    # 3 m walked, Table 3's longest distance (§3.4)
    goal_distance: float = 3.5
    # §2.4.4 (3): within this distance of the goal the task is complete
    goal_radius: float = 0.5
    # §2.4.4 (1): fallen below this torso height above the terrain [m] (x height_scale), or |roll| / |pitch| > pi/3
    min_height: float = 0.05
    max_tilt: float = math.pi / 3
    # §2.4.4 (2): off course beyond |y - y_start| [m] (from the start-to-goal line); time out after this many steps
    max_abs_y: float = 1.5
    max_episode_steps: int = 7000
    # ours: a state is "blown up" (status nonfinite: reset and counted) when any coordinate or velocity is
    # NaN/Inf, or runs away: base speed above max_base_speed [m/s] (the robot walks at < 0.5 m/s) or any
    # joint speed above max_joint_speed [rad/s] (a 2.5 Hz gait of 0.8 rad amplitude peaks near 13 rad/s)
    max_base_speed: float = 20.0
    max_joint_speed: float = 200.0
    # ours: start randomisation at every reset (robots sharing one terrain must not all see the same ground)
    reset_lateral: float = 0.1  # [m] on top of the env's lane (SimConfig.spawn_y_spread)
    reset_yaw: float = 0.2  # [rad]
    reset_joint_noise: float = 0.05  # [rad]
    seed: int = 0
    # ours: the pure-DRL action mode's joint targets, standing pose + joint_action_scale * action [rad], clipped
    # to the limits (kernels/cpg.py); 0 spans each joint's whole limit range with the actions
    joint_action_scale: float = 0.5
    # the episode ends this task checks, rows of mdp/terms/terminations.py's TERMINATIONS in their order (nonfinite
    # always)
    terminations: tuple[str, ...] = ("nonfinite", "fell", "off_course", "success", "timeout")
    # ours: goals in every direction (the navigate tasks; mdp/terms/goals.py). Off: the paper's one goal, goal_distance
    # ahead of the start along +x. On: each goal at a bearing uniform in +-goal_bearing [rad] from the robot's heading
    # when it is set, goal_distance_min..max [m] away, inside +-goal_area [m] of the start along x and y (mirrored
    # back into that square); reaching one sets the next and the episode goes on
    random_goals: bool = False
    goal_bearing: float = math.pi
    goal_distance_min: float = 1.0
    goal_distance_max: float = 4.0
    goal_area: float = 4.0
    # ours: a waypoint course ((x, y), ...) [m] in each robot's start frame (x along its start heading), the goals in
    # turn; reaching the last ends the episode (play.py --waypoints); empty: none
    waypoints: tuple[tuple[float, float], ...] = ()
    # the robot's standing height and footprint over the paper robot's (robot.geometry.height_scale, length_scale; 1
    # for the paper's): min_height and Table 1's height terms scale with height_scale, the observed heights (target z,
    # terrain h) are divided by it, h looks over a square length_scale times the paper's. Set with the robot
    # (robot.registry.with_robot), no flag of its own
    height_scale: float = field(default=1.0, metadata={"flag": False})
    length_scale: float = field(default=1.0, metadata={"flag": False})


#: Table 1's terms (Eq. 5), the reward of the paper's task
PAPER_REWARD_TERMS = ("height", "direction", "distance", "stability", "forward")


@dataclass
class RewardConfig:
    """Table 1 / Eq. 5 weights. The paper names w_h, w_d, w_theta but gives no values (docs/internals.md, "The
    MDP")."""

    w_height: float = 1.0  # ours
    w_direction: float = 1.0  # ours
    w_distance: float = 1.0  # ours
    # heading error [rad] within which the direction term is silent. Table 1's condition "θ > π/6" would be
    # math.pi / 6 (``--env.reward.direction_deadband 0.5236``); ours is 0: with the π/6 dead band a policy never learns
    # to correct start-yaw errors below 30° (H100, flat, 150 iterations: 32/64 vs 63/64 reach the goal from
    # ±0.2 rad start yaw, docs/evaluation.md "Conventions").
    direction_deadband: float = 0.0
    # ours: Table 1's D is the start-to-goal vector; True takes it from the robot to the goal, so the direction
    # term steers back toward a goal the robot has drifted away from (docs/internals.md). False: the paper's.
    direction_to_goal: bool = True
    stability_penalty: float = 100.0  # Table 1: r_s = -100, weight 1
    stability_tilt: float = math.pi / 6  # Table 1: r_s while |roll| or |pitch| > pi/6 [rad] (docs/internals.md)
    forward_penalty: float = 0.3  # Table 1: r_f = -0.3, weight 1
    # ours: more than w_d / (1 - gamma) = 100, what lingering by the goal is worth (docs/internals.md)
    goal_bonus: float = 300.0
    # ours: paid once on leaving the course (§2.4.4 (2)); without it PPO walks off the course when stuck at a
    # step (docs/internals.md). 0 restores the paper's reward.
    off_course_penalty: float = 100.0
    # ours: paid once on falling (§2.4.4 (1)), beside r_s's -100 on that step; 0 (off) in every task (docs/training.md:
    # 300 and 1000 did not lower the complex recipe's rugged falls)
    fall_penalty: float = 0.0
    # ours: gait-quality terms (docs/internals.md, "Stability shaping"), each per 20 ms step and 0 = off (Table 1
    # has only the -100 fine beyond pi/6). Body tilt: -w_tilt (roll^2 + pitch^2) [rad^2]; body roll and pitch rate:
    # -w_ang_vel (w_x^2 + w_y^2) [(rad/s)^2, body frame]; action rate: -w_action_rate sum_k (a_k - a_k,prev)^2 over
    # the 15 actions in [-1, 1]. Off here; train.py's recipes for the paper's terrains switch them on
    # (tasks.STABLE_SHAPING: 5 / 0.05 / 0.1), ``paper_reward()`` switches them off with the other additions.
    w_tilt: float = 0.0
    w_ang_vel: float = 0.0
    w_action_rate: float = 0.0
    # ours: lateral offset from the start-to-goal line, -w_lateral (y - y_start)^2 [m^2] per 20 ms step; 0 = off. The
    # direction term alone barely minds a drift far from the goal (0.4 m at 3 m: 1 - cos 7.6 deg = 0.009) and turns
    # the robot hard near it; rugged rounds that end badly past 3 m grow with the drift
    # (studies/time_to_skill/recipes/kl_choice).
    w_lateral: float = 0.0
    # the terms this task pays, rows of mdp/terms/rewards.py's REWARD_TERMS (logged as Reward/<name>, summed in table
    # order)
    terms: tuple[str, ...] = ("height", "direction", "distance", "stability", "forward", "goal", "off_course", "fall",
                              "tilt", "ang_vel", "action_rate", "lateral")

    def paper_reward(self) -> "RewardConfig":
        """Table 1 as written: its five terms alone (no goal bonus, no off-course penalty, no gait-quality terms, their
        weights 0 as well), the π/6 dead band on the start-to-goal direction (the weights w_h, w_d, w_theta, which the
        paper does not give, stay ours)."""
        from dataclasses import replace

        return replace(self, direction_deadband=math.pi / 6, direction_to_goal=False, goal_bonus=0.0,
                       off_course_penalty=0.0, fall_penalty=0.0, stability_tilt=math.pi / 6, w_tilt=0.0, w_ang_vel=0.0,
                       w_action_rate=0.0, w_lateral=0.0, terms=PAPER_REWARD_TERMS)  # fmt: skip


@dataclass
class RandomizationConfig:
    """Domain randomisation for sim-to-real (ours). Off by default and in the paper's setting.

    Drawn once per env when the world is built (uniform in each range): foot-ground friction, base payload,
    leg link masses, PD gains and effort limits, and where set the foot radius and the contact time constant. Every
    step: observation noise. Actions act one control step late in a share of the envs (actuation latency). Every
    ``push_interval`` seconds: a push, a random horizontal change of the base velocity."""

    enabled: bool = False
    friction: tuple[float, float] = (0.4, 1.2)  # friction coefficient of the robot's contacts (default 0.9)
    payload: tuple[float, float] = (-0.2, 0.6)  # mass added to the torso [kg] (torso 1.6 kg)
    link_mass_scale: tuple[float, float] = (0.8, 1.2)
    kp_scale: tuple[float, float] = (0.8, 1.2)
    kd_scale: tuple[float, float] = (0.8, 1.2)
    effort_scale: tuple[float, float] = (0.8, 1.2)
    # motor strength (None: off): one more factor per env on both the PD stiffness and the effort limits, on top of
    # their own kp_scale and effort_scale draws, so weak motors meet weak gains as in the evaluation's motor_strength
    # (hexnewton.analysis.rollout.sweep_overrides)
    motor_strength: tuple[float, float] | None = None
    # contact geometry and softness (None: the robot's own): the foot sphere's radius [m] (nominal 12 mm; its centre
    # stays at the tibia's end) and the time constant [s] of the robot's contacts with the ground (MuJoCo's solref,
    # damping ratio 1; nominal 0.02)
    foot_radius: tuple[float, float] | None = None
    contact_timeconst: tuple[float, float] | None = None
    latency_share: float = 0.5  # share of envs whose actions take effect one control step (20 ms) late
    # uniform observation noise amplitudes: joint positions [rad], joint velocities [rad/s], target [m],
    # quaternion components, max terrain height [m], gyro [rad/s] (CPG parameters and the last actions are the
    # controller's own: no noise)
    noise_joint_pos: float = 0.01
    noise_joint_vel: float = 0.5
    noise_target: float = 0.05
    noise_quat: float = 0.02
    noise_height: float = 0.01
    noise_gyro: float = 0.2  # base angular velocity [rad/s] (with ObsConfig.gyro)
    push_interval: float = 6.0  # [s]
    push_velocity: float = 0.3  # largest horizontal base velocity change [m/s]


@dataclass
class ObsConfig:
    """What the networks read beyond the paper's state (ours; all off: the paper's observation for actor and critic,
    §2.4.1). ``gyro`` and ``last_action`` add columns to the policy's observation (the actor's, and the critic's too),
    which the robot's runtime assembles from its sensors (``hexnewton.deploy.runtime``); ``critic`` gives the critic a
    group of privileged state the robot does not sense (``hexnewton/mdp/terms/critic.py``)."""

    # the base angular velocity in the body frame [rad/s], an IMU's gyro (noise: RandomizationConfig.noise_gyro)
    gyro: bool = False
    # the policy's last actions, clamped to [-1, 1] as the action kernel applies them; 0 before an episode's first
    last_action: bool = False
    # the critic's own observation group ``critic`` (rsl-rl's obs_groups: actor ["policy"], critic ["policy",
    # "critic"]): base velocities, terrain heights around the feet and ahead of the body, the lower legs' contact
    # forces, the env's randomised physics and the CPG's phases; the actor's input stays the policy group
    critic: bool = False


@dataclass
class HexConfig:
    robot: RobotConfig = field(default_factory=RobotConfig)
    terrain: TerrainConfig = field(default_factory=TerrainConfig)
    sim: SimConfig = field(default_factory=SimConfig)
    cpg: CPGConfig = field(default_factory=CPGConfig)
    task: TaskConfig = field(default_factory=TaskConfig)
    reward: RewardConfig = field(default_factory=RewardConfig)
    randomization: RandomizationConfig = field(default_factory=RandomizationConfig)
    obs: ObsConfig = field(default_factory=ObsConfig)


def control_decimation(control_dt: float, frame_dt: float) -> int:
    """Physics frames per control step; ValueError unless ``control_dt`` is a positive multiple of ``frame_dt``."""
    ratio = control_dt / frame_dt if frame_dt > 0 else 0.0
    if control_dt <= 0 or ratio < 0.5 or abs(ratio - round(ratio)) > 1e-6:
        raise ValueError(f"task.control_dt ({control_dt}) must be a positive multiple of sim.frame_dt ({frame_dt})")
    return int(round(ratio))


def terrain_for_goal(terrain: TerrainConfig, goal_distance: float) -> TerrainConfig:
    """``terrain`` with its patch reaching at least 1 m beyond a goal ``goal_distance`` ahead (x_max on a 0.5 m
    grid; the default 5 m patch holds the paper's 3.5 m goal)."""
    from dataclasses import replace

    need = math.ceil(2.0 * (goal_distance + 1.0)) / 2.0
    return terrain if need <= terrain.x_max else replace(terrain, x_max=need)


def without_lanes(terrain: TerrainConfig, **fields) -> TerrainConfig:
    """``terrain`` as one course, no curriculum: no lanes and nothing only lanes use (``start_levels``,
    ``start_progress``, ``past_share``, ``lane_courses``), then ``fields``."""
    from dataclasses import replace

    return replace(terrain, levels=0, start_levels=1, start_progress=0.0, past_share=0.0, lane_courses=(), **fields)


def _as_tuples(v):
    """Lists (JSON's and ``asdict``'s form of tuples) back to tuples, at any depth; dicts stay dicts."""
    if isinstance(v, (list, tuple)):
        return tuple(_as_tuples(x) for x in v)
    if isinstance(v, dict):
        return {k: _as_tuples(x) for k, x in v.items()}
    return v


def dataclass_from_dict(cls, values: dict):
    """Rebuild dataclass ``cls`` from ``dataclasses.asdict`` output: nested dataclasses recursively (a field's
    dataclass, optional dataclass or tuple of dataclasses, as its annotation says), lists as tuples; missing fields
    keep their defaults, unknown keys are ignored (configs written by older or newer versions load)."""
    import dataclasses
    import typing

    hints = typing.get_type_hints(cls)
    out = {}
    for f in dataclasses.fields(cls):
        if f.name not in (values or {}):
            continue
        out[f.name] = _from_value(hints[f.name], values[f.name])
    return cls(**out)


def _from_value(hint, v):
    """``v`` (plain data) as annotation ``hint`` says: a dataclass, a tuple of them or None, else :func:`_as_tuples`."""
    import dataclasses
    import types
    import typing

    args = typing.get_args(hint)
    if typing.get_origin(hint) in (typing.Union, types.UnionType):
        if v is None:
            return None
        hint = next(a for a in args if a is not type(None))
        args = typing.get_args(hint)
    if dataclasses.is_dataclass(hint) and isinstance(v, dict):
        return dataclass_from_dict(hint, v)
    if typing.get_origin(hint) is tuple and args and dataclasses.is_dataclass(args[0]) and isinstance(v, (list, tuple)):
        return tuple(dataclass_from_dict(args[0], x) if isinstance(x, dict) else x for x in v)
    return _as_tuples(v)


def config_from_dict(d: dict) -> HexConfig:
    """Rebuild a :class:`HexConfig` from ``dataclasses.asdict`` output (a checkpoint's or config.json's "config")."""
    return dataclass_from_dict(HexConfig, d or {})


def apply_overrides(obj, overrides: dict):
    """``obj`` (a dataclass tree) with ``{"sim.frame_dt": 0.02, ...}`` set; ValueError for a path it does not have."""
    import dataclasses

    out = obj
    for path, value in overrides.items():
        def put(o, keys):
            names = {f.name for f in dataclasses.fields(o)}
            if keys[0] not in names:
                raise ValueError(f"{type(obj).__name__} has no field '{path}'")
            if len(keys) == 1:
                return dataclasses.replace(o, **{keys[0]: value})
            return dataclasses.replace(o, **{keys[0]: put(getattr(o, keys[0]), keys[1:])})

        out = put(out, path.split("."))
    return out

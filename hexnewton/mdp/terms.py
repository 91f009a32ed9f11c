"""The MDP's terms (Huang et al. 2025, §2.4), by kind: episode ends, rewards and observations, one table and one fused
kernel each.

After the physics frames of a control step the env (``hexnewton/mdp/env.py``) launches, in this order,
:func:`episode_status_kernel` (which ends each env's episode, and why), the rewards kernel of the task's reward terms
(:func:`make_rewards_kernel`), then, after the resets of the finished envs (``hexnewton/mdp/events.py``),
:func:`observations_kernel`. Each kind declares its terms once, in a table of rows (name, parameters, a ``@wp.func`` for
one env, a float64 NumPy function for all envs): ``TERMINATIONS``, ``REWARD_TERMS``, ``OBS_TERMS``. The fused kernel,
the log names and the float64 reference follow from the table, so adding a term touches its row (and, for a new
parameter, its config field). A task chooses its rows: ``TaskConfig.terminations``, ``RewardConfig.terms`` (with
their weights in ``RewardConfig``) and the observation layout of its action mode (:data:`LAYOUTS`).

Term tables
-----------
Each of those modules declares its terms once, as a tuple of frozen dataclass rows (name, parameters, a Warp
function, a float64 NumPy function). One fused kernel per table runs every row's Warp function in table order:
``for k in range(wp.static(len(TABLE)))`` is unrolled at code generation, and ``wp.static(TABLE[k].func)`` calls the
row's function directly, so the compiled kernel is the hand-written one (no indirection, one launch).

The term functions read the configuration through :data:`TaskParams` and :data:`RewardParams`, Warp structs generated
from ``TaskConfig`` and ``RewardConfig``: one member per scalar field (float, int, bool), same name. A term that
needs a new parameter therefore needs only the config field (``i.task.<field>`` / ``i.reward.<field>`` in the term).
:func:`make_struct` fills a struct instance and converts the config dataclasses.

Episode ends (§2.4.4)
---------------------
Each env's episode status is a code: 0 running, else why the episode ended. ``STATUS_NAMES[code]`` is its name
(``Episode/<name>_rate`` in the training log).

``TERMINATIONS`` declares each end once, one :class:`Termination` row per status code, in the order the kernel
checks them (the first that holds is the env's status; 0, running, if none does):
  5 nonfinite  the physics blew up: NaN/Inf in any coordinate or velocity, or a runaway (base speed above
               ``max_base_speed``, a joint speed above ``max_joint_speed``); the env is reset and counted;
  1 fell       the torso is less than ``min_height`` above the terrain under it, or |roll| or |pitch| exceeds
               ``max_tilt`` (§2.4.4 (1));
  2 off course |y - y_start| > ``max_abs_y`` (§2.4.4 (2));
  3 success    within ``goal_radius`` of the goal, ``goal_distance`` ahead of the env's start (§2.4.4 (3));
  4 timeout    this step is the episode's ``max_episode_steps``-th (``episode_steps`` counts the steps before it)
               (§2.4.4 (2)).
The codes and names live in ``mdp/status.py`` (plain Python, for tools that do not load Warp); each row adds the
condition as a ``@wp.func`` of (:class:`EndInputs`, :class:`EndFrame`) and as a float64 NumPy function of the same
inputs (:func:`end_frame_np`). The kernel (:func:`episode_status_kernel`, the rows unrolled with ``wp.static``), the
float64 reference (:func:`episode_status_np`) and the episode statistics' names (``Episode/<name>_rate``, env.py)
follow from the table. Adding an end: its code and name in ``reference.py``, its row here (and a ``TaskConfig`` field
for a new threshold, read as ``i.task.<field>``).

The kernel also writes roll, pitch and yaw (ZYX Euler angles of the base quaternion; 0 for a blown-up env) for
observations, rewards, logging and recording.

Rewards (Table 1 and Eq. 5)
---------------------------
R_t = w_h r_h + w_d r_d + w_theta r_theta + r_f + r_s   (Eq. 5)   + r_goal + r_off (ours)

The paper leaves the weights, the direction condition and its step length unstated. Our choices follow.

**Units.** Per-step terms are quoted for a 20 ms control step (``REF_DT``) and scaled by
``control_dt / REF_DT``, so they mean the same per second at any control rate. The one-off success bonus is
not scaled.

**The terms** (z is the torso height above the terrain under it, because the terrain height varies):
- r_h (height), "(z_r - 0.11), condition z_r > 0.12": exactly that, and 0 otherwise.
- r_theta (direction), "(cos θ, sin θ) · D / ||D||, condition θ > π/6". Taken literally, a term paid only
  outside the ±30° cone would be largest just outside it. We therefore read the condition as "heading error
  beyond π/6" and pay min(0, (cos θ, sin θ) · D̂ - cos(π/6)) (π/6 is ``RewardConfig.direction_deadband``).
  That is 0 inside the cone and falls continuously to -1 - cos(π/6) = -1.87 when walking backward. The paper's
  D is the start-to-goal vector; ours (``RewardConfig.direction_to_goal``) is the robot-to-goal vector. With
  the start-to-goal D, a robot that has drifted sideways is paid for walking parallel to the goal line and
  past the goal circle (without it, 94 % of a complex run's episodes walked past the goal and off the course).
  The default dead band is 0 (ours, ``RewardConfig``): inside Table 1's ±30° cone nothing asks the policy to
  correct a heading error, and the goal circle (0.5 m at 3.5 m) allows only ~8°.
- r_d (distance), "exp(-(d_n - d_t))": d_n is the distance to the goal and d_t the goal radius, so
  r_d = 1 on reaching the goal.
- r_s (stability), "-100 if z_r < 0.05 or |θ_y| > π/6 or |θ_x| > π/6", weight 1. Paid per (20 ms) step while
  the condition holds. A fall (z < 0.05, or tilt > π/3) ends the episode at that step. The π/6 is
  ``RewardConfig.stability_tilt`` (``train.py --stability_tilt``): climbing 8 cm stairs pitches this robot's
  torso by 19-25° on average (its stance pose is fixed, so the body follows the feet: front feet one or two steps
  above the rear ones), and a -100 fine on every step beyond 30° makes falling cheaper than climbing.
- r_f (forward), "-0.3 if x_r - x_pr < 0.01", weight 1. The paper's step is unstated. 1 cm per 20 ms would
  be 0.5 m/s, twice what the fixed CPG walks. We read the threshold as a speed, ``FORWARD_MIN_SPEED`` =
  0.1 m/s along +x (the start-to-goal direction), i.e. 2 mm per 20 ms step.
- r_goal (ours), +300 when the goal is reached. The episode ends there, so without a bonus the paper's
  rewards would pay more for lingering just outside the goal radius than for entering it. The bonus must
  beat what lingering is worth: r_d is ~1 at the circle's edge, so with gamma = 0.99 walking past it is worth
  up to w_d / (1 - gamma) = 100. A bonus of 100 made missing and entering the circle equal,
  and runs without it stopped aiming (RESULTS.md); 300 makes entering worth three times as much.
- r_off (ours), -100 once when the robot leaves the course (|y - y_start| > 1.5 m, §2.4.4 (2)), as much as
  a fall. Table 1 fines falls but not leaving the course, and a robot stuck at a step earns about -0.07 per
  step (r_f = -0.3 against r_d ~ 0.2 two metres from the goal). Without r_off, PPO learnt to end such
  episodes by walking sideways off the course: on complex terrain 98 % of the training episodes ended off
  course (RESULTS.md). With gamma = 0.99 the discounted cost of lingering is ~ -7, far above -100.

Weights (ours, marked in ``RewardConfig``): w_h = 1, w_d = 1, w_theta = 1.

**Stability shaping** (ours, the table's last three rows; each weight 0 switches its term off,
``RewardConfig.paper_reward()`` all of them). Table 1 fines a tilt only beyond π/6, so inside ±30° a policy is free
to rock the body, and with a -100 cliff at 30° it learns nothing about how far it is from it. Three smooth costs
per 20 ms step (scaled like the others):
- r_tilt = -w_tilt (roll² + pitch²) [rad²]: 10° of pitch costs 0.06 w_tilt, 30° 0.55 w_tilt;
- r_ang_vel = -w_ang_vel (ω_x² + ω_y²), the body's roll and pitch rates [rad/s] in its own frame: the rocking
  that a tilt average hides;
- r_action_rate = -w_action_rate Σ_k (a_k - a_k,prev)² over the 15 actions in [-1, 1] (0 on an episode's first
  step): the CPG parameters should change with the ground, not every control step.

**The table.** ``REWARD_TERMS`` declares every term once, one :class:`RewardTerm` row per term in column order:
its name (logged as ``Reward/<name>``), the ``RewardConfig`` field that weighs it, whether it is paid per 20 ms step
(scaled by ``control_dt / REF_DT``) or once, whether it is a cost (paid as -weight x value), a ``@wp.func`` that
computes its unweighted value for one env from :class:`RewardInputs` and the env's :class:`RewardFrame`, and a
float64 NumPy function of the same value for all envs (from a namespace with the same fields as NumPy arrays and the
frame of :func:`reward_frame_np`). From the table follow the kernel (:func:`make_rewards_kernel`; one launch: the
frame, then each row's function unrolled with ``wp.static``, times its weight and scale, written to ``terms[:, k]``
and summed into ``reward`` in table order), the log names (``TERMS``), the weight vector (:func:`reward_weights`)
and the float64 reference (:func:`rewards_reference`, weighted and summed the same way). A term computed from the
simulator state (``state=True``) is 0 for an env whose base position is not finite (a blown-up env, reset and counted
by the caller), and any term whose value is not finite is 0: training never sees a NaN.

Adding a term touches two places: its row in ``REWARD_TERMS`` with its ``@wp.func`` and NumPy function (both read
``i.task.<field>`` / ``i.reward.<field>`` for any ``TaskConfig`` / ``RewardConfig`` field: the term tables' structs
makes the structs from the dataclasses), and, for a new weight or parameter, its field in ``RewardConfig``. The env
sizes ``terms``, launches the kernel and logs ``Reward/<name>`` from the table; ``tests/mdp/test_terms.py`` checks every
row's Warp function against its NumPy function.

Observations (§2.4.1)
---------------------
The policy's observation (Huang et al. 2025, §2.4.1), one kernel for every env. The layout lives here only.

The paper says the state has 59 dimensions but lists only 54:
- 18 joint positions;
- 18 joint velocities;
- the target position (x, y, z);
- the 14 amplitudes A1[2], A2[6], A3[6];
- the maximum terrain height h.

We add omega (the fifteenth CPG parameter) and the base orientation as a unit quaternion, which makes 59.

``OBS_TERMS`` declares each part once, one :class:`ObsTerm` row per part in layout order: name, size, meaning, the
``RandomizationConfig`` field of its noise amplitude (None: exact), the layouts that carry it, a ``@wp.func`` that
writes its values for one env and a float64 NumPy function of the same values for all envs. From the table follow
``OBS_LAYOUT`` (name, start, end per layout), ``OBS_DIM``, the noise per column (:func:`observation_noise`), the
kernel (:func:`observations_kernel`, the rows unrolled with ``wp.static``, one launch for every layout), the float64
reference (:func:`observations_reference`) and the layouts below. Adding a part: its row here; ``hexnewton.deploy.runtime``
assembles the same parts from the robot's sensors by name.

Layouts (from the table):
"""


import dataclasses
import functools
from dataclasses import dataclass
from typing import Callable

import numpy as np
import warp as wp
from warp._src.codegen import Struct

from hexnewton.config import RewardConfig, TaskConfig
from hexnewton.mdp.status import FELL, NONFINITE, OFF_COURSE, RUNNING, STATUS_NAMES, SUCCESS, TIMEOUT
from hexnewton.physics.cpg import quat_to_rpy
from hexnewton.physics.reference import quat_rotate_inv_np, quat_to_rpy_np
from hexnewton.physics.terrain.heightmap import HeightGrid

# ====================================================================================================
# the ground as the terms see it: a height grid on the device (float64 references: physics/terrain/query.py)
# ====================================================================================================

@wp.struct
class HeightField:
    """Device copy of a :class:`HeightGrid` (a terrain's exact heights); cell (i, j) spans x0 + [i, i+1) / inv_res in x."""

    heights: wp.array2d(dtype=wp.float32)
    x0: float
    y0: float
    inv_res: float
    nx: int
    ny: int


def height_field_from_grid(grid: HeightGrid, device: wp.DeviceLike = None) -> HeightField:
    """Upload ``grid`` to ``device`` as a :class:`HeightField` (the struct keeps the array alive)."""
    hf = HeightField()
    hf.heights = wp.array(np.ascontiguousarray(grid.heights, dtype=np.float32), dtype=wp.float32,
                          device=device)
    hf.x0 = float(grid.x0)
    hf.y0 = float(grid.y0)
    hf.inv_res = float(1.0 / grid.res)
    hf.nx = int(grid.nx)
    hf.ny = int(grid.ny)
    return hf


@wp.func
def _cell_index(coord: float, origin: float, inv_res: float, n: int) -> int:
    """Index of the cell containing ``coord``, clamped to [0, n - 1]."""
    return wp.clamp(int(wp.floor((coord - origin) * inv_res)), 0, n - 1)


@wp.func
def terrain_height(hf: HeightField, x: float, y: float) -> float:
    """Terrain height at (x, y): the height of the (clamped) cell containing the point."""
    i = _cell_index(x, hf.x0, hf.inv_res, hf.nx)
    j = _cell_index(y, hf.y0, hf.inv_res, hf.ny)
    return hf.heights[i, j]


@wp.func
def max_terrain_height(hf: HeightField, x: float, y: float, half_extent: float) -> float:
    """Highest cell overlapping the square [x - half_extent, x + half_extent] x [y - ..., y + ...]."""
    i0 = _cell_index(x - half_extent, hf.x0, hf.inv_res, hf.nx)
    i1 = _cell_index(x + half_extent, hf.x0, hf.inv_res, hf.nx)
    j0 = _cell_index(y - half_extent, hf.y0, hf.inv_res, hf.ny)
    j1 = _cell_index(y + half_extent, hf.y0, hf.inv_res, hf.ny)
    h = hf.heights[i0, j0]
    for i in range(i0, i1 + 1):
        for j in range(j0, j1 + 1):
            h = wp.max(h, hf.heights[i, j])
    return h


@wp.kernel
def sample_heights_kernel(
    hf: HeightField,
    points: wp.array(dtype=wp.vec3),
    half_extent: float,
    height_out: wp.array(dtype=wp.float32),
    max_out: wp.array(dtype=wp.float32),
):
    """Per point: terrain height under it and the max height over its square footprint."""
    tid = wp.tid()
    p = points[tid]
    height_out[tid] = terrain_height(hf, p[0], p[1])
    max_out[tid] = max_terrain_height(hf, p[0], p[1], half_extent)


def sample_heights(
    hf: HeightField, points_np: np.ndarray, half_extent: float, device: wp.DeviceLike = None
) -> tuple[np.ndarray, np.ndarray]:
    """Host helper: run :func:`sample_heights_kernel` on (N, 2) or (N, 3) points; returns (h, hmax)."""
    pts = np.asarray(points_np, dtype=np.float32)
    if pts.ndim != 2 or pts.shape[1] not in (2, 3):
        raise ValueError(f"points must have shape (N, 2) or (N, 3), got {pts.shape}")
    if pts.shape[1] == 2:
        pts = np.concatenate([pts, np.zeros((len(pts), 1), dtype=np.float32)], axis=1)
    n = len(pts)
    points = wp.array(pts, dtype=wp.vec3, device=device)
    h = wp.zeros(n, dtype=wp.float32, device=device)
    hmax = wp.zeros(n, dtype=wp.float32, device=device)
    if n > 0:
        wp.launch(sample_heights_kernel, dim=n, inputs=[hf, points, float(half_extent)], outputs=[h, hmax],
                  device=device)
    return h.numpy(), hmax.numpy()


# ====================================================================================================
# term tables: configuration structs
# ====================================================================================================

_SCALARS = {bool: wp.bool, int: wp.int32, float: wp.float32}


def config_struct(cls: type) -> Struct:
    """A Warp struct ``<Name>Params`` with the scalar fields (float, int, bool) of the dataclass ``cls``."""
    fields = {f.name: _SCALARS[type(f.default)] for f in dataclasses.fields(cls) if type(f.default) in _SCALARS}
    name = cls.__name__.removesuffix("Config") + "Params"
    return wp.struct(type(name, (), {"__annotations__": fields, "__module__": __name__, "__qualname__": name}))


TaskParams = config_struct(TaskConfig)
RewardParams = config_struct(RewardConfig)


def config_params(struct: Struct, cfg) -> object:
    """An instance of a :func:`config_struct` struct holding ``cfg``'s values."""
    s = struct()
    for name in struct.vars:
        setattr(s, name, getattr(cfg, name))
    return s


def make_struct(struct: Struct, **values) -> object:
    """An instance of ``struct`` with every member given by name; a config dataclass given for a
    :func:`config_struct` member is converted."""
    missing, unknown = set(struct.vars) - set(values), set(values) - set(struct.vars)
    if missing or unknown:
        raise TypeError(f"{struct.key}: missing {sorted(missing)}, unknown {sorted(unknown)}")
    s = struct()
    for name, value in values.items():
        member = struct.vars[name].type
        if isinstance(member, Struct) and dataclasses.is_dataclass(value):
            value = config_params(member, value)
        setattr(s, name, value)
    return s


# ====================================================================================================
# episode ends
# ====================================================================================================

@wp.struct
class EndInputs:
    """What the end conditions read, one row per env."""

    joint_q: wp.array2d[wp.float32]  # base position (3), quaternion (x, y, z, w), 18 joint angles
    joint_qd: wp.array2d[wp.float32]  # base linear and angular velocity, 18 joint velocities
    episode_steps: wp.array[wp.int32]  # the episode's steps before this one
    start: wp.array[wp.vec2]  # the episode's start
    hf: HeightField
    task: TaskParams


@wp.struct
class EndFrame:
    """Per-env values the conditions share (:func:`end_frame`)."""

    e: int
    px: float  # base position [m]
    py: float
    pz: float
    rpy: wp.vec3  # roll, pitch, yaw of the (normalised) base quaternion


@wp.func
def end_frame(i: EndInputs, e: int) -> EndFrame:
    f = EndFrame()
    f.e = e
    f.px = i.joint_q[e, 0]
    f.py = i.joint_q[e, 1]
    f.pz = i.joint_q[e, 2]
    f.rpy = quat_to_rpy(wp.normalize(wp.quat(i.joint_q[e, 3], i.joint_q[e, 4], i.joint_q[e, 5], i.joint_q[e, 6])))
    return f


@dataclass(frozen=True)
class EndFrameNp:
    """:class:`EndFrame` for all envs, in float64; ``finite`` marks the envs whose state is all finite."""

    px: np.ndarray
    py: np.ndarray
    pz: np.ndarray
    rpy: np.ndarray  # (N, 3)
    finite: np.ndarray


def end_frame_np(i) -> EndFrameNp:
    """Float64 :func:`end_frame`; ``i`` has :class:`EndInputs`' fields as NumPy arrays, with ``ground`` (N,), the
    terrain under each base, in place of ``hf``, and ``task`` a ``TaskConfig``."""
    jq, jqd = np.asarray(i.joint_q, np.float64), np.asarray(i.joint_qd, np.float64)
    finite = np.isfinite(jq).all(axis=1) & np.isfinite(jqd).all(axis=1)
    rpy = quat_to_rpy_np(np.where(finite[:, None], jq[:, 3:7], [0.0, 0.0, 0.0, 1.0]))
    return EndFrameNp(px=jq[:, 0], py=jq[:, 1], pz=jq[:, 2], rpy=rpy, finite=finite)


# ----------------------------------------------------------------------------------------------------
# the conditions: one Warp function per env and one NumPy function for all envs
# ----------------------------------------------------------------------------------------------------


@wp.func
def nonfinite(i: EndInputs, f: EndFrame) -> bool:
    finite = bool(True)
    for k in range(i.joint_q.shape[1]):
        finite = finite and wp.isfinite(i.joint_q[f.e, k])
    for k in range(i.joint_qd.shape[1]):
        v = i.joint_qd[f.e, k]
        finite = finite and wp.isfinite(v)
        if k >= 6 and wp.abs(v) > i.task.max_joint_speed:
            finite = False
    base_v = wp.vec3(i.joint_qd[f.e, 0], i.joint_qd[f.e, 1], i.joint_qd[f.e, 2])
    if wp.length(base_v) > i.task.max_base_speed:
        finite = False
    return not finite


def nonfinite_np(i, f):
    jqd = np.asarray(i.joint_qd, np.float64)
    with np.errstate(invalid="ignore"):
        runaway = (np.linalg.norm(jqd[:, :3], axis=1) > i.task.max_base_speed) | (
            np.abs(jqd[:, 6:]) > i.task.max_joint_speed
        ).any(axis=1)
    return ~f.finite | runaway


@wp.func
def fell(i: EndInputs, f: EndFrame) -> bool:
    lim = i.task.max_tilt
    low = f.pz - terrain_height(i.hf, f.px, f.py) < i.task.min_height
    return low or wp.abs(f.rpy[0]) > lim or wp.abs(f.rpy[1]) > lim


def fell_np(i, f):
    lim = i.task.max_tilt
    return (f.pz - i.ground < i.task.min_height) | (np.abs(f.rpy[:, 0]) > lim) | (np.abs(f.rpy[:, 1]) > lim)


@wp.func
def left_course(i: EndInputs, f: EndFrame) -> bool:
    return wp.abs(f.py - i.start[f.e][1]) > i.task.max_abs_y


def left_course_np(i, f):
    return np.abs(f.py - np.asarray(i.start, np.float64)[:, 1]) > i.task.max_abs_y


@wp.func
def success(i: EndInputs, f: EndFrame) -> bool:
    return wp.length(wp.vec2(f.px, f.py) - i.start[f.e] - wp.vec2(i.task.goal_distance, 0.0)) < i.task.goal_radius


def success_np(i, f):
    start = np.asarray(i.start, np.float64)
    return np.hypot(f.px - start[:, 0] - i.task.goal_distance, f.py - start[:, 1]) < i.task.goal_radius


@wp.func
def timeout(i: EndInputs, f: EndFrame) -> bool:
    return i.episode_steps[f.e] + 1 >= i.task.max_episode_steps


def timeout_np(i, f):
    return np.asarray(i.episode_steps) + 1 >= i.task.max_episode_steps


# ----------------------------------------------------------------------------------------------------
# the table
# ----------------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class Termination:
    """One episode end: status ``code`` (``STATUS_NAMES``) when ``func`` holds and no earlier row does."""

    code: int
    func: wp.Function  # (EndInputs, EndFrame) -> bool for one env
    reference: Callable  # float64 NumPy (inputs namespace, end_frame_np) -> (N,) bool

    @property
    def name(self) -> str:
        return STATUS_NAMES[self.code]


TERMINATIONS = (
    Termination(NONFINITE, nonfinite, nonfinite_np),
    Termination(FELL, fell, fell_np),
    Termination(OFF_COURSE, left_course, left_course_np),
    Termination(SUCCESS, success, success_np),
    Termination(TIMEOUT, timeout, timeout_np),
)
assert sorted(t.code for t in TERMINATIONS) == list(range(1, len(STATUS_NAMES))), "one row per status code"


def choose(table: tuple, names: tuple[str, ...], what: str) -> tuple:
    """The rows of ``table`` named in ``names``, in table order; ValueError (one line) for a name that is no row."""
    known = [row.name for row in table]
    unknown = [name for name in names if name not in known]
    if unknown:
        raise ValueError(f"{what}: no term {', '.join(unknown)}; choose from {', '.join(known)}")
    return tuple(row for row in table if row.name in names)


TERMINATION_NAMES = tuple(t.name for t in TERMINATIONS)


def make_status_kernel(names: tuple[str, ...] = TERMINATION_NAMES) -> wp.Kernel:
    """The fused episode-status kernel of the ``TERMINATIONS`` rows ``names`` (``TaskConfig.terminations``; the
    physics' blow-up check, ``nonfinite``, is always first), one per choice in a process. :data:`episode_status_kernel`
    is every row's."""
    table = choose(TERMINATIONS, names, "task.terminations")
    if not table or table[0].code != NONFINITE:
        raise ValueError("task.terminations must include nonfinite (a blown-up env has to be reset)")
    return _status_kernel(table)


@functools.cache
def _status_kernel(table: tuple) -> wp.Kernel:
    @wp.kernel(module="unique")
    def episode_status_kernel(i: EndInputs, status: wp.array[wp.int32], rpy: wp.array2d[wp.float32]):
        """Each env's status: the code of the first row whose condition holds, else ``RUNNING``; and its roll, pitch,
        yaw (0 for a blown-up env)."""
        e = wp.tid()
        f = end_frame(i, e)
        s = int(RUNNING)
        for k in range(wp.static(len(table))):
            if s == RUNNING:
                if wp.static(table[k].func)(i, f):
                    s = wp.static(table[k].code)
        status[e] = s
        a = f.rpy
        if s == NONFINITE:
            a = wp.vec3(0.0)
        for k in range(3):
            rpy[e, k] = a[k]

    return episode_status_kernel


episode_status_kernel = make_status_kernel()


def episode_status_np(i, names: tuple[str, ...] | None = None):
    """Float64 reference of :func:`make_status_kernel`'s kernel (inputs as in :func:`end_frame_np`): (status, rpy)."""
    table = TERMINATIONS if names is None else choose(TERMINATIONS, names, "task.terminations")
    f = end_frame_np(i)
    with np.errstate(invalid="ignore"):
        hits = [t.reference(i, f) for t in table]
    status = np.select(hits, [t.code for t in table], RUNNING)
    return status, np.where((status == NONFINITE)[:, None], 0.0, f.rpy)


# ====================================================================================================
# rewards
# ====================================================================================================

REF_DT = 0.02
FORWARD_MIN_SPEED = 0.1


@wp.struct
class RewardInputs:
    """What the reward terms read, one row per env. The kernel also writes ``prev_x`` and ``prev_actions`` for the
    next step."""

    joint_q: wp.array2d[wp.float32]  # base position (3), quaternion (x, y, z, w), 18 joint angles
    joint_qd: wp.array2d[wp.float32]  # base linear and angular velocity (world frame), 18 joint velocities
    rpy: wp.array2d[wp.float32]  # roll, pitch, yaw (the terminations kernel's; 0 for a blown-up env)
    status: wp.array[wp.int32]  # this step's episode status (a status code)
    episode_steps: wp.array[wp.int32]  # the episode's steps before this one
    actions: wp.array2d[wp.float32]  # the policy's actions
    start: wp.array[wp.vec2]  # the episode's start; the goal lies task.goal_distance ahead of it along +x
    hf: HeightField
    prev_x: wp.array[wp.float32]  # base x at the last step
    prev_actions: wp.array2d[wp.float32]  # the last step's actions, clamped to [-1, 1]
    task: TaskParams
    reward: RewardParams


@wp.struct
class RewardFrame:
    """Per-env values the terms share, computed once per step by :func:`reward_frame`."""

    e: int  # the env
    px: float  # base position [m]
    py: float
    z: float  # torso height above the terrain under it [m]
    to_goal: wp.vec2  # goal minus base position [m]
    scale: float  # control_dt / REF_DT: per-step terms mean the same per second at any control rate
    ok: bool  # base position and the terrain height under it are finite


@wp.func
def reward_frame(i: RewardInputs, e: int) -> RewardFrame:
    f = RewardFrame()
    f.e = e
    f.px = i.joint_q[e, 0]
    f.py = i.joint_q[e, 1]
    f.z = i.joint_q[e, 2] - terrain_height(i.hf, f.px, f.py)
    f.to_goal = i.start[e] + wp.vec2(i.task.goal_distance, 0.0) - wp.vec2(f.px, f.py)
    f.scale = i.task.control_dt / REF_DT
    f.ok = wp.isfinite(f.px) and wp.isfinite(f.py) and wp.isfinite(f.z)
    return f


@dataclass(frozen=True)
class FrameNp:
    """:class:`RewardFrame` for all envs, in float64."""

    px: np.ndarray
    py: np.ndarray
    z: np.ndarray
    to_goal: np.ndarray  # (N, 2)
    scale: float
    ok: np.ndarray


def reward_frame_np(i) -> FrameNp:
    """Float64 :func:`reward_frame` for all envs; ``i.ground`` (N,) is the terrain under each base."""
    jq = np.asarray(i.joint_q, np.float64)
    px, py = jq[:, 0], jq[:, 1]
    z = jq[:, 2] - np.asarray(i.ground, np.float64)
    start = np.asarray(i.start, np.float64)
    to_goal = np.stack([start[:, 0] + i.task.goal_distance - px, start[:, 1] - py], axis=1)
    ok = np.isfinite(px) & np.isfinite(py) & np.isfinite(z)
    return FrameNp(px=px, py=py, z=z, to_goal=to_goal, scale=i.task.control_dt / REF_DT, ok=ok)


# ----------------------------------------------------------------------------------------------------
# the terms: unweighted values, one Warp function per env and one NumPy function for all envs
# ----------------------------------------------------------------------------------------------------


@wp.func
def height(i: RewardInputs, f: RewardFrame) -> float:
    """r_h: z - 0.11 above 0.12 m, else 0."""
    r = float(0.0)
    if f.z > 0.12:
        r = f.z - 0.11
    return r


def height_np(i, f):
    return np.where(f.z > 0.12, f.z - 0.11, 0.0)


@wp.func
def direction(i: RewardInputs, f: RewardFrame) -> float:
    """r_theta: min(0, cos(heading error) - cos(dead band)), toward the goal (ours) or along +x."""
    # the start-to-goal direction D is +x, so (cos θ, sin θ) . D / |D| = cos(yaw); ours: D from the robot
    bearing = float(0.0)
    if i.reward.direction_to_goal:
        bearing = wp.atan2(f.to_goal[1], f.to_goal[0])
    return wp.min(0.0, wp.cos(i.rpy[f.e, 2] - bearing) - wp.cos(i.reward.direction_deadband))


def direction_np(i, f):
    bearing = np.arctan2(f.to_goal[:, 1], f.to_goal[:, 0]) if i.reward.direction_to_goal else 0.0
    return np.minimum(0.0, np.cos(np.asarray(i.rpy, np.float64)[:, 2] - bearing) - np.cos(i.reward.direction_deadband))


@wp.func
def distance(i: RewardInputs, f: RewardFrame) -> float:
    """r_d: exp(-(d_n - d_t)), 1 on the goal circle."""
    return wp.exp(-(wp.length(f.to_goal) - i.task.goal_radius))


def distance_np(i, f):
    return np.exp(-(np.hypot(f.to_goal[:, 0], f.to_goal[:, 1]) - i.task.goal_radius))


@wp.func
def stability(i: RewardInputs, f: RewardFrame) -> float:
    """-1 while z < 0.05 m, |roll| or |pitch| > stability_tilt, or fallen (r_s = stability_penalty x this)."""
    lim = i.reward.stability_tilt
    tilted = wp.abs(i.rpy[f.e, 0]) > lim or wp.abs(i.rpy[f.e, 1]) > lim
    r = float(0.0)
    if f.z < 0.05 or tilted or i.status[f.e] == FELL:
        r = -1.0
    return r


def stability_np(i, f):
    rpy = np.asarray(i.rpy, np.float64)
    tilted = (np.abs(rpy[:, 0]) > i.reward.stability_tilt) | (np.abs(rpy[:, 1]) > i.reward.stability_tilt)
    return np.where((f.z < 0.05) | tilted | (np.asarray(i.status) == FELL), -1.0, 0.0)


@wp.func
def forward(i: RewardInputs, f: RewardFrame) -> float:
    """-1 below FORWARD_MIN_SPEED along +x (r_f = forward_penalty x this)."""
    r = float(0.0)
    if f.px - i.prev_x[f.e] < FORWARD_MIN_SPEED * i.task.control_dt:
        r = -1.0
    return r


def forward_np(i, f):
    return np.where(f.px - np.asarray(i.prev_x, np.float64) < FORWARD_MIN_SPEED * i.task.control_dt, -1.0, 0.0)


@wp.func
def goal(i: RewardInputs, f: RewardFrame) -> float:
    """1 on reaching the goal (ours: r_goal = goal_bonus x this)."""
    r = float(0.0)
    if i.status[f.e] == SUCCESS:
        r = 1.0
    return r


def goal_np(i, f):
    return np.where(np.asarray(i.status) == SUCCESS, 1.0, 0.0)


@wp.func
def off_course(i: RewardInputs, f: RewardFrame) -> float:
    """-1 on leaving the course (ours: r_off = off_course_penalty x this)."""
    r = float(0.0)
    if i.status[f.e] == OFF_COURSE:
        r = -1.0
    return r


def off_course_np(i, f):
    return np.where(np.asarray(i.status) == OFF_COURSE, -1.0, 0.0)


@wp.func
def tilt(i: RewardInputs, f: RewardFrame) -> float:
    """roll² + pitch² [rad²], a cost: r_tilt = -w_tilt x this."""
    return i.rpy[f.e, 0] * i.rpy[f.e, 0] + i.rpy[f.e, 1] * i.rpy[f.e, 1]


def tilt_np(i, f):
    rpy = np.asarray(i.rpy, np.float64)
    return rpy[:, 0] ** 2 + rpy[:, 1] ** 2


@wp.func
def body_roll_pitch_rate(qx: float, qy: float, qz: float, qw: float, wx: float, wy: float, wz: float) -> wp.vec2:
    """The base's world-frame angular velocity (a free joint's qd[3:6]) in its own frame: (roll rate, pitch rate)."""
    w_body = wp.quat_rotate_inv(wp.quat(qx, qy, qz, qw), wp.vec3(wx, wy, wz))
    return wp.vec2(w_body[0], w_body[1])


@wp.func
def ang_vel(i: RewardInputs, f: RewardFrame) -> float:
    """ω_x² + ω_y², the body's roll and pitch rates in its own frame [(rad/s)²]; a cost: r_ang_vel = -w_ang_vel x
    this."""
    e = f.e
    rate = body_roll_pitch_rate(i.joint_q[e, 3], i.joint_q[e, 4], i.joint_q[e, 5], i.joint_q[e, 6], i.joint_qd[e, 3],
                                i.joint_qd[e, 4], i.joint_qd[e, 5])  # fmt: skip
    return rate[0] * rate[0] + rate[1] * rate[1]


def ang_vel_np(i, f):
    w_body = quat_rotate_inv_np(np.asarray(i.joint_q, np.float64)[:, 3:7], np.asarray(i.joint_qd, np.float64)[:, 3:6])
    return w_body[:, 0] ** 2 + w_body[:, 1] ** 2


@wp.func
def clamped_action(i: RewardInputs, e: int, k: int) -> float:
    """Action k of env e in [-1, 1] (0 if not finite), as the action scaling reads it."""
    a = i.actions[e, k]
    if not wp.isfinite(a):
        a = 0.0
    return wp.clamp(a, -1.0, 1.0)


def clamped_actions_np(actions):
    return np.clip(np.nan_to_num(np.asarray(actions, np.float64), nan=0.0), -1.0, 1.0)


@wp.func
def action_rate(i: RewardInputs, f: RewardFrame) -> float:
    """Σ_k (a_k - a_k,prev)² (0 on an episode's first step), a cost: r_action_rate = -w_action_rate x this."""
    da = float(0.0)
    if i.episode_steps[f.e] > 0:
        for k in range(i.actions.shape[1]):
            d = clamped_action(i, f.e, k) - i.prev_actions[f.e, k]
            da += d * d
    return da


def action_rate_np(i, f):
    da = ((clamped_actions_np(i.actions) - np.asarray(i.prev_actions, np.float64)) ** 2).sum(axis=1)
    return np.where(np.asarray(i.episode_steps) > 0, da, 0.0)


# ----------------------------------------------------------------------------------------------------
# the table
# ----------------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class RewardTerm:
    """One reward term: ``terms[:, k] = (-)reward.<weight> * func(i, f) [* control_dt / REF_DT if per_step]``."""

    name: str  # logged as Reward/<name>
    weight: str  # the RewardConfig field that weighs it
    func: wp.Function  # (RewardInputs, RewardFrame) -> unweighted value of one env
    reference: Callable  # float64 NumPy (inputs namespace, reward_frame_np) -> (N,) unweighted values
    per_step: bool = True  # paid per 20 ms step, scaled by control_dt / REF_DT (False: paid once)
    state: bool = True  # computed from the simulator state: 0 for an env whose base position is not finite
    cost: bool = False  # paid as -weight * value (a cost >= 0 that the weight scales)


REWARD_TERMS = (
    # Table 1 and Eq. 5
    RewardTerm("height", "w_height", height, height_np),
    RewardTerm("direction", "w_direction", direction, direction_np),
    RewardTerm("distance", "w_distance", distance, distance_np),
    RewardTerm("stability", "stability_penalty", stability, stability_np),  # -1 while fallen or tilted: -100
    RewardTerm("forward", "forward_penalty", forward, forward_np),  # -1 below FORWARD_MIN_SPEED: -0.3
    # ours: the success bonus and the off-course fine, paid once
    RewardTerm("goal", "goal_bonus", goal, goal_np, per_step=False),
    RewardTerm("off_course", "off_course_penalty", off_course, off_course_np, per_step=False),
    # ours: the stability shaping
    RewardTerm("tilt", "w_tilt", tilt, tilt_np, cost=True),
    RewardTerm("ang_vel", "w_ang_vel", ang_vel, ang_vel_np, cost=True),
    RewardTerm("action_rate", "w_action_rate", action_rate, action_rate_np, state=False, cost=True),
)
REWARD_NAMES = tuple(t.name for t in REWARD_TERMS)  # the columns of ``terms``


def reward_weights(reward, table=REWARD_TERMS):
    """The table's weights from a ``RewardConfig``, in column order: the kernel's ``weights`` argument."""
    return wp.types.vector(len(table), wp.float32)(*(float(getattr(reward, t.weight)) for t in table))


def reward_table(reward) -> tuple:
    """The rows of ``REWARD_TERMS`` a ``RewardConfig`` chooses (``RewardConfig.terms``), in table order."""
    return choose(REWARD_TERMS, reward.terms, "reward.terms")


@functools.cache
def make_rewards_kernel(table: tuple = REWARD_TERMS) -> wp.Kernel:
    """The fused reward kernel of a term table, one per table in a process (:data:`rewards_kernel` is
    ``REWARD_TERMS``'; the env's is :func:`reward_table`'s choice)."""

    @wp.kernel(module="unique")
    def rewards_kernel(
        i: RewardInputs,
        weights: wp.types.vector(len(table), wp.float32),
        reward: wp.array[wp.float32],
        terms: wp.array2d[wp.float32],
    ):
        """Every term of the table (weighted) into ``terms[e, k]`` and their sum, in table order, into ``reward[e]``;
        then this step's base x and clamped actions become ``prev_x`` and ``prev_actions``. Runs after the episode
        status, before the episode counters advance."""
        e = wp.tid()
        f = reward_frame(i, e)
        total = float(0.0)
        for k in range(wp.static(len(table))):
            w = weights[wp.static(k)]
            if wp.static(table[k].cost):
                w = -w
            t = w * wp.static(table[k].func)(i, f)
            if wp.static(table[k].per_step):
                t = t * f.scale
            if wp.static(table[k].state):
                if not f.ok:
                    t = 0.0
            if not wp.isfinite(t):
                t = 0.0
            terms[e, wp.static(k)] = t
            if wp.static(k == 0):
                total = t
            else:
                total = total + t
        reward[e] = total
        px = float(0.0)
        if f.ok:
            px = f.px
        i.prev_x[e] = px
        for k in range(i.actions.shape[1]):
            i.prev_actions[e, k] = clamped_action(i, e, k)

    return rewards_kernel


rewards_kernel = make_rewards_kernel(REWARD_TERMS)


def rewards_reference(i, table=REWARD_TERMS):
    """Float64 reference of :func:`make_rewards_kernel`'s kernel. ``i`` has :class:`RewardInputs`' fields as NumPy
    arrays, with ``ground`` (N,), the terrain under each base, in place of ``hf``, and ``task`` / ``reward`` a
    ``TaskConfig`` / ``RewardConfig``. Returns (reward (N,), terms (N, len(table)), prev_x (N,), prev_actions (N, A)).
    """
    with np.errstate(invalid="ignore", over="ignore"):
        f = reward_frame_np(i)
        cols = []
        for row in table:
            t = (-1.0 if row.cost else 1.0) * getattr(i.reward, row.weight) * row.reference(i, f)
            if row.per_step:
                t = t * f.scale
            if row.state:
                t = np.where(f.ok, t, 0.0)
            cols.append(np.where(np.isfinite(t), t, 0.0))
    terms = np.stack(cols, axis=1)
    return terms.sum(axis=1), terms, np.where(f.ok, f.px, 0.0), clamped_actions_np(i.actions)


# ====================================================================================================
# observations
# ====================================================================================================

H_HALF_EXTENT = 0.3  # ours: the square that "max height h" looks at: +-30 cm, about the legs' reach [m]
#: ``cpg``: the paper's (15 CPG parameters); ``cpg_posture``: with the body posture (18); ``joint``: the pure-DRL
#: comparison (no CPG parameters)
LAYOUTS = ("cpg", "cpg_posture", "joint")
CPG = ("cpg", "cpg_posture")


@wp.struct
class ObsInputs:
    """What the observation reads, one row per env."""

    joint_q: wp.array2d[wp.float32]  # base position (3), quaternion (x, y, z, w), 18 joint angles
    joint_qd: wp.array2d[wp.float32]  # base linear and angular velocity, 18 joint velocities
    params: wp.array2d[wp.float32]  # the CPG parameters the controller runs with (filtered); unread in ``joint``
    start: wp.array[wp.vec2]  # the episode's start; the goal lies task.goal_distance ahead of it along +x
    hf: HeightField
    task: TaskParams


# ----------------------------------------------------------------------------------------------------
# the parts: each Warp function writes its values to obs[e, k:k + size]; each NumPy function returns (N, size)
# ----------------------------------------------------------------------------------------------------


@wp.func
def joint_pos(i: ObsInputs, e: int, obs: wp.array2d[wp.float32], k: int):
    for j in range(18):
        obs[e, k + j] = i.joint_q[e, 7 + j]


def joint_pos_np(i):
    return np.asarray(i.joint_q, np.float64)[:, 7:25]


@wp.func
def joint_vel(i: ObsInputs, e: int, obs: wp.array2d[wp.float32], k: int):
    for j in range(18):
        obs[e, k + j] = i.joint_qd[e, 6 + j]


def joint_vel_np(i):
    return np.asarray(i.joint_qd, np.float64)[:, 6:24]


@wp.func
def target(i: ObsInputs, e: int, obs: wp.array2d[wp.float32], k: int):
    gx = i.start[e][0] + i.task.goal_distance
    gy = i.start[e][1]
    dx = gx - i.joint_q[e, 0]
    dy = gy - i.joint_q[e, 1]
    yaw = quat_to_rpy(wp.normalize(wp.quat(i.joint_q[e, 3], i.joint_q[e, 4], i.joint_q[e, 5], i.joint_q[e, 6])))[2]
    c = wp.cos(yaw)
    s = wp.sin(yaw)
    obs[e, k] = c * dx + s * dy
    obs[e, k + 1] = -s * dx + c * dy
    obs[e, k + 2] = terrain_height(i.hf, gx, gy) - i.joint_q[e, 2]


def target_np(i):
    jq, start = np.asarray(i.joint_q, np.float64), np.asarray(i.start, np.float64)
    gx, gy = start[:, 0] + i.task.goal_distance, start[:, 1]
    dx, dy = gx - jq[:, 0], gy - jq[:, 1]
    yaw = quat_to_rpy_np(jq[:, 3:7])[:, 2]
    c, s = np.cos(yaw), np.sin(yaw)
    return np.stack([c * dx + s * dy, -s * dx + c * dy, i.ground_at(gx, gy) - jq[:, 2]], axis=1)


@wp.func
def omega(i: ObsInputs, e: int, obs: wp.array2d[wp.float32], k: int):
    obs[e, k] = i.params[e, 0]


def omega_np(i):
    return np.asarray(i.params, np.float64)[:, :1]


@wp.func
def amplitudes(i: ObsInputs, e: int, obs: wp.array2d[wp.float32], k: int):
    for j in range(14):
        obs[e, k + j] = i.params[e, 1 + j]


def amplitudes_np(i):
    return np.asarray(i.params, np.float64)[:, 1:15]


@wp.func
def posture(i: ObsInputs, e: int, obs: wp.array2d[wp.float32], k: int):
    for j in range(3):
        obs[e, k + j] = i.params[e, 15 + j]


def posture_np(i):
    return np.asarray(i.params, np.float64)[:, 15:18]


@wp.func
def quat(i: ObsInputs, e: int, obs: wp.array2d[wp.float32], k: int):
    sign = float(1.0)
    if i.joint_q[e, 6] < 0.0:
        sign = -1.0
    for j in range(4):
        obs[e, k + j] = sign * i.joint_q[e, 3 + j]


def quat_np(i):
    jq = np.asarray(i.joint_q, np.float64)
    return jq[:, 3:7] * np.where(jq[:, 6:7] < 0, -1.0, 1.0)


@wp.func
def max_height(i: ObsInputs, e: int, obs: wp.array2d[wp.float32], k: int):
    px = i.joint_q[e, 0]
    py = i.joint_q[e, 1]
    obs[e, k] = max_terrain_height(i.hf, px, py, H_HALF_EXTENT) - terrain_height(i.hf, px, py)


def max_height_np(i):
    jq = np.asarray(i.joint_q, np.float64)
    return (i.ground_at.max(jq[:, 0], jq[:, 1], H_HALF_EXTENT) - i.ground_at(jq[:, 0], jq[:, 1]))[:, None]


# ----------------------------------------------------------------------------------------------------
# the table
# ----------------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class ObsTerm:
    """One part of the observation: ``size`` values in the layouts that carry it, in table order."""

    name: str
    size: int
    doc: str
    noise: str | None  # the RandomizationConfig field of its uniform noise amplitude (None: exact)
    func: wp.Function  # (ObsInputs, env, obs, first column) writes the part's values
    reference: Callable  # float64 NumPy (inputs namespace) -> (N, size)
    layouts: tuple[str, ...] = LAYOUTS

    @property
    def mask(self) -> int:
        """Bit ``LAYOUTS.index(layout)`` set for each layout that carries it."""
        return sum(1 << LAYOUTS.index(name) for name in self.layouts)


OBS_TERMS = (
    ObsTerm("joint_pos", 18, "joint positions [rad], order R1..L3 x (hip, knee, ankle)", "noise_joint_pos",
            joint_pos, joint_pos_np),
    ObsTerm("joint_vel", 18, "joint velocities [rad/s]", "noise_joint_vel", joint_vel, joint_vel_np),
    ObsTerm("target", 3, "target relative to the robot in its heading frame (x forward, y left; z = goal ground - "
            "base z) [m]", "noise_target", target, target_np),
    # the CPG parameters are the controller's own: exact
    ObsTerm("omega", 1, "omega [rad/s] (the filtered parameter the CPG runs with)", None, omega, omega_np, CPG),
    ObsTerm("amplitudes", 14, "A1_R, A1_L, A2[R1..L3], A3[R1..L3] [rad] (filtered)", None, amplitudes,
            amplitudes_np, CPG),
    ObsTerm("posture", 3, "body posture P_h, P_p, P_r [rad] (filtered)", None, posture, posture_np,
            ("cpg_posture",)),
    ObsTerm("quat", 4, "base orientation quaternion (x, y, z, w), sign chosen so that w >= 0", "noise_quat", quat,
            quat_np),
    ObsTerm("max_height", 1, "h: highest terrain within +-H_HALF_EXTENT of the base, minus the terrain under the "
            "base [m]", "noise_height", max_height, max_height_np),
)  # fmt: skip


def _layout(layout: str) -> tuple[tuple[str, int, int], ...]:
    spans, k = [], 0
    for t in OBS_TERMS:
        if layout in t.layouts:
            spans.append((t.name, k, k + t.size))
            k += t.size
    return tuple(spans)


#: (name, start, end) of each part, per layout
OBS_LAYOUT = {layout: _layout(layout) for layout in LAYOUTS}
OBS_DIM = {layout: spans[-1][2] for layout, spans in OBS_LAYOUT.items()}


def _describe(layout: str) -> str:
    doc = {t.name: t.doc for t in OBS_TERMS}
    rows = [f"    [{a}:{b}]".ljust(14) + doc[name] if b > a + 1 else f"    [{a}]".ljust(14) + doc[name]
            for name, a, b in OBS_LAYOUT[layout]]
    return f"``{layout}`` ({OBS_DIM[layout]}):\n" + "\n".join(rows)


if __doc__:  # None under python -OO
    __doc__ += "\n" + "\n\n".join(_describe(layout) for layout in LAYOUTS) + "\n"


def observation_noise(layout: str, randomization) -> np.ndarray:
    """Uniform noise amplitude per column of ``layout`` from a ``RandomizationConfig`` (0 where exact)."""
    noise = np.zeros(OBS_DIM[layout], np.float32)
    for t in OBS_TERMS:
        if t.noise is not None and layout in t.layouts:
            _, a, b = next(span for span in OBS_LAYOUT[layout] if span[0] == t.name)
            noise[a:b] = getattr(randomization, t.noise)
    return noise


@wp.kernel
def observations_kernel(i: ObsInputs, layout: int, obs: wp.array2d[wp.float32]):
    """The observation of each env in layout ``LAYOUTS[layout]``: the parts of ``OBS_TERMS`` that it carries, in
    table order."""
    e = wp.tid()
    k = int(0)
    for r in range(wp.static(len(OBS_TERMS))):
        if (wp.static(OBS_TERMS[r].mask) >> layout) & 1 != 0:
            wp.static(OBS_TERMS[r].func)(i, e, obs, k)
            k += wp.static(OBS_TERMS[r].size)


def observations_reference(i, layout: str) -> np.ndarray:
    """Float64 reference of :func:`observations_kernel`. ``i`` has :class:`ObsInputs`' fields as NumPy arrays, with
    ``task`` a ``TaskConfig`` and, in place of ``hf``, ``ground_at(x, y)`` returning terrain heights and
    ``ground_at.max(x, y, half_extent)`` the max over a square (both vectorised), e.g. ``terrain_height_np`` /
    ``max_terrain_height_np`` bound to a grid."""
    return np.concatenate([t.reference(i) for t in OBS_TERMS if layout in t.layouts], axis=1)

"""The critic's own observation group (ours, ``ObsConfig.critic``): ``CRITIC_TERMS``, one :class:`CriticTerm` row per
part in layout order, the fused kernel (:func:`critic_kernel`) and its float64 reference (:func:`critic_reference`);
the layouts and their sizes follow from the table.

It holds what tells a bad step from bad luck and what the robot does not sense: the base's velocities, the ground
around each foot and ahead of the body, the lower legs' contact forces, the env's randomised physics and the CPG's
phases. Only the critic reads it (rsl-rl's ``obs_groups``: actor ``["policy"]``, critic ``["policy", "critic"]``), so
neither the exported policy nor the robot's runtime needs it; it carries no noise. A value that is not finite is 0.

Layouts (from the table; the action mode's, as the policy's ``BASE_LAYOUTS``):
"""

from dataclasses import dataclass
from typing import Callable

import numpy as np
import warp as wp

from hexnewton.config import LEG_NAMES
from hexnewton.mdp.terms.ground import HeightField, terrain_height
from hexnewton.mdp.terms.observations import BASE_LAYOUTS, CPG
from hexnewton.kernels.cpg import quat_to_rpy
from hexnewton.kernels.reference import quat_rotate_inv_np, quat_to_rpy_np

#: ours: the 3 x 3 ground heights around each foot, 3 cm apart along world x and y (a 2 cm block and the blocks beside
#: it): offsets FOOT_GRID [m]
FOOT_SPACING = 0.03
FOOT_SIDE = 3
FOOT_GRID = tuple(round((k - (FOOT_SIDE - 1) / 2) * FOOT_SPACING, 9) for k in range(FOOT_SIDE))
#: ours: the ground heights ahead of the body, AHEAD_X x AHEAD_Y in its heading frame [m] (x forward, y left): 5 rows
#: 10 cm apart from 5 cm ahead (two stair treads), 3 columns 10 cm apart (the body's width)
AHEAD_FIRST, AHEAD_SPACING, AHEAD_ROWS = 0.05, 0.10, 5
AHEAD_COLS = 3
AHEAD_X = tuple(round(AHEAD_FIRST + k * AHEAD_SPACING, 9) for k in range(AHEAD_ROWS))
AHEAD_Y = tuple(round((k - (AHEAD_COLS - 1) / 2) * AHEAD_SPACING, 9) for k in range(AHEAD_COLS))
#: the randomised physics, one column each (``mdp.events.randomize_physics``' draws; the nominal robot's values where
#: nothing is drawn), and ``late``: 1 for an env whose actions act one control step late
PHYSICS = ("friction", "payload", "link_mass_scale", "kp_scale", "kd_scale", "effort_scale", "foot_radius",
           "contact_timeconst", "late")  # fmt: skip
#: the contact time constant of the robot's shapes when none is drawn (MuJoCo's default solref) [s]
NOMINAL_TIMECONST = 0.02
LEGS = len(LEG_NAMES)


@wp.struct
class CriticInputs:
    """What the critic group reads, one row per env (``body_q``: every body, env by env)."""

    joint_q: wp.array2d[wp.float32]  # base position (3), quaternion (x, y, z, w), 18 joint angles
    joint_qd: wp.array2d[wp.float32]  # base linear and angular velocity (world frame), 18 joint velocities
    body_q: wp.array[wp.transform]  # every body's pose in the world
    lower_legs: wp.array2d[wp.int32]  # (N, 6) each leg's tibia body, legs in LEG_NAMES order
    foot: wp.vec3  # the foot sphere's centre in its tibia's frame [m]
    forces: wp.array2d[wp.vec3]  # (N, 6) the contact force on each lower leg [N, world frame]
    physics: wp.array2d[wp.float32]  # (N, len(PHYSICS)) the env's randomised physics
    cpg_state: wp.array2d[wp.float32]  # (N, 4) the two oscillators' (x, y); unread in ``joint``
    episode_steps: wp.array[wp.int32]  # control steps of the episode so far (0: it has just begun)
    hf: HeightField


# ----------------------------------------------------------------------------------------------------
# the parts: each Warp function writes its values to out[env, col:col + size]; each NumPy function returns (N, size)
# ----------------------------------------------------------------------------------------------------


@wp.func
def _base_quat(inputs: CriticInputs, env: int) -> wp.quat:
    return wp.normalize(wp.quat(inputs.joint_q[env, 3], inputs.joint_q[env, 4], inputs.joint_q[env, 5],
                                inputs.joint_q[env, 6]))  # fmt: skip


@wp.func
def base_lin_vel(inputs: CriticInputs, env: int, out: wp.array2d[wp.float32], col: int):
    v = wp.quat_rotate_inv(_base_quat(inputs, env), wp.vec3(inputs.joint_qd[env, 0], inputs.joint_qd[env, 1],
                                                            inputs.joint_qd[env, 2]))  # fmt: skip
    for j in range(3):
        out[env, col + j] = v[j]


def base_lin_vel_np(inputs):
    return quat_rotate_inv_np(np.asarray(inputs.joint_q, np.float64)[:, 3:7],
                              np.asarray(inputs.joint_qd, np.float64)[:, 0:3])  # fmt: skip


@wp.func
def base_ang_vel(inputs: CriticInputs, env: int, out: wp.array2d[wp.float32], col: int):
    w = wp.quat_rotate_inv(_base_quat(inputs, env), wp.vec3(inputs.joint_qd[env, 3], inputs.joint_qd[env, 4],
                                                            inputs.joint_qd[env, 5]))  # fmt: skip
    for j in range(3):
        out[env, col + j] = w[j]


def base_ang_vel_np(inputs):
    return quat_rotate_inv_np(np.asarray(inputs.joint_q, np.float64)[:, 3:7],
                              np.asarray(inputs.joint_qd, np.float64)[:, 3:6])  # fmt: skip


@wp.func
def foot_heights(inputs: CriticInputs, env: int, out: wp.array2d[wp.float32], col: int):
    k = int(0)
    for leg in range(LEGS):
        p = wp.transform_point(inputs.body_q[inputs.lower_legs[env, leg]], inputs.foot)
        for i in range(FOOT_SIDE):
            for j in range(FOOT_SIDE):
                dx = (float(i) - 0.5 * float(FOOT_SIDE - 1)) * FOOT_SPACING
                dy = (float(j) - 0.5 * float(FOOT_SIDE - 1)) * FOOT_SPACING
                h = terrain_height(inputs.hf, p[0] + dx, p[1] + dy)
                out[env, col + k] = h - p[2]
                k += 1


def feet_np(inputs) -> np.ndarray:
    """(N, 6, 3) each foot's centre in the world."""
    poses = np.asarray(inputs.body_q, np.float64)[np.asarray(inputs.lower_legs)]  # (N, 6, 7)
    conj = poses[..., 3:7] * np.array([-1.0, -1.0, -1.0, 1.0])  # R(q) v = R(q*)^T v
    foot = np.broadcast_to(np.asarray(inputs.foot, np.float64), poses[..., :3].shape)
    return poses[..., :3] + quat_rotate_inv_np(conj, foot)


def foot_heights_np(inputs):
    feet = feet_np(inputs)
    g = np.asarray(FOOT_GRID)
    x = feet[..., 0, None, None] + g[:, None]
    y = feet[..., 1, None, None] + g[None, :]
    return (inputs.ground_at(x, y) - feet[..., 2, None, None]).reshape(len(feet), -1)


@wp.func
def ahead_heights(inputs: CriticInputs, env: int, out: wp.array2d[wp.float32], col: int):
    yaw = quat_to_rpy(_base_quat(inputs, env))[2]
    c = wp.cos(yaw)
    s = wp.sin(yaw)
    k = int(0)
    for i in range(AHEAD_ROWS):
        for j in range(AHEAD_COLS):
            ax = AHEAD_FIRST + float(i) * AHEAD_SPACING
            ay = (float(j) - 0.5 * float(AHEAD_COLS - 1)) * AHEAD_SPACING
            h = terrain_height(inputs.hf, inputs.joint_q[env, 0] + c * ax - s * ay,
                               inputs.joint_q[env, 1] + s * ax + c * ay)  # fmt: skip
            out[env, col + k] = h - inputs.joint_q[env, 2]
            k += 1


def ahead_heights_np(inputs):
    jq = np.asarray(inputs.joint_q, np.float64)
    yaw = quat_to_rpy_np(jq[:, 3:7])[:, 2, None, None]
    ax, ay = np.meshgrid(AHEAD_X, AHEAD_Y, indexing="ij")
    x = jq[:, 0, None, None] + np.cos(yaw) * ax - np.sin(yaw) * ay
    y = jq[:, 1, None, None] + np.sin(yaw) * ax + np.cos(yaw) * ay
    return (inputs.ground_at(x, y) - jq[:, 2, None, None]).reshape(len(jq), -1)


@wp.func
def leg_forces(inputs: CriticInputs, env: int, out: wp.array2d[wp.float32], col: int):
    begun = inputs.episode_steps[env] > 0
    for leg in range(LEGS):
        f = wp.vec3(0.0)
        if begun:
            f = inputs.forces[env, leg]
        for j in range(3):
            out[env, col + 3 * leg + j] = f[j]


def leg_forces_np(inputs):
    f = np.asarray(inputs.forces, np.float64).reshape(len(inputs.episode_steps), -1)
    return np.where(np.asarray(inputs.episode_steps)[:, None] > 0, f, 0.0)


@wp.func
def physics(inputs: CriticInputs, env: int, out: wp.array2d[wp.float32], col: int):
    for j in range(inputs.physics.shape[1]):
        out[env, col + j] = inputs.physics[env, j]


def physics_np(inputs):
    return np.asarray(inputs.physics, np.float64)


@wp.func
def cpg_phase(inputs: CriticInputs, env: int, out: wp.array2d[wp.float32], col: int):
    for osc in range(2):
        x = inputs.cpg_state[env, 2 * osc]
        y = inputs.cpg_state[env, 2 * osc + 1]
        r = wp.sqrt(x * x + y * y)
        if r > 1.0e-6:
            out[env, col + 2 * osc] = x / r
            out[env, col + 2 * osc + 1] = y / r
        else:
            out[env, col + 2 * osc] = 1.0
            out[env, col + 2 * osc + 1] = 0.0


def cpg_phase_np(inputs):
    xy = np.asarray(inputs.cpg_state, np.float64).reshape(-1, 2, 2)
    r = np.linalg.norm(xy, axis=-1, keepdims=True)
    unit = np.where(r > 1e-6, xy / np.maximum(r, 1e-300), np.array([1.0, 0.0]))
    return unit.reshape(len(xy), 4)


# ----------------------------------------------------------------------------------------------------
# the table
# ----------------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class CriticTerm:
    """One part of the critic group: ``size`` values in the layouts that carry it, in table order."""

    name: str
    size: int
    doc: str
    func: wp.Function  # (CriticInputs, env, out, first column) writes the part's values
    reference: Callable  # float64 NumPy (inputs namespace) -> (N, size)
    layouts: tuple[str, ...] = BASE_LAYOUTS

    @property
    def mask(self) -> int:
        """Bit ``BASE_LAYOUTS.index(layout)`` set for each layout that carries it."""
        return sum(1 << BASE_LAYOUTS.index(name) for name in self.layouts)


_FOOT_POINTS = len(FOOT_GRID) ** 2
CRITIC_TERMS = (
    CriticTerm("base_lin_vel", 3, "base linear velocity in the body frame [m/s]", base_lin_vel, base_lin_vel_np),
    CriticTerm("base_ang_vel", 3, "base angular velocity in the body frame [rad/s]", base_ang_vel, base_ang_vel_np),
    CriticTerm("foot_heights", LEGS * _FOOT_POINTS, f"per leg (R1..L3) the ground at the {_FOOT_POINTS} points "
               "FOOT_GRID x FOOT_GRID around the foot's centre, minus the centre's height [m]", foot_heights,
               foot_heights_np),
    CriticTerm("ahead_heights", len(AHEAD_X) * len(AHEAD_Y), "the ground at AHEAD_X x AHEAD_Y ahead of the base in "
               "its heading frame, minus the base height [m]", ahead_heights, ahead_heights_np),
    CriticTerm("leg_forces", 3 * LEGS, "per leg (R1..L3) the contact force on the lower leg (shin and foot), world "
               "frame [N]; 0 on an episode's first step", leg_forces, leg_forces_np),
    CriticTerm("physics", len(PHYSICS), "the env's randomised physics: " + ", ".join(PHYSICS), physics, physics_np),
    CriticTerm("cpg_phase", 4, "each oscillator's phase as the unit vector of its (x, y)", cpg_phase, cpg_phase_np,
               CPG),
)  # fmt: skip


def _layout(layout: str) -> tuple[tuple[str, int, int], ...]:
    spans, k = [], 0
    for t in CRITIC_TERMS:
        if layout in t.layouts:
            spans.append((t.name, k, k + t.size))
            k += t.size
    return tuple(spans)


#: (name, start, end) of each part, per layout
CRITIC_LAYOUT = {layout: _layout(layout) for layout in BASE_LAYOUTS}
CRITIC_DIM = {layout: spans[-1][2] for layout, spans in CRITIC_LAYOUT.items()}


def _describe(layout: str) -> str:
    doc = {t.name: t.doc for t in CRITIC_TERMS}
    rows = [f"    [{a}:{b}]".ljust(14) + doc[name] for name, a, b in CRITIC_LAYOUT[layout]]
    return f"``{layout}`` ({CRITIC_DIM[layout]}):\n" + "\n".join(rows)


if __doc__:  # None under python -OO
    __doc__ += "\n" + "\n\n".join(_describe(layout) for layout in ("cpg", "joint")) + "\n"


def physics_columns(draws: dict, late: np.ndarray | None, robot, num_envs: int) -> np.ndarray:
    """(N, len(PHYSICS)) float32: each env's ``draws`` (``randomize_physics``' dict; {} without randomisation) and its
    ``late`` flag (None: none late), the nominal ``robot`` (a ``RobotConfig``) where nothing was drawn."""
    nominal = {"friction": robot.friction, "payload": 0.0, "link_mass_scale": 1.0, "kp_scale": 1.0, "kd_scale": 1.0,
               "effort_scale": 1.0, "foot_radius": robot.foot_radius, "contact_timeconst": NOMINAL_TIMECONST,
               "late": 0.0}  # fmt: skip
    values = dict(draws, late=np.zeros(num_envs) if late is None else np.asarray(late, np.float64))
    return np.stack([np.broadcast_to(np.asarray(values.get(name, nominal[name]), np.float64), num_envs)
                     for name in PHYSICS], axis=1).astype(np.float32)  # fmt: skip


@wp.kernel
def critic_kernel(inputs: CriticInputs, layout: int, out: wp.array2d[wp.float32]):
    """The critic group of each env in layout ``BASE_LAYOUTS[layout]``: the parts of ``CRITIC_TERMS`` that it carries,
    in table order; a value that is not finite becomes 0."""
    env = wp.tid()
    col = int(0)
    for row in range(wp.static(len(CRITIC_TERMS))):
        if (wp.static(CRITIC_TERMS[row].mask) >> layout) & 1 != 0:
            wp.static(CRITIC_TERMS[row].func)(inputs, env, out, col)
            col += wp.static(CRITIC_TERMS[row].size)
    for j in range(out.shape[1]):
        if not wp.isfinite(out[env, j]):
            out[env, j] = 0.0


def critic_reference(inputs, layout: str) -> np.ndarray:
    """Float64 reference of :func:`critic_kernel`. ``inputs`` has :class:`CriticInputs`' fields as NumPy arrays
    (``body_q`` (bodies, 7), ``forces`` (N, 6, 3)) and, in place of ``hf``, ``ground_at(x, y)`` returning terrain
    heights (vectorised), e.g. ``terrain_height_np`` bound to a grid."""
    with np.errstate(invalid="ignore"):
        out = np.concatenate([t.reference(inputs) for t in CRITIC_TERMS if layout in t.layouts], axis=1)
    return np.where(np.isfinite(out), out, 0.0)

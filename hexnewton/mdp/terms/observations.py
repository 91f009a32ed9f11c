"""Observations (§2.4.1): ``OBS_TERMS``, one :class:`ObsTerm` row per part of the policy's observation in layout
order, the fused kernel (:func:`observations_kernel`, one launch for every layout) and its float64 reference
(:func:`observations_reference`); the layouts, their sizes and the noise per column follow from the table.

The paper says the state has 59 dimensions but lists 54 (18 joint positions, 18 joint velocities, the target (x, y, z),
the 14 amplitudes A1[2], A2[6], A3[6], the maximum terrain height h); we add omega and the base orientation as a unit
quaternion. ``hexnewton.deploy.runtime`` assembles the same parts from the robot's sensors by name;
``docs/internals.md`` ("The MDP") says how to add a part.

A layout is its action mode's (``BASE_LAYOUTS``) with the rows that ``ObsConfig``'s switches (``SWITCHES``) turn on
appended, named ``base+switch+...`` (:func:`layout_name`: ``cpg_posture+gyro+last_action``). Base layouts (from the
table):
"""

from dataclasses import dataclass
from itertools import combinations
from typing import Callable

import numpy as np
import warp as wp

from hexnewton.config import JOINT_NAMES, PARAM_NAMES, POSTURE_NAMES
from hexnewton.mdp.terms.goals import Goals
from hexnewton.mdp.terms.ground import HeightField, max_terrain_height, terrain_height
from hexnewton.mdp.terms.structs import TaskParams
from hexnewton.kernels.cpg import quat_to_rpy
from hexnewton.kernels.reference import quat_rotate_inv_np, quat_to_rpy_np

#: ours: the square that "max height h" looks at: +-30 cm, about the paper robot's legs' reach [m] (another robot's x
#: ``TaskConfig.length_scale``)
H_HALF_EXTENT = 0.3
#: ``cpg``: the paper's (15 CPG parameters); ``cpg_posture``: with the body posture (18); ``joint``: the pure-DRL
#: comparison (no CPG parameters)
BASE_LAYOUTS = ("cpg", "cpg_posture", "joint")
CPG = ("cpg", "cpg_posture")
#: the policy's actions per base layout (the columns of ``last_action``)
LAYOUT_ACTIONS = {"cpg": len(PARAM_NAMES), "cpg_posture": len(PARAM_NAMES) + len(POSTURE_NAMES),
                  "joint": len(JOINT_NAMES)}
#: the ``ObsConfig`` fields that add rows to the policy's observation, in the order a layout's name lists them
SWITCHES = ("gyro", "last_action")


def layout_name(base: str, obs=None) -> str:
    """The layout of base layout ``base`` with the rows ``obs`` (an ``ObsConfig``; None: none) switches on."""
    return "+".join((base, *(name for name in SWITCHES if obs is not None and getattr(obs, name))))


def layout_parts(layout: str) -> tuple[str, tuple[str, ...]]:
    """(base layout, switches on) of a layout's name."""
    base, *switches = layout.split("+")
    return base, tuple(switches)


#: every layout: the base layouts first (their indices are those of ``BASE_LAYOUTS``), then with each set of switches
LAYOUTS = tuple("+".join((base, *on)) for k in range(len(SWITCHES) + 1) for on in combinations(SWITCHES, k)
                for base in BASE_LAYOUTS)


@wp.struct
class ObsInputs:
    """What the observation reads, one row per env."""

    joint_q: wp.array2d[wp.float32]  # base position (3), quaternion (x, y, z, w), 18 joint angles
    joint_qd: wp.array2d[wp.float32]  # base linear and angular velocity, 18 joint velocities
    params: wp.array2d[wp.float32]  # the CPG parameters the controller runs with (filtered); unread in ``joint``
    goals: Goals  # each env's goal (goals.py)
    actions: wp.array2d[wp.float32]  # the policy's last actions, as the rewards kernel kept them (clamped)
    episode_steps: wp.array[wp.int32]  # control steps of the episode so far (0: it has just begun)
    hf: HeightField
    task: TaskParams


# ----------------------------------------------------------------------------------------------------
# the parts: each Warp function writes its values to obs[env, col:col + size]; each NumPy function returns (N, size)
# ----------------------------------------------------------------------------------------------------


@wp.func
def joint_pos(inputs: ObsInputs, env: int, obs: wp.array2d[wp.float32], col: int):
    for j in range(18):
        obs[env, col + j] = inputs.joint_q[env, 7 + j]


def joint_pos_np(inputs):
    return np.asarray(inputs.joint_q, np.float64)[:, 7:25]


@wp.func
def joint_vel(inputs: ObsInputs, env: int, obs: wp.array2d[wp.float32], col: int):
    for j in range(18):
        obs[env, col + j] = inputs.joint_qd[env, 6 + j]


def joint_vel_np(inputs):
    return np.asarray(inputs.joint_qd, np.float64)[:, 6:24]


@wp.func
def target(inputs: ObsInputs, env: int, obs: wp.array2d[wp.float32], col: int):
    gx = inputs.goals.goal[env][0]
    gy = inputs.goals.goal[env][1]
    dx = gx - inputs.joint_q[env, 0]
    dy = gy - inputs.joint_q[env, 1]
    yaw = quat_to_rpy(wp.normalize(wp.quat(inputs.joint_q[env, 3], inputs.joint_q[env, 4], inputs.joint_q[env, 5],
                                           inputs.joint_q[env, 6])))[2]  # fmt: skip
    c = wp.cos(yaw)
    s = wp.sin(yaw)
    obs[env, col] = c * dx + s * dy
    obs[env, col + 1] = -s * dx + c * dy
    obs[env, col + 2] = (terrain_height(inputs.hf, gx, gy) - inputs.joint_q[env, 2]) / inputs.task.height_scale


def target_np(inputs):
    jq, goal = np.asarray(inputs.joint_q, np.float64), np.asarray(inputs.goals.goal, np.float64)
    gx, gy = goal[:, 0], goal[:, 1]
    dx, dy = gx - jq[:, 0], gy - jq[:, 1]
    yaw = quat_to_rpy_np(jq[:, 3:7])[:, 2]
    c, s = np.cos(yaw), np.sin(yaw)
    z = (inputs.ground_at(gx, gy) - jq[:, 2]) / inputs.task.height_scale
    return np.stack([c * dx + s * dy, -s * dx + c * dy, z], axis=1)


@wp.func
def omega(inputs: ObsInputs, env: int, obs: wp.array2d[wp.float32], col: int):
    obs[env, col] = inputs.params[env, 0]


def omega_np(inputs):
    return np.asarray(inputs.params, np.float64)[:, :1]


@wp.func
def amplitudes(inputs: ObsInputs, env: int, obs: wp.array2d[wp.float32], col: int):
    for j in range(14):
        obs[env, col + j] = inputs.params[env, 1 + j]


def amplitudes_np(inputs):
    return np.asarray(inputs.params, np.float64)[:, 1:15]


@wp.func
def posture(inputs: ObsInputs, env: int, obs: wp.array2d[wp.float32], col: int):
    for j in range(3):
        obs[env, col + j] = inputs.params[env, 15 + j]


def posture_np(inputs):
    return np.asarray(inputs.params, np.float64)[:, 15:18]


@wp.func
def quat(inputs: ObsInputs, env: int, obs: wp.array2d[wp.float32], col: int):
    sign = float(1.0)
    if inputs.joint_q[env, 6] < 0.0:
        sign = -1.0
    for j in range(4):
        obs[env, col + j] = sign * inputs.joint_q[env, 3 + j]


def quat_np(inputs):
    jq = np.asarray(inputs.joint_q, np.float64)
    return jq[:, 3:7] * np.where(jq[:, 6:7] < 0, -1.0, 1.0)


@wp.func
def max_height(inputs: ObsInputs, env: int, obs: wp.array2d[wp.float32], col: int):
    px = inputs.joint_q[env, 0]
    py = inputs.joint_q[env, 1]
    half = H_HALF_EXTENT * inputs.task.length_scale
    h = max_terrain_height(inputs.hf, px, py, half) - terrain_height(inputs.hf, px, py)
    obs[env, col] = h / inputs.task.height_scale


def max_height_np(inputs):
    jq = np.asarray(inputs.joint_q, np.float64)
    t = inputs.task
    h = inputs.ground_at.max(jq[:, 0], jq[:, 1], H_HALF_EXTENT * t.length_scale) - inputs.ground_at(jq[:, 0], jq[:, 1])
    return (h / t.height_scale)[:, None]


@wp.func
def gyro(inputs: ObsInputs, env: int, obs: wp.array2d[wp.float32], col: int):
    q = wp.normalize(wp.quat(inputs.joint_q[env, 3], inputs.joint_q[env, 4], inputs.joint_q[env, 5],
                             inputs.joint_q[env, 6]))  # fmt: skip
    w = wp.quat_rotate_inv(q, wp.vec3(inputs.joint_qd[env, 3], inputs.joint_qd[env, 4], inputs.joint_qd[env, 5]))
    for j in range(3):
        obs[env, col + j] = w[j]


def gyro_np(inputs):
    return quat_rotate_inv_np(np.asarray(inputs.joint_q, np.float64)[:, 3:7],
                              np.asarray(inputs.joint_qd, np.float64)[:, 3:6])  # fmt: skip


@wp.func
def last_action(inputs: ObsInputs, env: int, obs: wp.array2d[wp.float32], col: int):
    begun = inputs.episode_steps[env] > 0
    for j in range(inputs.actions.shape[1]):
        a = float(0.0)
        if begun:
            a = inputs.actions[env, j]
        obs[env, col + j] = a


def last_action_np(inputs):
    begun = np.asarray(inputs.episode_steps)[:, None] > 0
    return np.where(begun, np.asarray(inputs.actions, np.float64), 0.0)


# ----------------------------------------------------------------------------------------------------
# the table
# ----------------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class ObsTerm:
    """One part of the observation: ``size`` values (None: one per action, ``LAYOUT_ACTIONS``) in the layouts that
    carry it, in table order: those whose base layout is in ``layouts`` and, for a row with a ``switch`` (an
    ``ObsConfig`` field), that have it on."""

    name: str
    size: int | None
    doc: str
    noise: str | None  # the RandomizationConfig field of its uniform noise amplitude (None: exact)
    func: wp.Function  # (ObsInputs, env, obs, first column) writes the part's values
    reference: Callable  # float64 NumPy (inputs namespace) -> (N, size)
    layouts: tuple[str, ...] = BASE_LAYOUTS
    switch: str | None = None

    def carried_by(self, layout: str) -> bool:
        base, on = layout_parts(layout)
        return base in self.layouts and (self.switch is None or self.switch in on)

    def size_in(self, layout: str) -> int:
        return LAYOUT_ACTIONS[layout_parts(layout)[0]] if self.size is None else self.size

    @property
    def mask(self) -> int:
        """Bit ``LAYOUTS.index(layout)`` set for each layout that carries it."""
        return sum(1 << k for k, name in enumerate(LAYOUTS) if self.carried_by(name))


OBS_TERMS = (
    ObsTerm("joint_pos", 18, "joint positions [rad], order R1..L3 x (hip, knee, ankle)", "noise_joint_pos",
            joint_pos, joint_pos_np),
    ObsTerm("joint_vel", 18, "joint velocities [rad/s]", "noise_joint_vel", joint_vel, joint_vel_np),
    ObsTerm("target", 3, "target relative to the robot in its heading frame (x forward, y left; z = goal ground - "
            "base z, / the robot's height_scale) [m]", "noise_target", target, target_np),
    # the CPG parameters are the controller's own: exact
    ObsTerm("omega", 1, "omega [rad/s] (the filtered parameter the CPG runs with)", None, omega, omega_np, CPG),
    ObsTerm("amplitudes", 14, "A1_R, A1_L, A2[R1..L3], A3[R1..L3] [rad] (filtered)", None, amplitudes,
            amplitudes_np, CPG),
    ObsTerm("posture", 3, "body posture P_h, P_p, P_r [rad] (filtered)", None, posture, posture_np,
            ("cpg_posture",)),
    ObsTerm("quat", 4, "base orientation quaternion (x, y, z, w), sign chosen so that w >= 0", "noise_quat", quat,
            quat_np),
    ObsTerm("max_height", 1, "h: highest terrain within +-H_HALF_EXTENT (x the robot's length_scale) of the base, "
            "minus the terrain under the base (/ its height_scale) [m]", "noise_height", max_height, max_height_np),
    # ours, ObsConfig's switches (off: the paper's observation)
    ObsTerm("gyro", 3, "base angular velocity in the body frame (x forward, y left, z up) [rad/s], an IMU's gyro",
            "noise_gyro", gyro, gyro_np, switch="gyro"),
    ObsTerm("last_action", None, "the policy's last actions, clamped to [-1, 1]; 0 before the episode's first",
            None, last_action, last_action_np, switch="last_action"),
)  # fmt: skip


def _layout(layout: str) -> tuple[tuple[str, int, int], ...]:
    spans, k = [], 0
    for t in OBS_TERMS:
        if t.carried_by(layout):
            spans.append((t.name, k, k + t.size_in(layout)))
            k += t.size_in(layout)
    return tuple(spans)


#: (name, start, end) of each part, per layout
OBS_LAYOUT = {layout: _layout(layout) for layout in LAYOUTS}
OBS_DIM = {layout: spans[-1][2] for layout, spans in OBS_LAYOUT.items()}


def _describe(layout: str) -> str:
    doc = {t.name: t.doc for t in OBS_TERMS}
    rows = [f"    [{a}:{b}]".ljust(14) + doc[name] if b > a + 1 else f"    [{a}]".ljust(14) + doc[name]
            for name, a, b in OBS_LAYOUT[layout]]
    return f"``{layout}`` ({OBS_DIM[layout]}):\n" + "\n".join(rows)


def _describe_switches() -> str:
    doc = {t.name: (t.switch, t.doc, t.size) for t in OBS_TERMS if t.switch}
    rows = [f"    {name} ({size or 'one per action'}, ``ObsConfig.{switch}``): {text}"
            for name, (switch, text, size) in doc.items()]  # fmt: skip
    return "Appended by the switches, in this order:\n" + "\n".join(rows)


if __doc__:  # None under python -OO
    __doc__ += "\n" + "\n\n".join([*(_describe(layout) for layout in BASE_LAYOUTS), _describe_switches()]) + "\n"


def obs_span(layout: str, name: str) -> tuple[int, int]:
    """The columns [start, end) of part ``name`` in ``layout``'s observation."""
    _, a, b = next(span for span in OBS_LAYOUT[layout] if span[0] == name)
    return a, b


def observation_noise(layout: str, randomization) -> np.ndarray:
    """Uniform noise amplitude per column of ``layout`` from a ``RandomizationConfig`` (0 where exact)."""
    noise = np.zeros(OBS_DIM[layout], np.float32)
    for t in OBS_TERMS:
        if t.noise is not None and t.carried_by(layout):
            a, b = obs_span(layout, t.name)
            noise[a:b] = getattr(randomization, t.noise)
    return noise


@wp.kernel
def observations_kernel(inputs: ObsInputs, layout: int, obs: wp.array2d[wp.float32]):
    """The observation of each env in layout ``LAYOUTS[layout]``: the parts of ``OBS_TERMS`` that it carries, in
    table order."""
    env = wp.tid()
    col = int(0)
    for row in range(wp.static(len(OBS_TERMS))):
        if (wp.static(OBS_TERMS[row].mask) >> layout) & 1 != 0:
            wp.static(OBS_TERMS[row].func)(inputs, env, obs, col)
            if wp.static(OBS_TERMS[row].size is None):  # one column per action
                col += inputs.actions.shape[1]
            else:
                col += wp.static(OBS_TERMS[row].size or 0)


def observations_reference(inputs, layout: str) -> np.ndarray:
    """Float64 reference of :func:`observations_kernel`. ``inputs`` has :class:`ObsInputs`' fields as NumPy arrays, with
    ``task`` a ``TaskConfig`` and, in place of ``hf``, ``ground_at(x, y)`` returning terrain heights and
    ``ground_at.max(x, y, half_extent)`` the max over a square (both vectorised), e.g. ``terrain_height_np`` /
    ``max_terrain_height_np`` bound to a grid."""
    return np.concatenate([t.reference(inputs) for t in OBS_TERMS if t.carried_by(layout)], axis=1)

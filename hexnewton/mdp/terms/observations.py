"""Observations (§2.4.1): ``OBS_TERMS``, one :class:`ObsTerm` row per part of the policy's observation in layout
order, the fused kernel (:func:`observations_kernel`, one launch for every layout) and its float64 reference
(:func:`observations_reference`); the layouts, their sizes and the noise per column follow from the table.

The paper says the state has 59 dimensions but lists 54 (18 joint positions, 18 joint velocities, the target (x, y, z),
the 14 amplitudes A1[2], A2[6], A3[6], the maximum terrain height h); we add omega and the base orientation as a unit
quaternion. ``hexnewton.deploy.runtime`` assembles the same parts from the robot's sensors by name;
``docs/internals.md`` ("The MDP") says how to add a part.

Layouts (from the table):
"""

from dataclasses import dataclass
from typing import Callable

import numpy as np
import warp as wp

from hexnewton.mdp.terms.ground import HeightField, max_terrain_height, terrain_height
from hexnewton.mdp.terms.structs import TaskParams
from hexnewton.physics.cpg import quat_to_rpy
from hexnewton.physics.reference import quat_to_rpy_np

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
    gx = inputs.start[env][0] + inputs.task.goal_distance
    gy = inputs.start[env][1]
    dx = gx - inputs.joint_q[env, 0]
    dy = gy - inputs.joint_q[env, 1]
    yaw = quat_to_rpy(wp.normalize(wp.quat(inputs.joint_q[env, 3], inputs.joint_q[env, 4], inputs.joint_q[env, 5],
                                           inputs.joint_q[env, 6])))[2]  # fmt: skip
    c = wp.cos(yaw)
    s = wp.sin(yaw)
    obs[env, col] = c * dx + s * dy
    obs[env, col + 1] = -s * dx + c * dy
    obs[env, col + 2] = terrain_height(inputs.hf, gx, gy) - inputs.joint_q[env, 2]


def target_np(inputs):
    jq, start = np.asarray(inputs.joint_q, np.float64), np.asarray(inputs.start, np.float64)
    gx, gy = start[:, 0] + inputs.task.goal_distance, start[:, 1]
    dx, dy = gx - jq[:, 0], gy - jq[:, 1]
    yaw = quat_to_rpy_np(jq[:, 3:7])[:, 2]
    c, s = np.cos(yaw), np.sin(yaw)
    return np.stack([c * dx + s * dy, -s * dx + c * dy, inputs.ground_at(gx, gy) - jq[:, 2]], axis=1)


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
    obs[env, col] = max_terrain_height(inputs.hf, px, py, H_HALF_EXTENT) - terrain_height(inputs.hf, px, py)


def max_height_np(inputs):
    jq = np.asarray(inputs.joint_q, np.float64)
    return (inputs.ground_at.max(jq[:, 0], jq[:, 1], H_HALF_EXTENT) - inputs.ground_at(jq[:, 0], jq[:, 1]))[:, None]


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


def obs_span(layout: str, name: str) -> tuple[int, int]:
    """The columns [start, end) of part ``name`` in ``layout``'s observation."""
    _, a, b = next(span for span in OBS_LAYOUT[layout] if span[0] == name)
    return a, b


def observation_noise(layout: str, randomization) -> np.ndarray:
    """Uniform noise amplitude per column of ``layout`` from a ``RandomizationConfig`` (0 where exact)."""
    noise = np.zeros(OBS_DIM[layout], np.float32)
    for t in OBS_TERMS:
        if t.noise is not None and layout in t.layouts:
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
            col += wp.static(OBS_TERMS[row].size)


def observations_reference(inputs, layout: str) -> np.ndarray:
    """Float64 reference of :func:`observations_kernel`. ``inputs`` has :class:`ObsInputs`' fields as NumPy arrays, with
    ``task`` a ``TaskConfig`` and, in place of ``hf``, ``ground_at(x, y)`` returning terrain heights and
    ``ground_at.max(x, y, half_extent)`` the max over a square (both vectorised), e.g. ``terrain_height_np`` /
    ``max_terrain_height_np`` bound to a grid."""
    return np.concatenate([t.reference(inputs) for t in OBS_TERMS if layout in t.layouts], axis=1)

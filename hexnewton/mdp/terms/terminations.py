"""Episode ends (§2.4.4): ``TERMINATIONS``, one :class:`Termination` row per status code, its fused kernel
(:func:`make_status_kernel`) and its float64 reference (:func:`episode_status_np`), the episode's one NumPy definition
of its ends in ``hexnewton/deploy/rules.py`` (which the robot runtime and C MuJoCo's closed loop share).

The status codes and their names live in ``hexnewton/mdp/status.py``. The rows, in the order the kernel checks them
(the first that holds is the env's status; 0, running, if none does):

- ``nonfinite``: the physics blew up (NaN/Inf in the state, or a base or joint speed above its limit);
- ``fell``: the torso is below ``min_height`` above the terrain, or |roll| or |pitch| exceeds ``max_tilt``;
- ``off_course``: more than ``max_abs_y`` from the line to the goal (the start-to-goal line: |y - y_start| on the
  straight tasks);
- ``success``: within ``goal_radius`` of the episode's last goal (``goals.py``: on the straight tasks the one goal,
  ``goal_distance`` ahead of the start);
- ``timeout``: this step is the episode's ``max_episode_steps``-th.

The kernel also writes roll, pitch and yaw (0 for a blown-up env) for the rewards, logging and recording.
``docs/internals.md`` ("The MDP") gives the reasons and how to add an end."""

import functools
from dataclasses import dataclass
from typing import Callable

import warp as wp

from hexnewton.deploy import rules
from hexnewton.mdp.status import FELL, NONFINITE, OFF_COURSE, RUNNING, STATUS_NAMES, SUCCESS, TIMEOUT
from hexnewton.mdp.terms.goals import Goals, goal_reached, off_line
from hexnewton.mdp.terms.ground import HeightField, terrain_height
from hexnewton.mdp.terms.structs import TaskParams, choose
from hexnewton.kernels.cpg import quat_to_rpy


@wp.struct
class EndInputs:
    """What the end conditions read, one row per env."""

    joint_q: wp.array2d[wp.float32]  # base position (3), quaternion (x, y, z, w), 18 joint angles
    joint_qd: wp.array2d[wp.float32]  # base linear and angular velocity, 18 joint velocities
    episode_steps: wp.array[wp.int32]  # the episode's steps before this one
    goals: Goals  # each env's goal (goals.py)
    hf: HeightField
    task: TaskParams


@wp.struct
class EndFrame:
    """Per-env values the conditions share (:func:`end_frame`)."""

    env: int
    px: float  # base position [m]
    py: float
    pz: float
    rpy: wp.vec3  # roll, pitch, yaw of the (normalised) base quaternion


@wp.func
def end_frame(inputs: EndInputs, env: int) -> EndFrame:
    """Env ``env``'s :class:`EndFrame`."""
    frame = EndFrame()
    frame.env = env
    frame.px = inputs.joint_q[env, 0]
    frame.py = inputs.joint_q[env, 1]
    frame.pz = inputs.joint_q[env, 2]
    frame.rpy = quat_to_rpy(wp.normalize(wp.quat(inputs.joint_q[env, 3], inputs.joint_q[env, 4], inputs.joint_q[env, 5],
                                                 inputs.joint_q[env, 6])))
    return frame


#: float64 end frame of all envs (``inputs`` with :class:`EndInputs`' fields as NumPy arrays, ``ground`` (N,), the
#: terrain under each base, in place of ``hf``, and ``task`` a ``TaskConfig``): the shared rule's
EndFrameNp, end_frame_np = rules.EndFrame, rules.end_frame


# ----------------------------------------------------------------------------------------------------
# the conditions: one Warp function per env; their float64 twins are hexnewton/deploy/rules.py's
# ----------------------------------------------------------------------------------------------------


@wp.func
def nonfinite(inputs: EndInputs, frame: EndFrame) -> bool:
    """NaN/Inf in the state, or a runaway: base speed above ``max_base_speed``, a joint's above ``max_joint_speed``."""
    finite = bool(True)
    for k in range(inputs.joint_q.shape[1]):
        finite = finite and wp.isfinite(inputs.joint_q[frame.env, k])
    for k in range(inputs.joint_qd.shape[1]):
        v = inputs.joint_qd[frame.env, k]
        finite = finite and wp.isfinite(v)
        if k >= 6 and wp.abs(v) > inputs.task.max_joint_speed:
            finite = False
    base_v = wp.vec3(inputs.joint_qd[frame.env, 0], inputs.joint_qd[frame.env, 1],
                     inputs.joint_qd[frame.env, 2])  # fmt: skip
    if wp.length(base_v) > inputs.task.max_base_speed:
        finite = False
    return not finite




@wp.func
def fell(inputs: EndInputs, frame: EndFrame) -> bool:
    """The torso less than ``min_height`` (x the robot's ``height_scale``) above the terrain under it, or |roll| or
    |pitch| above ``max_tilt``."""
    lim = inputs.task.max_tilt
    low = frame.pz - terrain_height(inputs.hf, frame.px, frame.py) < inputs.task.min_height * inputs.task.height_scale
    return low or wp.abs(frame.rpy[0]) > lim or wp.abs(frame.rpy[1]) > lim




@wp.func
def left_course(inputs: EndInputs, frame: EndFrame) -> bool:
    """More than ``max_abs_y`` from the line through the goal along its course (|y - y_start| going along +x)."""
    return wp.abs(off_line(inputs.goals, frame.env, frame.px, frame.py)) > inputs.task.max_abs_y




@wp.func
def success(inputs: EndInputs, frame: EndFrame) -> bool:
    """Within ``goal_radius`` of the episode's last goal (``goals.left`` 0)."""
    last = inputs.goals.left[frame.env] == 0
    return last and goal_reached(inputs.goals, frame.env, frame.px, frame.py, inputs.task.goal_radius)




@wp.func
def timeout(inputs: EndInputs, frame: EndFrame) -> bool:
    """This step is the episode's ``max_episode_steps``-th."""
    return inputs.episode_steps[frame.env] + 1 >= inputs.task.max_episode_steps




# ----------------------------------------------------------------------------------------------------
# the table
# ----------------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class Termination:
    """One episode end: status ``code`` (``STATUS_NAMES``) when ``func`` holds and no earlier row does."""

    code: int
    func: wp.Function  # (EndInputs, EndFrame) -> bool for one env
    reference: Callable  # its rule in deploy/rules.py: float64 NumPy (inputs namespace, end_frame_np) -> (N,) bool

    @property
    def name(self) -> str:
        return STATUS_NAMES[self.code]


TERMINATIONS = (
    Termination(NONFINITE, nonfinite, rules.nonfinite),
    Termination(FELL, fell, rules.fell),
    Termination(OFF_COURSE, left_course, rules.left_course),
    Termination(SUCCESS, success, rules.success),
    Termination(TIMEOUT, timeout, rules.timeout),
)
assert [(t.name, t.code, t.reference) for t in TERMINATIONS] == list(rules.ENDS), "the shared rules' ends, in order"
assert sorted(t.code for t in TERMINATIONS) == list(range(1, len(STATUS_NAMES))), "one row per status code"


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
    def episode_status_kernel(inputs: EndInputs, status: wp.array[wp.int32], rpy: wp.array2d[wp.float32]):
        """Each env's status: the code of the first row whose condition holds, else ``RUNNING``; and its roll, pitch,
        yaw (0 for a blown-up env)."""
        env = wp.tid()
        frame = end_frame(inputs, env)
        s = int(RUNNING)
        for k in range(wp.static(len(table))):
            if s == RUNNING:
                if wp.static(table[k].func)(inputs, frame):
                    s = wp.static(table[k].code)
        status[env] = s
        a = frame.rpy
        if s == NONFINITE:
            a = wp.vec3(0.0)
        for k in range(3):
            rpy[env, k] = a[k]

    return episode_status_kernel


episode_status_kernel = make_status_kernel()


def episode_status_np(inputs, names: tuple[str, ...] | None = None):
    """Float64 reference of :func:`make_status_kernel`'s kernel (inputs as in :func:`end_frame_np`): (status, rpy), the
    shared rule's (``hexnewton.deploy.rules.episode_status``)."""
    table = TERMINATIONS if names is None else choose(TERMINATIONS, names, "task.terminations")
    return rules.episode_status(inputs, tuple(t.name for t in table))

"""The rules of an episode, in float64 NumPy for all robots at once: its status codes, its ends (§2.4.4) and its goals.
This is their one definition: the robot runtime (:class:`hexnewton.deploy.runtime.Controller`'s goals), C MuJoCo's
closed loop (``analysis/sim2sim.py``) and the simulator's float64 twins of its Warp kernels
(``mdp/terms/terminations.py``, ``mdp/terms/goals.py``) all call these functions; ``tests/mdp/test_rules.py`` checks the
Warp kernels against them on random states. NumPy only (the deployment runtime's), no Warp, Newton or torch.

The ends, in the order they are checked (the first that holds is the status; ``RUNNING`` if none does), :data:`ENDS`:

- ``nonfinite``: NaN/Inf in the state, or a base speed above ``max_base_speed`` or a joint's above ``max_joint_speed``;
- ``fell``: the torso below ``min_height`` above the ground under it, or |roll| or |pitch| above ``max_tilt``;
- ``off_course``: more than ``max_abs_y`` from the line through the goal along its course;
- ``success``: within ``goal_radius`` of the episode's last goal (``left`` 0);
- ``timeout``: this step is the episode's ``max_episode_steps``-th.

The goals (``mdp/terms/goals.py``'s docstring says why): :func:`set_goal` gives goal number ``k`` of an episode (a
waypoint of the course in the start frame, a random goal from two draws, or the paper's ``goal_distance`` ahead along
+x), :func:`goal_switch` the next one to a robot still running within ``goal_radius`` of a goal that is not its last.
The goals' state (:class:`Goals`' fields) and the ends' inputs (:class:`EndInputs`' fields) are NumPy arrays, one row
per robot; the task's numbers come from any object with ``TaskConfig``'s field names."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from hexnewton.kernels.reference import quat_to_rpy_np

RUNNING, FELL, OFF_COURSE, SUCCESS, TIMEOUT, NONFINITE = 0, 1, 2, 3, 4, 5
STATUS_NAMES = ("running", "fell", "off_course", "success", "timeout", "nonfinite")


# ----------------------------------------------------------------------------------------------------
# the goals
# ----------------------------------------------------------------------------------------------------


@dataclass
class Goals:
    """Each robot's goal and what sets the next, as ``mdp/terms/goals.py``'s Warp struct: ``goal``, ``course`` (N, 2),
    ``left`` (goals after this one: 0 the last, -1 no end), ``reached`` (N,), ``start`` (N, 2), ``start_yaw`` (N,),
    ``waypoints`` (N, K, 2) in the start frame and ``waypoint_count`` K (0: none)."""

    goal: np.ndarray
    course: np.ndarray
    left: np.ndarray
    reached: np.ndarray
    start: np.ndarray
    start_yaw: np.ndarray
    waypoints: np.ndarray
    waypoint_count: int


def start_goals(start, start_yaw, waypoints=None) -> Goals:
    """:class:`Goals` of robots starting at ``start`` (N, 2) heading ``start_yaw`` (N,) with a waypoint course
    ``waypoints`` ((K, 2) for all or (N, K, 2); None: none), no goal set yet (:func:`set_goal` with k = 0)."""
    start = np.asarray(start, np.float64).reshape(-1, 2)
    n = len(start)
    w = np.zeros((n, 0, 2)) if waypoints is None else np.asarray(waypoints, np.float64)
    w = np.broadcast_to(w, (n, *w.shape)) if w.ndim == 2 else w
    yaw = np.broadcast_to(np.asarray(start_yaw, np.float64), (n,)).copy()
    return Goals(goal=np.zeros((n, 2)), course=np.tile([1.0, 0.0], (n, 1)), left=np.zeros(n, np.int64),
                 reached=np.zeros(n, np.int64), start=start, start_yaw=yaw, waypoints=w, waypoint_count=w.shape[1])


def waypoints_world(start, start_yaw, waypoints) -> np.ndarray:
    """Waypoints (N, K, 2) in each start frame (x along the start heading) in the world: (N, K, 2)."""
    s, a, w = (np.asarray(v, np.float64) for v in (start, start_yaw, waypoints))
    c, sn = np.cos(a)[:, None], np.sin(a)[:, None]
    return np.stack([s[:, :1] + c * w[..., 0] - sn * w[..., 1], s[:, 1:] + sn * w[..., 0] + c * w[..., 1]], axis=-1)


def goal_from_draws(x, y, yaw, u_bearing, u_distance, start, task) -> np.ndarray:
    """A random goal (N, 2) for robots at (x, y) heading ``yaw`` from two uniform draws in [0, 1): bearing
    yaw + goal_bearing (2 u_bearing - 1), distance goal_distance_min + (max - min) u_distance, mirrored back into the
    square of +-goal_area around ``start`` along each axis it leaves by, then clamped to it."""
    x, y, start = np.asarray(x, np.float64), np.asarray(y, np.float64), np.asarray(start, np.float64)
    bearing = np.asarray(yaw, np.float64) + task.goal_bearing * (2.0 * np.asarray(u_bearing, np.float64) - 1.0)
    r = task.goal_distance_min + (task.goal_distance_max - task.goal_distance_min) * np.asarray(u_distance, np.float64)
    ox, oy = r * np.cos(bearing), r * np.sin(bearing)
    a = task.goal_area
    ox = np.where(np.abs(x + ox - start[:, 0]) > a, -ox, ox)
    oy = np.where(np.abs(y + oy - start[:, 1]) > a, -oy, oy)
    return np.stack([np.clip(x + ox, start[:, 0] - a, start[:, 0] + a), np.clip(y + oy, start[:, 1] - a, start[:, 1] + a)],
                    axis=1)  # fmt: skip


def course_to(x, y, goal) -> np.ndarray:
    """The unit vectors (N, 2) from (x, y) to ``goal`` (+x for a goal within 1 um)."""
    d = np.asarray(goal, np.float64) - np.stack([np.asarray(x, np.float64), np.asarray(y, np.float64)], axis=1)
    n = np.hypot(d[:, 0], d[:, 1])
    return np.where((n > 1e-6)[:, None], d / np.where(n > 1e-6, n, 1.0)[:, None], [1.0, 0.0])


def set_goal(goals, task, k, x, y, yaw, u_bearing, u_distance) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Goal number ``k`` (N,) of the episode (0: the first) for robots at (x, y) heading ``yaw``: the waypoint, the
    random goal (from the two draws, ``task.random_goals``) or the goal ahead; (goal (N, 2), course (N, 2), left (N,)).
    ``goals``: :class:`Goals`' fields (only the course and the start are read)."""
    x, y, k = np.asarray(x, np.float64), np.asarray(y, np.float64), np.asarray(k)
    n = int(goals.waypoint_count)
    if n > 0:
        w = np.asarray(goals.waypoints, np.float64)[np.arange(len(k)), np.minimum(k, n - 1)]
        g = waypoints_world(goals.start, goals.start_yaw, w[:, None])[:, 0]
        return g, course_to(x, y, g), np.maximum(n - 1 - k, 0)
    if task.random_goals:
        g = goal_from_draws(x, y, yaw, u_bearing, u_distance, goals.start, task)
        return g, course_to(x, y, g), np.full(len(x), -1)
    g = np.stack([x + task.goal_distance, y], axis=1)
    return g, np.tile([1.0, 0.0], (len(x), 1)), np.zeros(len(x), np.int64)


def goal_distance(goals, x, y) -> np.ndarray:
    """Each robot's planar distance (N,) to its goal [m]."""
    g = np.asarray(goals.goal, np.float64)
    return np.hypot(g[:, 0] - np.asarray(x, np.float64), g[:, 1] - np.asarray(y, np.float64))


def off_line(goals, px, py) -> np.ndarray:
    """The signed offset [m] of (px, py) from the line through the goal along its course (left positive)."""
    c, g = np.asarray(goals.course, np.float64), np.asarray(goals.goal, np.float64)
    return (np.asarray(py, np.float64) - g[:, 1]) * c[:, 0] - (np.asarray(px, np.float64) - g[:, 0]) * c[:, 1]


def goal_switch(status, x, y, yaw, goals, task, u_bearing, u_distance) -> dict[str, np.ndarray]:
    """Robots still running (``status`` RUNNING) within ``goal_radius`` of a goal that is not their last: one more goal
    reached, the next one set (:func:`set_goal`) from where they stand (x, y) and their heading ``yaw`` now
    (``u_bearing``, ``u_distance``: the random goals' draws). Returns the new ``goal``, ``course``, ``left``,
    ``reached`` and ``switched`` (N,), the robots that got their next goal; ``goals`` is left as it was."""
    goal, course = np.asarray(goals.goal, np.float64), np.asarray(goals.course, np.float64)
    left, reached = np.asarray(goals.left), np.asarray(goals.reached)
    switched = (np.asarray(status) == RUNNING) & (left != 0) & (goal_distance(goals, x, y) < task.goal_radius)
    g, c, lf = set_goal(goals, task, reached + 1, x, y, yaw, u_bearing, u_distance)
    pick = switched[:, None]
    return {"goal": np.where(pick, g, goal), "course": np.where(pick, c, course), "left": np.where(switched, lf, left),
            "reached": np.where(switched, reached + 1, reached), "switched": switched}


# ----------------------------------------------------------------------------------------------------
# the ends
# ----------------------------------------------------------------------------------------------------


@dataclass
class EndInputs:
    """What the ends read, one row per robot: ``joint_q`` (N, 7 + 18) base position, quaternion (x, y, z, w) and
    joint angles; ``joint_qd`` (N, 6 + 18) base linear and angular velocity, joint velocities; ``episode_steps`` (N,)
    the episode's steps before this one; ``goals`` (:class:`Goals`' fields); ``ground`` (N,) the terrain under each
    base; ``task`` (``TaskConfig``'s fields)."""

    joint_q: np.ndarray
    joint_qd: np.ndarray
    episode_steps: np.ndarray
    goals: object
    ground: np.ndarray
    task: object


@dataclass(frozen=True)
class EndFrame:
    """Per-robot values the ends share: base position, roll / pitch / yaw (N, 3) of the normalised base quaternion,
    and ``finite``, the robots whose state is all finite."""

    px: np.ndarray
    py: np.ndarray
    pz: np.ndarray
    rpy: np.ndarray
    finite: np.ndarray


def end_frame(inputs) -> EndFrame:
    """The :class:`EndFrame` of ``inputs`` (:class:`EndInputs`' fields)."""
    jq, jqd = np.asarray(inputs.joint_q, np.float64), np.asarray(inputs.joint_qd, np.float64)
    finite = np.isfinite(jq).all(axis=1) & np.isfinite(jqd).all(axis=1)
    rpy = quat_to_rpy_np(np.where(finite[:, None], jq[:, 3:7], [0.0, 0.0, 0.0, 1.0]))
    return EndFrame(px=jq[:, 0], py=jq[:, 1], pz=jq[:, 2], rpy=rpy, finite=finite)


def nonfinite(inputs, frame: EndFrame) -> np.ndarray:
    """NaN/Inf in the state, or a runaway: base speed above ``max_base_speed``, a joint's above ``max_joint_speed``."""
    jqd = np.asarray(inputs.joint_qd, np.float64)
    with np.errstate(invalid="ignore"):
        runaway = (np.linalg.norm(jqd[:, :3], axis=1) > inputs.task.max_base_speed) | (
            np.abs(jqd[:, 6:]) > inputs.task.max_joint_speed
        ).any(axis=1)
    return ~frame.finite | runaway


def fell(inputs, frame: EndFrame) -> np.ndarray:
    """The torso less than ``min_height`` (x the robot's ``height_scale``) above the terrain under it, or |roll| or
    |pitch| above ``max_tilt``."""
    lim = inputs.task.max_tilt
    low = frame.pz - np.asarray(inputs.ground, np.float64) < inputs.task.min_height * inputs.task.height_scale
    return low | (np.abs(frame.rpy[:, 0]) > lim) | (np.abs(frame.rpy[:, 1]) > lim)


def left_course(inputs, frame: EndFrame) -> np.ndarray:
    """More than ``max_abs_y`` from the line through the goal along its course."""
    return np.abs(off_line(inputs.goals, frame.px, frame.py)) > inputs.task.max_abs_y


def success(inputs, frame: EndFrame) -> np.ndarray:
    """Within ``goal_radius`` of the episode's last goal (``left`` 0)."""
    near = goal_distance(inputs.goals, frame.px, frame.py) < inputs.task.goal_radius
    return near & (np.asarray(inputs.goals.left) == 0)


def timeout(inputs, frame: EndFrame) -> np.ndarray:
    """This step is the episode's ``max_episode_steps``-th."""
    return np.asarray(inputs.episode_steps) + 1 >= inputs.task.max_episode_steps


#: (name, status code, condition) of every end, in the order they are checked
ENDS = (("nonfinite", NONFINITE, nonfinite), ("fell", FELL, fell), ("off_course", OFF_COURSE, left_course),
        ("success", SUCCESS, success), ("timeout", TIMEOUT, timeout))  # fmt: skip
assert [STATUS_NAMES[code] for _, code, _ in ENDS] == [name for name, _, _ in ENDS]
assert sorted(code for _, code, _ in ENDS) == list(range(1, len(STATUS_NAMES))), "one end per status code"


def episode_status(inputs, names=None) -> tuple[np.ndarray, np.ndarray]:
    """Each robot's status (N,), the code of the first of the ends ``names`` (``TaskConfig.terminations``; None:
    all; ``nonfinite`` always) that holds, else ``RUNNING``; and its roll / pitch / yaw (N, 3), 0 for a blown-up one."""
    unknown = sorted(set(names or ()) - {name for name, _, _ in ENDS})
    if unknown:
        raise ValueError(f"task.terminations: no end {', '.join(unknown)}; choose from "
                         f"{', '.join(name for name, _, _ in ENDS)}")  # fmt: skip
    rows = [(code, func) for name, code, func in ENDS if names is None or name in names or code == NONFINITE]
    frame = end_frame(inputs)
    with np.errstate(invalid="ignore"):
        hits = [func(inputs, frame) for _, func in rows]
    status = np.select(hits, [code for code, _ in rows], RUNNING)
    return status, np.where((status == NONFINITE)[:, None], 0.0, frame.rpy)

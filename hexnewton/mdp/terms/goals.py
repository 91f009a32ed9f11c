"""Goals (ours; the MDP's command): each env's goal, stored per env in :class:`Goals`, which every term reads; where the
first goal of an episode and each next one lie (:func:`set_goal`); the switch to the next goal
(:func:`goal_switch_kernel`); their float64 twins, the episode's one NumPy definition of its goals in
``hexnewton/deploy/rules.py`` (which the robot runtime and C MuJoCo's closed loop share).

The paper's task has one goal, ``TaskConfig.goal_distance`` ahead of the start along +x, whose reaching ends the episode
(§2.4.4 (3)). The terms read, per env:

- ``goal``: the goal's position (x, y) in the world [m] (the observation's target, the distance and direction rewards,
  the success end);
- ``course``: the unit vector of the line from where the robot was when the goal was set to the goal, Table 1's
  start-to-goal direction D: the forward reward measures progress along it, the lateral reward and the off-course end
  the offset from that line, the curriculum and the episode log the distance walked along it;
- ``left``: the goals after this one in the episode: 0, the last (reaching it ends the episode, status ``success``);
  -1, no end (random goals);
- ``reached``: the goals reached in the episode so far;
- ``start``, ``start_yaw``: the episode's start pose, the frame of a waypoint course;
- ``waypoints`` (N, K) and ``waypoint_count`` K: each env's waypoint course in its start frame (K = 0: none).

Where a goal lies (:func:`set_goal`: at every reset, and for a robot that reached a goal that was not its last):

- a waypoint course (``TaskConfig.waypoints``, or :meth:`GoalBuffers.set_waypoints`, one course per env): waypoint k in
  turn, in the start frame (x along the start heading); the last is the episode's last goal;
- random goals (``TaskConfig.random_goals``, the navigate tasks): at a bearing uniform in +-``goal_bearing`` from the
  robot's heading now and a distance uniform in [``goal_distance_min``, ``goal_distance_max``]
  (:func:`goal_from_draws`); a goal beyond +-``goal_area`` of the start along x or y is mirrored back across the robot
  along that axis (its distance kept), then clamped to the square (only a robot outside it needs that), so that every
  goal lies on the terrain patch (``tasks.navigation_terrain``). None is the last: an episode ends on a fall or its
  time limit;
- otherwise the paper's: ``goal_distance`` ahead of the robot along +x, the course +x, the last goal.

Each control step, after the rewards (which pay the goal bonus on that step), :func:`goal_switch_kernel` gives a robot
still running (status 0) within ``goal_radius`` of a goal that is not its last the next one. The straight tasks never
switch: their one goal is the last, and reaching it ends the episode.
"""

from __future__ import annotations

import math

import numpy as np
import warp as wp

from hexnewton.deploy import rules
from hexnewton.mdp.status import RUNNING
from hexnewton.mdp.terms.structs import TaskParams
from hexnewton.kernels.cpg import quat_to_rpy
from hexnewton.kernels.reference import quat_to_rpy_np

#: the switch's random draws: ``wp.rand_init(task.seed + SWITCH_SEED, env + N * counter)``
SWITCH_SEED = 611953


@wp.struct
class Goals:
    """Each env's goal and what sets the next (module docstring), one row per env."""

    goal: wp.array[wp.vec2]  # the goal (x, y) in the world [m]
    course: wp.array[wp.vec2]  # unit vector from where the goal was set toward it
    left: wp.array[wp.int32]  # goals after this one: 0 the last, -1 no end
    reached: wp.array[wp.int32]  # goals reached in the episode so far
    start: wp.array[wp.vec2]  # the episode's start (x, y) [m]
    start_yaw: wp.array[wp.float32]  # the episode's start heading [rad]
    waypoints: wp.array2d[wp.vec2]  # (N, max(K, 1)) each env's waypoint course in its start frame [m]
    waypoint_count: int  # K (0: no waypoint course)


@wp.func
def goal_from_draws(x: float, y: float, yaw: float, u_bearing: float, u_distance: float, start: wp.vec2,
                    task: TaskParams) -> wp.vec2:  # fmt: skip
    """A random goal for a robot at (x, y) heading ``yaw``, from two uniform draws in [0, 1): bearing
    yaw + goal_bearing (2 u_bearing - 1), distance goal_distance_min + (max - min) u_distance, mirrored back into the
    square of +-goal_area around ``start`` along each axis it leaves by, then clamped to it."""
    bearing = yaw + task.goal_bearing * (2.0 * u_bearing - 1.0)
    r = task.goal_distance_min + (task.goal_distance_max - task.goal_distance_min) * u_distance
    ox = r * wp.cos(bearing)
    oy = r * wp.sin(bearing)
    a = task.goal_area
    if wp.abs(x + ox - start[0]) > a:
        ox = -ox
    if wp.abs(y + oy - start[1]) > a:
        oy = -oy
    return wp.vec2(wp.clamp(x + ox, start[0] - a, start[0] + a), wp.clamp(y + oy, start[1] - a, start[1] + a))


#: float64 :func:`goal_from_draws` for all envs: (N, 2), the shared rule's
goal_from_draws_np = rules.goal_from_draws


@wp.func
def course_to(x: float, y: float, goal: wp.vec2) -> wp.vec2:
    """The unit vector from (x, y) to ``goal`` (+x for a goal within 1 um)."""
    d = goal - wp.vec2(x, y)
    n = wp.length(d)
    out = wp.vec2(1.0, 0.0)
    if n > 1.0e-6:
        out = d / n
    return out


course_to_np = rules.course_to


@wp.func
def set_goal(goals: Goals, task: TaskParams, env: int, k: int, x: float, y: float, yaw: float, u_bearing: float,
             u_distance: float):  # fmt: skip
    """Env ``env``'s goal number ``k`` of the episode (0: the first) for the robot at (x, y) heading ``yaw``: the
    waypoint, the random goal (from the two draws) or the goal ahead (module docstring); its course and ``left``."""
    n = goals.waypoint_count
    if n > 0:
        w = goals.waypoints[env, wp.min(k, n - 1)]
        s = goals.start[env]
        c = wp.cos(goals.start_yaw[env])
        sn = wp.sin(goals.start_yaw[env])
        g = wp.vec2(s[0] + c * w[0] - sn * w[1], s[1] + sn * w[0] + c * w[1])
        goals.goal[env] = g
        goals.course[env] = course_to(x, y, g)
        goals.left[env] = wp.max(n - 1 - k, 0)
    elif task.random_goals:
        g = goal_from_draws(x, y, yaw, u_bearing, u_distance, goals.start[env], task)
        goals.goal[env] = g
        goals.course[env] = course_to(x, y, g)
        goals.left[env] = -1
    else:  # the paper's: goal_distance ahead along +x, the one goal
        goals.goal[env] = wp.vec2(x + task.goal_distance, y)
        goals.course[env] = wp.vec2(1.0, 0.0)
        goals.left[env] = 0


#: float64 :func:`set_goal` for all envs (``goals`` with :class:`Goals`' fields as NumPy arrays, ``k`` (N,)):
#: (goal (N, 2), course (N, 2), left (N,)), the shared rule's
set_goal_np = rules.set_goal


@wp.func
def goal_reached(goals: Goals, env: int, px: float, py: float, radius: float) -> bool:
    """The robot at (px, py) is within ``radius`` of its goal."""
    return wp.length(goals.goal[env] - wp.vec2(px, py)) < radius


@wp.func
def along_course(goals: Goals, env: int, dx: float, dy: float) -> float:
    """The displacement (dx, dy) along the goal's course (the straight tasks' course +x: exactly dx)."""
    c = goals.course[env]
    return dx * c[0] + dy * c[1]


@wp.func
def off_line(goals: Goals, env: int, px: float, py: float) -> float:
    """The signed offset [m] of (px, py) from the line through the goal along its course (left positive; the
    straight tasks': exactly y - y_goal, the goal's y the start's)."""
    c = goals.course[env]
    g = goals.goal[env]
    return (py - g[1]) * c[0] - (px - g[0]) * c[1]


off_line_np = rules.off_line


@wp.kernel
def goal_switch_kernel(status: wp.array[wp.int32], joint_q: wp.array2d[wp.float32], goals: Goals, task: TaskParams,
                       seed: int, counter: wp.array[wp.int32]):  # fmt: skip
    """A robot still running within ``goal_radius`` of a goal that is not its last: one more goal reached, and the next
    one set (:func:`set_goal`) from where it stands and its heading now."""
    e = wp.tid()
    if status[e] != RUNNING or goals.left[e] == 0:
        return
    px = joint_q[e, 0]
    py = joint_q[e, 1]
    if not goal_reached(goals, e, px, py, task.goal_radius):
        return
    k = goals.reached[e] + 1
    goals.reached[e] = k
    yaw = quat_to_rpy(wp.normalize(wp.quat(joint_q[e, 3], joint_q[e, 4], joint_q[e, 5], joint_q[e, 6])))[2]
    rng = wp.rand_init(seed, e + joint_q.shape[0] * counter[0])
    u_bearing = wp.randf(rng)
    u_distance = wp.randf(rng)
    set_goal(goals, task, e, k, px, py, yaw, u_bearing, u_distance)


def goal_switch_reference(status, joint_q, goals, task, u_bearing, u_distance) -> dict[str, np.ndarray]:
    """Float64 :func:`goal_switch_kernel` (``goals`` with :class:`Goals`' fields as NumPy arrays; ``u_bearing``,
    ``u_distance`` (N,) stand in for the kernel's draws): the shared rule (``hexnewton.deploy.rules.goal_switch``) at
    the envs' base positions and headings; the new ``goal``, ``course``, ``left`` and ``reached``, and ``switched``
    (N,), the envs that got their next goal."""
    q = np.asarray(joint_q, np.float64)
    return rules.goal_switch(status, q[:, 0], q[:, 1], quat_to_rpy_np(q[:, 3:7])[:, 2], goals, task, u_bearing,
                             u_distance)  # fmt: skip


def goals_from_host(device: str, goal, course, left, reached=None, start=None, start_yaw=None,
                    waypoints=None) -> Goals:  # fmt: skip
    """A :class:`Goals` instance on ``device`` from host arrays (the float64 twins read the same arrays): ``goal``,
    ``course``, ``start`` (N, 2), ``left``, ``reached``, ``start_yaw`` (N,), ``waypoints`` (N, K, 2) (None: zeros, no
    waypoints)."""
    n = len(goal)
    vec = lambda a: wp.array(np.ascontiguousarray(a, np.float32), dtype=wp.vec2, device=device)  # noqa: E731
    g = Goals()
    g.goal, g.course = vec(goal), vec(course)
    g.left = wp.array(np.asarray(left, np.int32), device=device)
    g.reached = wp.array(np.zeros(n, np.int32) if reached is None else np.asarray(reached, np.int32), device=device)
    g.start = vec(np.zeros((n, 2)) if start is None else start)
    g.start_yaw = wp.array(np.zeros(n, np.float32) if start_yaw is None else np.asarray(start_yaw, np.float32),
                           device=device)  # fmt: skip
    w = np.zeros((n, 0, 2)) if waypoints is None else np.asarray(waypoints, np.float64)
    g.waypoints = wp.array(np.ascontiguousarray(w if w.shape[1] else np.zeros((n, 1, 2)), np.float32), dtype=wp.vec2,
                           device=device)  # fmt: skip
    g.waypoint_count = w.shape[1]
    return g


class GoalBuffers:
    """The env's :class:`Goals` arrays on ``device`` for ``num_envs`` envs, sharing ``start`` (the env's episode
    starts), with the task's waypoint course (``TaskConfig.waypoints``) for every env."""

    def __init__(self, task, start: wp.array, num_envs: int, device: str):
        self.task, self.start, self.n, self.device = task, start, num_envs, device
        z = lambda dtype: wp.zeros(num_envs, dtype=dtype, device=device)  # noqa: E731
        self.goal, self.course = z(wp.vec2), z(wp.vec2)
        self.left, self.reached, self.start_yaw = z(wp.int32), z(wp.int32), z(wp.float32)
        self.set_waypoints(np.asarray(task.waypoints, np.float64).reshape(-1, 2))

    def set_waypoints(self, points) -> None:
        """The waypoint course in each env's start frame from the next reset on: (K, 2) for every env or (N, K, 2), one
        per env; K = 0: none (the task's goals). ValueError (one line) for another shape or a value not finite."""
        p = np.asarray(points, np.float64)
        if p.ndim == 2:
            p = np.broadcast_to(p, (self.n, *p.shape))
        if p.ndim != 3 or p.shape[0] != self.n or p.shape[2] != 2 or not np.isfinite(p).all():
            raise ValueError(f"waypoints: (K, 2) or ({self.n}, K, 2) finite x, y values [m], got shape {p.shape}")
        self.count = p.shape[1]
        rows = p if self.count else np.zeros((self.n, 1, 2))
        self.waypoints = wp.array(np.ascontiguousarray(rows, np.float32), dtype=wp.vec2, device=self.device)

    def struct(self) -> Goals:
        """The :class:`Goals` instance the kernels take."""
        g = Goals()
        g.goal, g.course, g.left, g.reached = self.goal, self.course, self.left, self.reached
        g.start, g.start_yaw, g.waypoints, g.waypoint_count = self.start, self.start_yaw, self.waypoints, self.count
        return g

    def arrays(self) -> list[wp.array]:
        """The arrays a step changes (the graph's trial run puts them back)."""
        return [self.goal, self.course, self.left, self.reached, self.start_yaw]

    def waypoints_world(self) -> np.ndarray:
        """Each env's waypoint course in the world (N, K, 2) [m], host copy (K = 0: (N, 0, 2))."""
        w = self.waypoints.numpy()[:, : self.count].astype(np.float64)
        s, a = self.start.numpy().astype(np.float64), self.start_yaw.numpy().astype(np.float64)
        c, sn = np.cos(a)[:, None], np.sin(a)[:, None]
        return np.stack([s[:, :1] + c * w[..., 0] - sn * w[..., 1], s[:, 1:] + sn * w[..., 0] + c * w[..., 1]], axis=-1)


def check_goals(task) -> None:
    """ValueError (one line) for goal settings of a ``TaskConfig`` that cannot work."""
    if task.random_goals:
        lo, hi = task.goal_distance_min, task.goal_distance_max
        if not (math.isfinite(lo) and math.isfinite(hi) and task.goal_radius < lo <= hi):
            raise ValueError(f"task.goal_distance_min/max must satisfy goal_radius ({task.goal_radius:g}) < MIN <= MAX, "
                             f"got {lo:g} {hi:g}")  # fmt: skip
        if not (math.isfinite(task.goal_area) and task.goal_area > 0):
            raise ValueError(f"task.goal_area must be positive, got {task.goal_area:g}")
        if not 0 <= task.goal_bearing <= math.pi:
            raise ValueError(f"task.goal_bearing must lie in [0, pi] rad, got {task.goal_bearing:g}")
    w = np.asarray(task.waypoints, np.float64)
    if w.size and (w.ndim != 2 or w.shape[1] != 2 or not np.isfinite(w).all()):
        raise ValueError(f"task.waypoints: ((x, y), ...) finite [m], got {task.waypoints!r}")

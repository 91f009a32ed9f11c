"""The trained hierarchy on a robot's computer: NumPy + onnxruntime, no Warp, Newton or torch.

A controller bundle (written by ``python -m hexnewton.apps.export``) is a folder with:
- ``policy.onnx``: the high level (observation normaliser included), one file, dynamic batch dimension;
- ``controller.json``: the observation layout, the parameter ranges, the CPG and mapping constants, the
  control and integration periods, the standing pose and joint limits;
- ``check.npz``: a short simulator rollout (observations, the simulator's joint targets and, for a controller with
  the levelling reflex, the body attitude at every substep) that ``python -m hexnewton.apps.deploy BUNDLE`` replays to
  show this runtime reproduces the simulator here.

Per control step (``control_dt``, 20 ms by default) :meth:`Controller.step` takes the robot's readings:
- joint positions and velocities (18 each, order R1..L3 x hip, knee, ankle);
- the base orientation quaternion (x, y, z, w);
- the goal relative to the robot in its heading frame (:func:`target_in_heading_frame`), or instead the robot's planar
  pose from odometry (x, y, yaw; ``pose``), from which the controller forms it toward the goal it keeps
  (:meth:`Controller.set_goal`, in the odometry frame: a navigate bundle is steered by moving its goal; or a course of
  waypoints from the start poses, :meth:`Controller.set_course`, walked goal by goal with :meth:`Controller.next_goal`,
  the simulator's own switch: the episode's rules are :mod:`hexnewton.deploy.rules`', shared with the simulator);
- the highest terrain within ±30 cm minus the ground under the robot (0 without a terrain sensor);
- for a policy that observes it (``gyro`` in its layout: ``ObsConfig.gyro``), the base angular velocity in the body
  frame, the IMU's gyro [rad/s].

A policy whose layout holds ``last_action`` (``ObsConfig.last_action``) also observes its own last actions: the
controller keeps those :meth:`Controller.set_actions` was given, clamped to [-1, 1], zeros after a reset, as the
simulator does from an episode's start.

It runs the policy's deterministic action (the mean of its Beta distribution, computed inside ``policy.onnx``;
older Gaussian bundles can also sample, ``stochastic=True``, or take the expected clipped action,
``expected=True``), scales its 15 actions to (omega, A1, A2, A3) (18 with the body posture P_h, P_p, P_r),
then integrates the two Hopf oscillators (Eq. 3, RK4) and applies the mapping function
(Eq. 4) every ``substep_dt`` (2.5 ms by default), exactly as the simulator does. It returns the 18 joint
position targets at the end of the step (all substeps' targets are in ``last_substep_targets``, for a servo
loop faster than the control rate).

A controller trained with the levelling reflex (``posture_reflex`` in controller.json) bends its knees against the
body's measured pitch and roll at every substep. On the robot, run the two rates apart: :meth:`Controller.set_actions`
once per control step (``act(observe(...))``), then :meth:`Controller.substep` with the IMU's latest quaternion every
``substep_dt``; :meth:`Controller.step` holds the control step's quaternion for all its substeps.
A controller with the stuck response (``stuck_lift`` in controller.json, ``CPGConfig.stuck_*``) lifts every knee higher
while the robot stops gaining ground: :meth:`Controller.set_actions` then takes the observed goal as well (``step``
passes it).
The maths is the float64 reference of the simulator's kernels (``hexnewton.kernels.reference``).
"""

from __future__ import annotations

import json
import math
import os

from types import SimpleNamespace

import numpy as np

from hexnewton.config import TaskConfig
from hexnewton.deploy import rules
from hexnewton.kernels.reference import (
    hopf_cpg_reference,
    initial_cpg_state,
    mapping_reference,
    quat_to_rpy_np,
    scale_actions_reference,
    stuck_response_reference,
)

FORMAT = "hexnewton-controller/1"
#: the torso's height above level ground when the paper's robot stands and walks (RobotConfig's) [m]: the base height
#: :meth:`Controller.target_from_pose` assumes where none is given and controller.json has no ``stand_height``
STAND_HEIGHT = 0.13


def target_in_heading_frame(base_pos, base_quat, goal, goal_ground_z=None) -> np.ndarray:
    """The goal relative to the robot, rotated by -yaw (x forward, y left); z is the goal's ground height minus
    the base height (the robot's own base height if ``goal_ground_z`` is None, i.e. level ground). (N, 3)."""
    pos, goal = np.atleast_2d(np.asarray(base_pos, np.float64)), np.atleast_2d(np.asarray(goal, np.float64))
    yaw = quat_to_rpy_np(np.atleast_2d(base_quat))[:, 2]
    dx, dy = goal[:, 0] - pos[:, 0], goal[:, 1] - pos[:, 1]
    c, s = np.cos(yaw), np.sin(yaw)
    gz = pos[:, 2] if goal_ground_z is None else np.broadcast_to(np.asarray(goal_ground_z, np.float64), dx.shape)
    return np.stack([c * dx + s * dy, -s * dx + c * dy, gz - pos[:, 2]], axis=1)


def spec_robot(spec: dict):
    """The robot a controller.json was exported for: its whole description (``robot_description``), or the paper's
    robot for a bundle without one."""
    from hexnewton.config import RobotConfig, dataclass_from_dict

    description = spec.get("robot_description")
    return dataclass_from_dict(RobotConfig, description) if description else RobotConfig()


def load_spec(bundle: str) -> dict:
    """The bundle's controller.json, checked for its format."""
    path = os.path.join(bundle, "controller.json")
    if not os.path.isfile(path):
        raise ValueError(f"{bundle} is not a controller bundle (no controller.json)")
    with open(path) as f:
        spec = json.load(f)
    if spec.get("format") != FORMAT:
        raise ValueError(f"{path}: format {spec.get('format')!r}, expected {FORMAT!r}")
    return spec


def expected_clipped_action(mean, std) -> np.ndarray:
    """E[clip(a, -1, 1)] for a ~ N(mean, std^2), per action, in float64: the action a sampled policy asks of the CPG
    on average (the clipped actions are low-pass filtered into its parameters). A deterministic action for policies
    whose learnt std is wide, where the mean action is not what the policy does on average (RESULTS.md)."""
    mean = np.asarray(mean, np.float64)
    std = np.maximum(np.asarray(std, np.float64), 1e-12)
    erf = np.vectorize(math.erf, otypes=[np.float64])
    a, b = (-1.0 - mean) / std, (1.0 - mean) / std
    cdf_a, cdf_b = 0.5 * (1.0 + erf(a / math.sqrt(2.0))), 0.5 * (1.0 + erf(b / math.sqrt(2.0)))
    pdf_a, pdf_b = np.exp(-0.5 * a * a) / math.sqrt(2 * math.pi), np.exp(-0.5 * b * b) / math.sqrt(2 * math.pi)
    return -cdf_a + (1.0 - cdf_b) + mean * (cdf_b - cdf_a) - std * (pdf_b - pdf_a)


class Controller:
    """The exported CPG_RL hierarchy for ``num_robots`` robots (batched like the simulator). ``bundle``: a bundle's
    folder, or a ``controller.json``-shaped dict without a policy (a fixed gait: the CPG runs ``initial_params``;
    :func:`hexnewton.analysis.sim2sim.fixed_cpg_spec`)."""

    def __init__(self, bundle: str | dict, num_robots: int = 1, providers: list[str] | None = None,
                 stochastic: bool = False, seed: int | None = None, expected: bool = False):
        if isinstance(bundle, dict):  # a controller.json's contents without a policy: the CPG at its initial_params
            self.spec = spec = bundle
            self.session = None
        else:
            import onnxruntime as ort

            self.spec = spec = load_spec(bundle)
            self.session = ort.InferenceSession(os.path.join(bundle, "policy.onnx"),
                                                providers=providers or ["CPUExecutionProvider"])  # fmt: skip
            self._input = self.session.get_inputs()[0].name
        self.n = int(num_robots)
        self.layout = {name: (a, b) for name, a, b in spec["obs_layout"]}
        self.num_obs = int(spec["num_obs"])
        self.lower, self.upper = np.asarray(spec["param_lower"]), np.asarray(spec["param_upper"])
        c = spec["cpg"]
        self.cpg = (c["alpha"], c["mu"], c["delta"], c["theta"], c["duty"], c["steepness"])
        self.dt = float(spec["substep_dt"])
        self.substeps = int(spec["substeps_per_control"])
        self.gain = 1.0 if c["param_tau"] == 0 else 1.0 - math.exp(-self.dt / c["param_tau"])
        if stochastic and expected:
            raise ValueError("choose sampled (stochastic) or expected actions, not both")
        if (stochastic or expected) and "action_std" not in spec:
            raise ValueError(f"{bundle}: sampled and expected actions need a Gaussian policy's action_std; this "
                             f"bundle's policy ({spec.get('distribution', 'gaussian')}) runs its deterministic action")
        self.stochastic, self.expected = stochastic, expected
        self.action_std = np.asarray(spec.get("action_std", np.zeros(spec["num_actions"])), np.float64)
        self.rng = np.random.default_rng(seed)
        self.stand, self.joint_lower, self.joint_upper = (np.asarray(spec[k]) for k in ("stand_pose", "joint_lower",
                                                                                         "joint_upper"))  # fmt: skip
        self.reflex = float(spec.get("posture_reflex", 0.0))  # levelling reflex gain (0: none; older bundles)
        self.tilt_max = float(spec.get("posture_tilt_max", 0.0))
        # the stuck response (CPGConfig.stuck_*; 0: none, older bundles)
        self.stuck = {k: spec.get(f"stuck_{k}", d) for k, d in (("lift", 0.0), ("window", 1), ("progress", 0.0),
                                                                 ("hold", 1))}  # fmt: skip
        self.last_actions = np.zeros((self.n, int(spec["num_actions"])))  # the observation's ``last_action``
        # the robot's (controller.json's "robot"): its standing height [m] and its heights' scale, by which the
        # observed heights (the target's z, the terrain reading) are divided, as in training (1: the paper robot's)
        self.stand_height = float(spec.get("stand_height", STAND_HEIGHT))
        self.height_scale = float(spec.get("height_scale", 1.0))
        self.goal = None  # (N, 3): the goal's ground point in the odometry frame (set_goal)
        self.goals = None  # rules.Goals: the episode's course (set_course), None for a goal of set_goal
        self.reset()

    def reset(self, mask=None) -> None:
        """Selected robots (all if None): oscillators at their locked start, parameters at the initial gait."""
        m = np.ones(self.n, bool) if mask is None else np.asarray(mask, bool)
        if not hasattr(self, "params"):
            self.params = np.zeros((self.n, len(self.spec["initial_params"])))
            self.target = np.zeros_like(self.params)
            self.state = np.zeros((self.n, 4))
            self.dy = np.zeros((self.n, 2))
            self.last_substep_targets = np.zeros((self.substeps, self.n, 18))
            self.stuck_history = np.zeros((self.n, int(self.stuck["window"])))
            self.stuck_count = np.zeros(self.n, np.int64)
            self.stuck_left = np.zeros(self.n, np.int64)
        self.params[m] = self.target[m] = self.spec["initial_params"]
        self.state[m] = initial_cpg_state(self.cpg[1], self.cpg[3])
        self.dy[m] = 0.0
        self.stuck_count[m] = self.stuck_left[m] = 0
        self.last_actions[m] = 0.0

    def set_goal(self, x, y, ground_z=0.0) -> None:
        """The goal to walk to, in the odometry frame [m] (the frame of the ``pose`` :meth:`step` takes): the same for
        every robot (numbers) or one per robot ((N,) arrays); ``ground_z``: the ground's height there (0: level with
        the frame's origin). It stays until the next call; a waypoint course is the caller's goals in turn."""
        g = np.stack(np.broadcast_arrays(*(np.asarray(v, np.float64) for v in (x, y, ground_z))), axis=-1)
        if g.size not in (3, 3 * self.n) or not np.isfinite(g).all():
            raise ValueError(f"set_goal: finite x, y, ground_z, numbers or one per robot ({self.n}), got shape "
                             f"{g.shape}")  # fmt: skip
        self.goal = np.broadcast_to(g.reshape(-1, 3), (self.n, 3)).copy()
        self.goals = None

    def set_course(self, pose, waypoints=None, ground_z=None, goal_distance=None, goal_radius=None) -> None:
        """The episode's goals as the simulator sets them (the shared rule, :mod:`hexnewton.deploy.rules`) for robots
        starting at their planar poses ``pose`` (N, 3) in the odometry frame (x, y [m], yaw [rad]): the ``waypoints``
        ((K, 2) for every robot or (N, K, 2)) of a course in each start frame (x along the start heading) in turn, the
        last ending the episode; or, none given, the one goal ``goal_distance`` ahead along the frame's +x (None: the
        bundle's ``goal_distance``). ``ground_z`` (N, K): the ground under each goal (None: 0); ``goal_radius``: within
        it a goal is reached (None: the bundle's, else ``TaskConfig``'s). Sets the first goal; :meth:`next_goal` gives
        the next ones, ``goals`` holds the course (its ``course`` line, ``left`` after this one, ``reached``)."""
        p = np.asarray(pose, np.float64).reshape(self.n, 3)
        w = None if waypoints is None else np.asarray(waypoints, np.float64)
        if w is not None and (w.ndim not in (2, 3) or w.shape[-1] != 2 or not np.isfinite(w).all()):
            raise ValueError(f"set_course: waypoints (K, 2) or ({self.n}, K, 2) finite x, y [m], got shape {w.shape}")
        self.goals = rules.start_goals(p[:, :2], p[:, 2], w)
        k = max(self.goals.waypoint_count, 1)
        self.goal_ground = np.zeros((self.n, k)) if ground_z is None else np.broadcast_to(
            np.asarray(ground_z, np.float64).reshape(-1, k), (self.n, k)).copy()  # fmt: skip
        if goal_distance is None:
            goal_distance = self.spec.get("goal_distance", TaskConfig.goal_distance)
        if goal_radius is None:
            goal_radius = self.spec.get("goal_radius", TaskConfig.goal_radius)
        self._rule = SimpleNamespace(random_goals=False, goal_distance=float(goal_distance),
                                     goal_radius=float(goal_radius))  # fmt: skip
        zero = np.zeros(self.n)
        self.goals.goal, self.goals.course, self.goals.left = rules.set_goal(
            self.goals, self._rule, np.zeros(self.n, np.int64), p[:, 0], p[:, 1], p[:, 2], zero, zero)
        self._course_goal()

    def _course_goal(self) -> None:
        """:attr:`goal` from the course's current goal and the ground under it."""
        k = np.minimum(self.goals.reached, self.goal_ground.shape[1] - 1)
        self.goal = np.c_[self.goals.goal, self.goal_ground[np.arange(self.n), k]]

    def next_goal(self, pose, running=None) -> np.ndarray:
        """Robots still walking (``running`` (N,) bool, default all) within ``goal_radius`` of a goal of the course
        (:meth:`set_course`) that is not their last get the next one, as the simulator's goal switch
        (:func:`hexnewton.deploy.rules.goal_switch`); ``pose`` (N, 3): their planar poses. Returns which switched."""
        if self.goals is None:
            raise ValueError("no course: call set_course(pose, waypoints) first")
        p = np.asarray(pose, np.float64).reshape(self.n, 3)
        run = np.ones(self.n, bool) if running is None else np.asarray(running, bool)
        zero = np.zeros(self.n)
        out = rules.goal_switch(np.where(run, rules.RUNNING, rules.NONFINITE), p[:, 0], p[:, 1], p[:, 2], self.goals,
                                self._rule, zero, zero)  # fmt: skip
        if out["switched"].any():
            self.goals.goal, self.goals.course, self.goals.left, self.goals.reached = (
                out[k] for k in ("goal", "course", "left", "reached"))
            self._course_goal()
        return out["switched"]

    def target_from_pose(self, pose, base_z=None) -> np.ndarray:
        """The observation's target (N, 3) toward the goal of :meth:`set_goal` from the robots' planar poses ``pose``
        (N, 3): odometry's x, y [m] and yaw [rad]; ``base_z`` (N,): the base's height in the odometry frame (None: the
        robot's standing height above level ground, controller.json's ``stand_height``, else :data:`STAND_HEIGHT`). As
        the simulator's: the goal in the heading frame
        (x forward, y left), z the goal's ground minus the base height."""
        if self.goal is None:
            raise ValueError("no goal: call set_goal(x, y) first, or pass the target to step()")
        p = np.asarray(pose, np.float64).reshape(self.n, 3)
        dx, dy = self.goal[:, 0] - p[:, 0], self.goal[:, 1] - p[:, 1]
        c, s = np.cos(p[:, 2]), np.sin(p[:, 2])
        z = np.full(self.n, self.stand_height) if base_z is None else np.broadcast_to(np.asarray(base_z, np.float64),
                                                                               (self.n,))  # fmt: skip
        return np.stack([c * dx + s * dy, -s * dx + c * dy, self.goal[:, 2] - z], axis=1)

    def goal_distance(self, pose) -> np.ndarray:
        """Each robot's planar distance to its goal [m] from its pose (N, 3) (x, y, yaw): within the bundle's
        ``goal_radius`` it has reached it."""
        if self.goal is None:
            raise ValueError("no goal: call set_goal(x, y) first")
        p = np.asarray(pose, np.float64).reshape(self.n, 3)
        return np.hypot(self.goal[:, 0] - p[:, 0], self.goal[:, 1] - p[:, 1])

    def observe(self, joint_pos, joint_vel, base_quat, target, max_height=0.0, gyro=None) -> np.ndarray:
        """The policy's observation (N, num_obs), laid out as in training (``controller.json``), from the readings in
        metres (the target's z and the terrain reading ``max_height`` divided by the robot's ``height_scale`` here, as
        the simulator's observation does). ``gyro`` (N, 3): the base angular velocity in the body frame [rad/s],
        required by a policy that observes it (``gyro`` in the layout)."""
        obs = np.zeros((self.n, self.num_obs))
        quat = np.asarray(base_quat, np.float64).reshape(self.n, 4)
        h = np.asarray(max_height, np.float64)
        h = h.reshape(self.n, 1) if h.size == self.n else np.full((self.n, 1), float(h))
        if gyro is None and "gyro" in self.layout:
            raise ValueError("this policy observes the base angular velocity: pass the IMU's gyro to observe()")
        parts = {
            "joint_pos": np.asarray(joint_pos, np.float64).reshape(self.n, 18),
            "joint_vel": np.asarray(joint_vel, np.float64).reshape(self.n, 18),
            "target": np.asarray(target, np.float64).reshape(self.n, 3) * [1.0, 1.0, 1.0 / self.height_scale],
            "omega": self.params[:, :1],
            "amplitudes": self.params[:, 1:15],
            "posture": self.params[:, 15:],
            "quat": quat * np.where(quat[:, 3:4] < 0, -1.0, 1.0),
            "max_height": h / self.height_scale,
            "last_action": self.last_actions,
        }
        if gyro is not None:
            parts["gyro"] = np.asarray(gyro, np.float64).reshape(self.n, 3)
        for name, (a, b) in self.layout.items():
            obs[:, a:b] = parts[name]
        return obs

    def act(self, obs: np.ndarray) -> np.ndarray:
        """The policy's actions (N, num_actions) for observations (N, num_obs): the mean, sampled around it, or the
        expected clipped action (:func:`expected_clipped_action`)."""
        if self.session is None:
            raise ValueError("this controller has no policy (built from a spec): it runs its initial_params")
        mean = self.session.run(None, {self._input: np.asarray(obs, np.float32)})[0]
        if self.expected:
            return expected_clipped_action(mean, self.action_std)
        if not self.stochastic:
            return mean
        return mean + self.action_std * self.rng.standard_normal(mean.shape)

    def set_actions(self, actions: np.ndarray, target=None) -> None:
        """The policy's actions (N, num_actions) in [-1, 1] as the parameters the CPG follows from now on. ``target``
        (N, 3): the goal relative to the robot that the policy observed, required by a controller with the stuck
        response (``stuck_lift`` in controller.json), which lifts the knees of a robot that stops gaining ground. The
        actions, clamped to [-1, 1] (0 where not finite), are the next observation's ``last_action``."""
        self.last_actions = np.clip(np.nan_to_num(np.asarray(actions, np.float64), nan=0.0, posinf=0.0, neginf=0.0),
                                    -1.0, 1.0).reshape(self.n, -1)  # fmt: skip
        self.target = scale_actions_reference(actions, self.lower, self.upper)
        if self.stuck["lift"] > 0:
            if target is None:
                raise ValueError("this controller has the stuck response: pass the observed target to set_actions()")
            t = np.asarray(target, np.float64).reshape(self.n, -1)
            self.stuck_history, self.stuck_count, self.stuck_left, self.target = stuck_response_reference(
                t, self.stuck_history, self.stuck_count, self.stuck_left, self.target, self.stuck["lift"],
                self.stuck["progress"], int(self.stuck["hold"]))

    def substep(self, base_quat=None) -> np.ndarray:
        """One CPG + mapping substep (``substep_dt``); returns the joint targets (N, 18). ``base_quat`` (N, 4) or
        (4,), x y z w: the body's attitude now, required by a controller with the levelling reflex."""
        rpy = None
        if self.reflex:
            if base_quat is None:
                raise ValueError("this controller has the levelling reflex: pass the body's quaternion to substep()")
            rpy = quat_to_rpy_np(np.broadcast_to(np.asarray(base_quat, np.float64), (self.n, 4)))
        self.params, self.state, self.dy = hopf_cpg_reference(self.target, self.params, self.state, self.gain,
                                                              *self.cpg, self.dt)  # fmt: skip
        return mapping_reference(self.state, self.dy, self.params, self.cpg[1], self.stand, self.joint_lower,
                                 self.joint_upper, rpy, self.reflex, self.tilt_max)  # fmt: skip

    def advance(self, actions: np.ndarray, base_quat=None, target=None) -> np.ndarray:
        """Scale actions to the CPG parameters, then run ``substeps_per_control`` substeps; returns the last
        substep's joint targets (N, 18). ``base_quat``: the attitude for the reflex, (N, 4) held over the step or
        (substeps, N, 4), one per substep; ``target``: the observed goal for the stuck response (``set_actions``)."""
        self.set_actions(actions, target)
        q = None if base_quat is None else np.asarray(base_quat, np.float64)
        for k in range(self.substeps):
            self.last_substep_targets[k] = self.substep(q[k] if q is not None and q.ndim == 3 else q)
        return self.last_substep_targets[-1].copy()

    def step(self, joint_pos, joint_vel, base_quat, target=None, max_height=0.0, gyro=None, pose=None,
             base_z=None) -> np.ndarray:  # fmt: skip
        """One control step: readings in, 18 joint position targets out (N, 18). ``target``: the goal in the heading
        frame (:func:`target_in_heading_frame`); or, none given, ``pose`` (N, 3), the odometry's x, y, yaw, toward
        the goal of :meth:`set_goal` (:meth:`target_from_pose`, with ``base_z``)."""
        if target is None:
            if pose is None:
                raise ValueError("step() needs the target, or the robot's pose (x, y, yaw) and a goal (set_goal)")
            target = self.target_from_pose(pose, base_z)
        obs = self.observe(joint_pos, joint_vel, base_quat, target, max_height, gyro)
        return self.advance(self.act(obs), base_quat, target)


def replay(bundle: str) -> dict:
    """Replay the bundle's recorded simulator rollout; returns the largest differences from the simulator."""
    load_spec(bundle)
    rec = np.load(os.path.join(bundle, "check.npz"))
    obs, sim_targets = rec["obs"], rec["targets"]  # (K, N, num_obs), (K, N, 18)
    quats = rec["substep_quat"] if "substep_quat" in rec else None  # (K, substeps, N, 4): the reflex's attitude
    ctrl = Controller(bundle, num_robots=obs.shape[1])
    lay = ctrl.layout
    sl = lambda o, name: o[:, lay[name][0]:lay[name][1]]  # noqa: E731
    err_obs = err_q = 0.0
    for k in range(len(obs)):
        o = obs[k]
        gyro = sl(o, "gyro") if "gyro" in lay else None
        # the readings in metres: the recorded observation's heights are divided by the robot's height_scale
        hs = ctrl.height_scale
        mine = ctrl.observe(sl(o, "joint_pos"), sl(o, "joint_vel"), sl(o, "quat"), sl(o, "target") * [1.0, 1.0, hs],
                            sl(o, "max_height") * hs, gyro)  # fmt: skip
        err_obs = max(err_obs, float(np.abs(mine - o).max()))  # the CPG parameters were integrated here
        q = ctrl.advance(ctrl.act(mine), None if quats is None else quats[k], sl(o, "target"))
        err_q = max(err_q, float(np.abs(q - sim_targets[k]).max()))
    return {"steps": len(obs), "robots": obs.shape[1], "max_obs_diff": err_obs, "max_target_diff_rad": err_q}

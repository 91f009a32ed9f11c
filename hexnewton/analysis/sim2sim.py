"""A controller bundle in a closed loop in C MuJoCo, through the robot runtime, on the paper's terrains: the robots'
sensors (:class:`HeightScanner`), the episode ends, the rounds of the evaluation's protocol (:class:`Rounds`,
:func:`measure`), a film and MuJoCo's viewer. The command line and its report: ``python -m hexnewton.apps.sim2sim``."""

from __future__ import annotations

import math
import time
from dataclasses import asdict, replace
from types import SimpleNamespace

import numpy as np

from hexnewton.analysis.metrics import round_metrics, summarize
from hexnewton.analysis.rollout import EVAL_TERRAIN_SEED, START_SEED_OFFSET
from hexnewton.config import CPGConfig, RobotConfig, SimConfig, TaskConfig, TerrainConfig, terrain_for_goal
from hexnewton.deploy import rules
from hexnewton.deploy.mjcf import Layout, build_model
from hexnewton.deploy.runtime import FORMAT, Controller, spec_robot
from hexnewton.deploy.rules import RUNNING, SUCCESS
from hexnewton.kernels.reference import quat_to_rpy_np
from hexnewton.robot.geometry import (
    amplitude_scale,
    footprint,
    height_scale,
    joint_signs,
    leg_bounds,
    length_scale,
    spawn_clearance,
    stand_height,
)

#: the terrain reading's window, as the training observation's (``mdp.terms.observations.H_HALF_EXTENT``; another
#: robot's x its ``length_scale``) [m]
H_HALF_EXTENT = 0.3


_PARK_Z = -50.0  # where a finished robot waits, far below every terrain [m]


class HeightScanner:
    """The robot's terrain sensor: vertical ray casts (MuJoCo ``mj_rayHfield`` on the model's scanner heightfield)
    through the centres of a 1 cm lattice of the odometry frame, kept in an elevation map as cells enter the window.
    The terrain is static, so a cell is cast once; the readings are those of the training's height grid query
    (``terrain.query``: the cell under a point, the highest cell overlapping a square), edge cells clamped alike."""

    def __init__(self, model, data, grid, half: float = H_HALF_EXTENT):
        import mujoco

        self.half = half  # the terrain reading's window [m]
        self._ray, self.m, self.d = mujoco.mj_rayHfield, model, data
        self.geom = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_GEOM, "scanner")
        self.x0, self.y0, self.res, self.nx, self.ny = grid.x0, grid.y0, grid.res, grid.nx, grid.ny
        self.top = float(np.max(grid.heights)) + 1.0  # rays start 1 m above the highest terrain
        self.map = np.full((grid.nx, grid.ny), np.nan)
        self.rays = 0

    def _index(self, coord, origin: float, n: int) -> np.ndarray:
        return np.clip(np.floor((np.asarray(coord, np.float64) - origin) / self.res), 0, n - 1).astype(np.int64)

    def _cast(self, i0: int, i1: int, j0: int, j1: int) -> np.ndarray:
        """The map over cells [i0, i1] x [j0, j1], casting the rays of the cells not seen yet."""
        block = self.map[i0:i1 + 1, j0:j1 + 1]
        down = np.array([0.0, 0.0, -1.0])
        for a, b in zip(*np.nonzero(np.isnan(block))):
            i, j = i0 + a, j0 + b
            pnt = np.array([self.x0 + (i + 0.5) * self.res, self.y0 + (j + 0.5) * self.res, self.top])
            dist = self._ray(self.m, self.d, self.geom, pnt, down)
            if dist < 0:
                raise RuntimeError(f"height scanner: the ray at ({pnt[0]:.3f}, {pnt[1]:.3f}) hit no terrain")
            block[a, b] = self.top - dist
            self.rays += 1
        return block

    def height(self, x: float, y: float) -> float:
        """The ground under (x, y)."""
        i, j = int(self._index(x, self.x0, self.nx)), int(self._index(y, self.y0, self.ny))
        return float(self._cast(i, i, j, j)[0, 0])

    def window_max(self, x: float, y: float, half: float | None = None) -> float:
        """The highest terrain over the square of half side ``half`` (None: the reading's) around (x, y)."""
        half = self.half if half is None else half
        i0, i1 = self._index([x - half, x + half], self.x0, self.nx)
        j0, j1 = self._index([y - half, y + half], self.y0, self.ny)
        return float(self._cast(int(i0), int(i1), int(j0), int(j1)).max())

    def reading(self, x: float, y: float) -> float:
        """The observation's terrain term: highest terrain within the window (+-30 cm for the paper's robot) minus the
        ground under the base [m]."""
        return self.window_max(x, y) - self.height(x, y)


def fixed_cpg_spec(cpg: CPGConfig | None = None, robot: RobotConfig | None = None, control_dt: float = 0.02,
                   substep_dt: float = 0.005) -> dict:
    """A controller.json-shaped spec of the fixed CPG (§3.3): no policy, the CPG at ``cpg.fixed_params()``, for
    :class:`deploy.Controller`, on ``robot`` (default the paper's; ``cpg`` None: the default CPG with the robot's
    amplitude scale). The default 5 ms substep is the shipped policy's physics, with which the committed Newton numbers
    of the fixed CPG were measured (studies/stable_gait)."""
    robot = robot or RobotConfig()
    cpg = cpg or replace(CPGConfig(), amplitude_scale=amplitude_scale(robot))
    lo, hi = cpg.param_ranges()
    lower, upper = leg_bounds(robot)
    return {
        "format": FORMAT, "action_mode": "cpg", "num_obs": 0, "num_actions": cpg.num_params, "obs_layout": [],
        "param_names": list(cpg.param_names), "posture_reflex": cpg.posture_reflex if cpg.posture else 0.0,
        "posture_tilt_max": cpg.tilt_max, "param_lower": list(lo), "param_upper": list(hi),
        "initial_params": list(cpg.fixed_params()),
        "cpg": {k: getattr(cpg, k) for k in ("alpha", "mu", "delta", "theta", "duty", "steepness", "param_tau")},
        "control_dt": control_dt, "substep_dt": substep_dt, "substeps_per_control": int(round(control_dt / substep_dt)),
        "stand_pose": list(robot.stand_pose), "joint_lower": list(lower), "joint_upper": list(upper),
        "goal_distance": TaskConfig.goal_distance, **robot_fields(robot),
    }  # fmt: skip


def robot_fields(robot: RobotConfig) -> dict:
    """What a controller.json says of its robot beyond the joints' bounds (:func:`hexnewton.apps.export`'s, here for a
    spec without a policy): its name, senses, standing height, scales and whole description (named robots other than
    the paper's and robot files only: a paper-robot spec stays as it was)."""
    if robot == RobotConfig():
        return {}
    return {"robot": robot.name, "joint_signs": list(joint_signs(robot)), "stand_height": stand_height(robot),
            "height_scale": height_scale(robot), "length_scale": length_scale(robot),
            "robot_description": asdict(robot)}  # fmt: skip


def start_poses(rounds: int, seed: int, task: TaskConfig | None = None, spread: float = SimConfig.spawn_y_spread,
                stand=RobotConfig.stand_pose, robot: RobotConfig | None = None) -> dict:
    """The rounds' starts as the evaluation draws them: lanes ``linspace(-spread, spread, rounds)`` at x = 0, then
    from seed ``seed`` (the start seed) a lateral offset, a yaw and joint noise per robot (``TaskConfig.reset_*``)."""
    task, robot = task or TaskConfig(), robot or RobotConfig()
    lane = np.linspace(-spread, spread, rounds) if rounds > 1 else np.zeros(1)
    rng = np.random.default_rng(seed)
    lower, upper = leg_bounds(robot)
    joints = np.clip(np.tile(stand, 6) + rng.uniform(-task.reset_joint_noise, task.reset_joint_noise, (rounds, 18)),
                     np.tile(lower, 6), np.tile(upper, 6))  # fmt: skip
    return {"lane": lane, "y": lane + rng.uniform(-task.reset_lateral, task.reset_lateral, rounds),
            "yaw": rng.uniform(-task.reset_yaw, task.reset_yaw, rounds), "joints": joints}


def episode_status(qpos: np.ndarray, qvel: np.ndarray, ground: np.ndarray, start_xy: np.ndarray, steps: int,
                   task: TaskConfig, goal: np.ndarray | None = None, course: np.ndarray | None = None,
                   last: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:  # fmt: skip
    """The episode ends (the shared rule, :func:`hexnewton.deploy.rules.episode_status`, which the env's Warp kernel
    is tested against: those of ``task.terminations``, the blow-up always) for MuJoCo robots (N, 25) / (N, 24) after
    ``steps`` control steps: (status codes (N,), roll / pitch / yaw (N, 3)). Quaternions are MuJoCo's (w, x, y, z).
    ``goal`` (N, 2), its ``course`` (N, 2) and ``last`` (N,), whether it is the episode's last: None, the paper's goal
    ``goal_distance`` ahead of ``start_xy`` along +x, the last."""
    n = len(qpos)
    if goal is None:
        goal, course = start_xy + [task.goal_distance, 0.0], np.tile([1.0, 0.0], (n, 1))
    last = np.ones(n, bool) if last is None else np.asarray(last, bool)
    joint_q = np.concatenate([qpos[:, :3], qpos[:, [4, 5, 6, 3]], qpos[:, 7:]], axis=1)  # the quaternion as x y z w
    goals = SimpleNamespace(goal=goal, course=course, left=np.where(last, 0, 1))
    inputs = rules.EndInputs(joint_q, qvel, np.full(n, steps - 1), goals, ground, task)
    return rules.episode_status(inputs, task.terminations)


def bundle_model(bundle: str, given, choice: str | None, prog: str = "sim2sim") -> tuple[RobotConfig, str | None]:
    """The robot bundle ``bundle`` was exported for (one line where ``given``, ``--robot``'s, is another) and the MJCF
    file C MuJoCo runs for it (:func:`model_file`; None: the model written from the bundle's description)."""
    from hexnewton.deploy.runtime import load_spec
    from hexnewton.robot.registry import check_robot

    robot = spec_robot(load_spec(bundle))
    check_robot(robot, given, bundle, init=False)
    return robot, model_file(robot, given, choice, prog)


def model_file(robot, given, choice: str | None, prog: str = "sim2sim") -> str | None:
    """The robot's own MJCF file that ``--mjcf`` (``choice``; None: the default) runs, or None for the model written
    from the bundle's description ``robot``; ``given``: ``--robot``'s description (its file the one to run). Where the
    default cannot run the file (not here, no longer that robot, not driven by position servos), one line says so and
    the generated model runs; ``--mjcf own`` then is one error line (``prog`` begins the lines)."""
    from hexnewton.deploy.robot_mjcf import RobotFile
    from hexnewton.errors import HexnewtonError

    path = (given.source if given is not None else "") or robot.source
    if choice == "generated" or (choice is None and not path.lower().endswith(".xml")):
        return None
    try:
        notes = RobotFile(path, robot).notes
    except HexnewtonError as exc:
        if choice == "own":
            raise ValueError(f"--mjcf own: {exc}") from None
        print(f"{prog}: {exc}: running the model written from the bundle's description (--robot FILE.xml gives the "
              "file)", flush=True)  # fmt: skip
        return None
    for line in [f"{prog}: robot {robot.name}: its own MJCF file {path}, as written (--mjcf generated: the model "
                 "written from its description)"] + notes:  # fmt: skip
        print(line, flush=True)
    return path


class Rounds:
    """``rounds`` robots of one controller on one terrain, each its first episode, closed loop in MuJoCo.

    ``controller``: a bundle folder (its policy acts) or a spec dict without a policy (:func:`fixed_cpg_spec`).
    ``terrain``: a terrain name (its config from ``TerrainConfig``, patch long enough for the goal), seed ``seed``;
    starts from ``seed + START_SEED_OFFSET`` (:func:`start_poses`). MuJoCo's timestep is the bundle's substep.
    ``robots``: the indices of the rounds this model runs (default all ``rounds``), each with the start it has among
    all of them, so that a split of the rounds over processes (:func:`measure`'s ``workers``) runs the same rounds.
    ``waypoints`` ((x, y), ...) in each start frame: the goals in turn instead of the one ahead, as in Newton's
    navigation evaluation (``analysis.navigation``: the navigate tasks' square patch, every start heading, no
    off-course end); the runtime keeps each robot's goal (``Controller.set_goal``) and forms the target from its
    pose. ``mjcf``: the robot's own MJCF file, run as written (:class:`hexnewton.deploy.robot_mjcf.RobotFile`)
    instead of the model written from the description; ``layout`` says where each robot is in either
    (:class:`hexnewton.deploy.mjcf.Layout`)."""

    def __init__(self, controller: str | dict, terrain: str, rounds: int, seed: int = EVAL_TERRAIN_SEED,
                 robot: RobotConfig | None = None, task: TaskConfig | None = None, robots=None, waypoints=None,
                 mjcf: str | None = None):
        import mujoco

        from hexnewton.terrain.heightmap import build_height_grid

        keep = np.arange(rounds) if robots is None else np.asarray(robots, dtype=np.int64)
        if keep.ndim != 1 or keep.size == 0 or keep.min() < 0 or keep.max() >= rounds:
            raise ValueError(f"robots must be indices of the {rounds} rounds, got {robots!r}")
        total, rounds = rounds, keep.size
        self.ctrl = Controller(controller, num_robots=rounds)
        self.spec, self.n = self.ctrl.spec, rounds
        # the controller's robot (controller.json's description) and its scales of the task's heights
        self.mj, self.robot, self.task = mujoco, robot or spec_robot(self.spec), task or TaskConfig()
        self.task = replace(self.task, height_scale=float(self.spec.get("height_scale", 1.0)),
                            length_scale=float(self.spec.get("length_scale", 1.0)))
        self.policy = self.ctrl.session is not None
        self.control_dt, self.substeps = float(self.spec["control_dt"]), int(self.spec["substeps_per_control"])
        self.task = replace(self.task, goal_distance=float(self.spec.get("goal_distance", self.task.goal_distance)))
        self.course_points = None if waypoints is None else np.asarray(waypoints, np.float64).reshape(-1, 2)
        self.grid = build_height_grid(self._terrain(terrain, seed))
        s = start_poses(total, seed + START_SEED_OFFSET, self.task, stand=self.spec["stand_pose"], robot=self.robot)
        s = {k: v[keep] for k, v in s.items()}
        places = [(0.0, y, 1.0, a) for y, a in zip(s["y"], s["yaw"])]
        self.mjcf = mjcf
        if mjcf:
            from hexnewton.deploy.robot_mjcf import RobotFile

            self.m, self.layout = RobotFile(mjcf, self.robot).model(self.grid, places, float(self.spec["substep_dt"]))
        else:
            self.m = build_model(self.robot, self.grid, places, float(self.spec["substep_dt"]))
            self.layout = Layout.generated(self.m, rounds)
        self.d = mujoco.MjData(self.m)
        mujoco.mj_forward(self.m, self.d)  # the terrain's poses, for the scanner's rays
        self.scan = HeightScanner(self.m, self.d, self.grid, H_HALF_EXTENT * self.task.length_scale)
        z = [self.scan.window_max(0.0, y, footprint(self.robot)) + spawn_clearance(self.robot) for y in s["lane"]]
        yaw = s["yaw"]
        self.layout.place(self.d, np.stack([np.zeros(rounds), s["y"], z, np.cos(yaw / 2), 0 * yaw, 0 * yaw,
                                            np.sin(yaw / 2)], axis=1), s["joints"])  # fmt: skip
        self.layout.set_targets(self.d, s["joints"])
        mujoco.mj_forward(self.m, self.d)
        self.start, self.start_yaw = np.stack([np.zeros(rounds), s["y"]], axis=1), s["yaw"]
        self._first_goals()
        self.alive = np.ones(rounds, bool)
        self.steps = 0
        self._show_only(0)

    def _terrain(self, terrain: str, seed: int) -> TerrainConfig:
        """The terrain's config: the paper's patch long enough for the goal, or for a waypoint course the navigate
        tasks' square (with every start heading and the navigation's ends)."""
        if self.course_points is None:
            return terrain_for_goal(TerrainConfig(name=terrain, seed=seed), self.task.goal_distance)
        from hexnewton.analysis.navigation import NAVIGATION_ENDS
        from hexnewton.tasks import navigation_terrain

        self.task = replace(self.task, reset_yaw=math.pi, terminations=NAVIGATION_ENDS)
        return replace(navigation_terrain(terrain), seed=seed)

    def _first_goals(self) -> None:
        """Each robot's goals (the one ahead, or the waypoints in its start frame) set in the runtime from its start
        (``Controller.set_course``, the env's rule), with the ground under each (``course`` (N, K, 2) in the world,
        ``course_z`` (N, K))."""
        pose = np.c_[self.start, self.start_yaw]
        if self.course_points is None:
            self.course = (self.start + [self.task.goal_distance, 0.0])[:, None]
        else:
            w = np.broadcast_to(self.course_points, (self.n, *self.course_points.shape))
            self.course = rules.waypoints_world(self.start, self.start_yaw, w)
        self.course_z = np.array([[self.scan.height(x, y) for x, y in row] for row in self.course])
        self.ctrl.set_course(pose, self.course_points, self.course_z, self.task.goal_distance, self.task.goal_radius)

    @property
    def goal(self) -> np.ndarray:
        """Each robot's goal now (N, 2) in the world."""
        return self.ctrl.goals.goal

    @property
    def goal_z(self) -> np.ndarray:
        """The ground under each robot's goal (N,)."""
        return self.ctrl.goal[:, 2]

    @property
    def line(self) -> np.ndarray:
        """The unit vector (N, 2) of each goal's course line (+x for the one ahead)."""
        return self.ctrl.goals.course

    @property
    def final(self) -> np.ndarray:
        """Whether each robot's goal is its last (N,)."""
        return self.ctrl.goals.left == 0

    @property
    def leg(self) -> np.ndarray:
        """The goal each robot walks to now (the goals reached before it) (N,)."""
        return self.ctrl.goals.reached

    def next_goals(self, status: np.ndarray) -> None:
        """Robots still walking within ``goal_radius`` of a goal that is not their last: the next waypoint, by the
        env's goal switch (``Controller.next_goal``, the shared rule)."""
        q = self.layout.qpos(self.d)
        pose = np.c_[q[:, :2], quat_to_rpy_np(q[:, [4, 5, 6, 3]])[:, 2]]
        self.ctrl.next_goal(pose, self.alive & (status == RUNNING))

    def _show_only(self, k: int) -> None:
        """The geoms of every robot but ``k`` in group 3 (hidden by the viewer's and renderer's defaults)."""
        robot = {int(t): i for i, t in enumerate(self.layout.torsos)}
        for g, b in enumerate(self.m.geom_bodyid):
            i = robot.get(int(self.m.body_rootid[b]), k)
            if i != k:
                self.m.geom_group[g] = 3

    def sensors(self) -> dict:
        """The robots' current readings: joint encoders and velocities (N, 18, hexnewton's sense), IMU quaternion
        (N, 4), x y z w, and gyro (N, 3), the torso's angular velocity in its own frame [rad/s]."""
        return self.layout.readings(self.d)

    def observation_inputs(self, r: dict) -> dict:
        """The rest of the observation: the goal in the heading frame (odometry: the free joint's position) and the
        terrain reading, for the robots still walking (0 for the others)."""
        pos = self.layout.qpos(self.d)[:, :3]
        pose = np.c_[pos[:, :2], quat_to_rpy_np(np.atleast_2d(r["quat"]))[:, 2]]  # odometry's planar pose
        target = self.ctrl.target_from_pose(pose, pos[:, 2])
        height = np.zeros(self.n)
        for k in np.flatnonzero(self.alive):
            height[k] = self.scan.reading(pos[k, 0], pos[k, 1])
        return {"target": target, "max_height": height}

    def control_step(self) -> None:
        """One control step: ``substeps`` MuJoCo steps, each split around its joint targets (``mj_step1``: sensors of
        the current state; :meth:`targets` from them; ``mj_step2``: integrate)."""
        for k in range(self.substeps):
            self.mj.mj_step1(self.m, self.d)
            self.layout.set_targets(self.d, self.targets(k, self.sensors()))
            self.mj.mj_step2(self.m, self.d)
        self.steps += 1

    def targets(self, k: int, r: dict) -> np.ndarray:
        """The joint targets (N, 18) of substep ``k`` of the control step from the readings ``r``: the runtime's policy
        (if any) on the first substep's, then its CPG substep. A subclass may get them elsewhere (over ROS 2:
        :class:`hexnewton.analysis.ros_robot.RosRounds`)."""
        if k == 0 and self.policy:
            o = self.observation_inputs(r)
            obs = self.ctrl.observe(r["joint_pos"], r["joint_vel"], r["quat"], o["target"], o["max_height"], r["gyro"])
            self.ctrl.set_actions(self.ctrl.act(obs), o["target"])
        return self.ctrl.substep(r["quat"])

    def status(self) -> tuple[np.ndarray, np.ndarray]:
        """Episode status codes (N,) and roll / pitch / yaw (N, 3) after the last control step."""
        q, v = self.layout.qpos(self.d), self.layout.qvel(self.d)
        ground = np.array([self.scan.height(x, y) if a else 0.0 for (x, y), a in zip(q[:, :2], self.alive)])
        return episode_status(q, v, ground, self.start, self.steps, self.task, self.goal, self.line, self.final)

    def park(self, mask: np.ndarray) -> None:
        """Finished robots wait far below the terrain, 1 m apart and at rest (re-parked every step: they fall
        freely), where MuJoCo's collision detection skips them."""
        q, v = self.layout.blocks(self.d)
        k = np.flatnonzero(mask)
        q[k, 0], q[k, 1], q[k, 2] = 1.0 * k, 0.0, _PARK_Z
        v[k] = 0.0

    def run(self, max_steps: int | None = None, on_step=None) -> dict:
        """Run until every robot's first episode ended (or ``max_steps``); returns the per-step arrays the metrics
        take: ``pos`` (T, N, 2) relative to the start, ``rpy`` (T, N, 3), ``done`` (T, N), ``status`` (T, N), and
        ``legs`` (N,) the goals reached before the last one walked to. ``on_step(self)`` after every control step (a
        video frame, the viewer)."""
        max_steps = max_steps or self.task.max_episode_steps
        pos, rpy, done, status = [], [], [], []
        while self.alive.any() and self.steps < max_steps:
            self.control_step()
            st, a = self.status()
            st = np.where(self.alive, st, RUNNING)
            self.next_goals(st)
            p = self.layout.qpos(self.d)[:, :2] - self.start
            pos.append(np.where(self.alive[:, None], p, np.nan))
            rpy.append(np.where(self.alive[:, None], a, np.nan))
            done.append(st != RUNNING)
            status.append(st)
            self.alive &= st == RUNNING
            self.park(~self.alive)
            if on_step is not None:
                on_step(self)
        return {"pos": np.stack(pos), "rpy": np.stack(rpy), "done": np.stack(done), "status": np.stack(status),
                "legs": self.leg.copy(), "start_yaw": np.asarray(self.start_yaw, np.float64)}


def run_part(controller: str | dict, terrain: str, rounds: int, seed: int, max_steps: int | None,
             robots=None, on_step=None, waypoints=None, mjcf: str | None = None) -> dict:
    """The rounds ``robots`` (indices of ``rounds``; None: all) run to the end (toward ``waypoints``, if given; on the
    robot's own MJCF file ``mjcf``, if given): :meth:`Rounds.run`'s arrays plus ``control_dt``, ``steps`` and the
    scanner's ``rays``. A top-level function, so that worker processes can run it."""
    r = Rounds(controller, terrain, rounds, seed, robots=robots, waypoints=waypoints, mjcf=mjcf)
    ep = r.run(max_steps, on_step)
    ep.update(control_dt=r.control_dt, steps=r.steps, rays=r.scan.rays)
    return ep


def join_parts(parts: list[dict]) -> dict:
    """:func:`run_part` results of consecutive robot ranges as one: the robots side by side in the order given, each
    part's steps padded to the longest as its ended robots read (position and angles NaN, not done, RUNNING)."""
    t = max(p["pos"].shape[0] for p in parts)
    fill = {"pos": np.nan, "rpy": np.nan, "done": False, "status": RUNNING}
    out = {}
    for k, v in fill.items():
        padded = [np.concatenate([p[k], np.full((t - p[k].shape[0],) + p[k].shape[1:], v, p[k].dtype)]) for p in parts]
        out[k] = np.concatenate(padded, axis=1)
    out.update(control_dt=parts[0]["control_dt"], steps=t, rays=sum(p["rays"] for p in parts))
    out.update({k: np.concatenate([p[k] for p in parts]) for k in ("legs", "start_yaw") if all(k in p for p in parts)})
    return out


def waypoint_summary(ep: dict, count: int) -> dict:
    """The waypoint rounds as Newton's navigation evaluation scores its square (``analysis.navigation``): the share
    that completed the course (its last goal reached), the time, the goals reached, the path, the falls."""
    from hexnewton.analysis.navigation import summarize_square

    status = ep["status"]
    ended = status.any(axis=0)
    last = np.where(ended, np.argmax(status != RUNNING, axis=0), len(status) - 1)
    end = np.where(ended, status[last, np.arange(status.shape[1])], RUNNING)
    c, s = np.cos(ep["start_yaw"]), np.sin(ep["start_yaw"])
    d = ep["pos"]
    pos = np.stack([c * d[..., 0] + s * d[..., 1], -s * d[..., 0] + c * d[..., 1]], axis=-1)  # the start frame
    goals = np.where(end == SUCCESS, count, ep["legs"])
    return summarize_square({"pos": pos, "end": end, "steps": last + 1, "goals": goals, "dt": ep["control_dt"]})


def measure(controller: str | dict, terrain: str, rounds: int, seed: int = EVAL_TERRAIN_SEED,
            max_steps: int | None = None, on_step=None, workers: int = 1, waypoints=None,
            mjcf: str | None = None) -> dict:
    """:class:`Rounds` run to the end and summarised with :mod:`hexnewton.analysis.metrics` (``summarize``'s dict plus
    the wall time, the control steps and the scanner's ray count; with ``waypoints`` also ``waypoints``, the course's
    :func:`waypoint_summary`); ``mjcf``: the robot's own MJCF file instead of the generated model.
    ``workers`` > 1 splits the rounds into that many
    consecutive ranges, each a MuJoCo model of its own in a process of its own (no ``on_step`` then): the robots of
    one model never touch each other, so each round starts and walks as in one model of all of them, to rounding (a
    smaller model and policy batch round differently, and over thousands of steps on blocks that can change how a
    round ends: compare results at the same ``workers``)."""
    t0 = time.perf_counter()
    workers = max(1, min(int(workers), rounds))
    if workers > 1 and on_step is not None:
        raise ValueError("a film or viewer (on_step) shows one model: run it with workers=1")
    if workers == 1:
        ep = run_part(controller, terrain, rounds, seed, max_steps, None, on_step, waypoints, mjcf)
    else:
        import multiprocessing
        from concurrent.futures import ProcessPoolExecutor

        ranges = np.array_split(np.arange(rounds), workers)
        with ProcessPoolExecutor(workers, mp_context=multiprocessing.get_context("spawn")) as pool:
            parts = list(pool.map(run_part, *zip(*[(controller, terrain, rounds, seed, max_steps, r, None, waypoints,
                                                    mjcf) for r in ranges])))  # fmt: skip
        ep = join_parts(parts)
    out = summarize(round_metrics(ep["pos"], ep["rpy"], ep["done"], ep["status"], ep["control_dt"]), ep["rpy"])
    out.update(control_steps=ep["steps"], wall_s=round(time.perf_counter() - t0, 1), rays=ep["rays"])
    if waypoints is not None:
        out["waypoints"] = waypoint_summary(ep, len(waypoints))
    return out


class Film:
    """``on_step`` callback writing robot 0's round to an mp4 (MuJoCo's offscreen renderer, a camera tracking the
    torso, every other control step; imageio-ffmpeg encodes). ``close()`` finishes the file."""

    def __init__(self, path: str, width: int = 640, height: int = 480, every: int = 2):
        import imageio_ffmpeg

        self.path, self.size, self.every, self.frames = path, (width, height), every, 0
        self.renderer = self.camera = None
        self.writer = imageio_ffmpeg.write_frames(path, self.size, fps=1.0 / (0.02 * every), macro_block_size=1)
        self.writer.send(None)

    def __call__(self, r: Rounds) -> None:
        mj = r.mj
        if self.renderer is None:
            try:
                self.renderer = mj.Renderer(r.m, self.size[1], self.size[0])
            except Exception as exc:  # no OpenGL context (MUJOCO_GL=egl or osmesa needs Mesa's libraries)
                raise ValueError(f"--video: MuJoCo cannot render here ({exc}); try MUJOCO_GL=egl or osmesa") from exc
            self.camera = mj.MjvCamera()
            self.camera.type = mj.mjtCamera.mjCAMERA_TRACKING
            self.camera.trackbodyid = int(r.layout.torsos[0])
            self.camera.distance, self.camera.elevation, self.camera.azimuth = 1.0, -25.0, 135.0
        if (r.alive[0] or self.frames == 0) and r.steps % self.every == 0:
            self.renderer.update_scene(r.d, self.camera)
            self.writer.send(np.ascontiguousarray(self.renderer.render()))
            self.frames += 1

    def close(self) -> None:
        self.writer.close()
        if self.renderer is not None:
            self.renderer.close()


class Viewer:
    """``on_step`` callback showing the rounds in MuJoCo's interactive viewer (robot 0; the others are in the hidden
    geom group 3) at real time."""

    def __init__(self):
        self.handle, self.t0 = None, None

    def __call__(self, r: Rounds) -> None:
        if self.handle is None:
            import mujoco.viewer

            self.handle = mujoco.viewer.launch_passive(r.m, r.d)
            self.t0 = time.perf_counter()
        if not self.handle.is_running():
            raise KeyboardInterrupt
        self.handle.sync()
        time.sleep(max(0.0, self.t0 + r.steps * r.control_dt - time.perf_counter()))

    def close(self) -> None:
        if self.handle is not None:
            self.handle.close()

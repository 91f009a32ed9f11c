"""Named tasks: each one environment config (:class:`~hexnewton.config.HexConfig`) and one learner config
(:class:`~hexnewton.learning.agent.AgentConfig`), registered by name and with Gymnasium.

    python train.py --list_tasks
    python train.py --task complex                       # the shipped complex policy's recipe
    python train.py --task complex --env.reward.w_tilt 20 --agent.algorithm.learning_rate 5e-4

    import gymnasium as gym
    import hexnewton.tasks                                 # registers the tasks, as isaaclab_tasks and mjlab.tasks do
    env = gym.make("Hexnewton-Complex-v0", num_envs=1024, device="cuda")
    env = gym.make("Hexnewton-Rugged-v0", num_envs=1024, device="cuda", robot="mx_phoenix")   # another robot

A task is data: :func:`task` returns a fresh copy, ``train.py`` applies the command line's overrides to it, and every
checkpoint records the task's name and the full configs it trained with, so ``play.py``, ``evaluate`` and ``export``
need nothing but the checkpoint. A task's robot is the paper's; ``--robot NAME|FILE`` (``train.py``, the baselines)
and ``gym.make(..., robot=NAME|FILE|RobotConfig)`` put another one into it with its scales
(:func:`hexnewton.robot.registry.with_robot`, docs/robots.md). Adding a task is one :func:`register` call below.

The recipe of the paper's terrains (ours; docs/training.md says what each part does): a terrain curriculum (10 lanes of
rising difficulty, robots start on the first 3), a knee-lift floor (A2 in 0.9-1.3 rad: a high-stepping gait from the
start), domain randomisation, the 20 ms physics frame, a 0.1 s filter on the CPG parameters and the stability shaping
(:data:`STABLE_SHAPING`). The complex course adds the body posture and the stable-gait curriculum
(:data:`STABLE_STAGES`, 300 iterations: 172 s from process start to the exported policy on one H100,
studies/time_to_skill). ``paper`` is Table 1's reward and Table 2's PPO on the complex course, with
none of that. The recipes observe :data:`RECIPE_OBSERVATION`; ``complex-asymmetric`` is the complex recipe with
:data:`ASYMMETRIC_OBSERVATION` (docs/training.md, "Observations").

``navigate-flat`` and ``navigate-rugged`` (ours) walk to goals in every direction (:data:`NAVIGATE_GOALS`) on a square
patch around the starts (:func:`navigation_terrain`) with a signed hip amplitude (:data:`SIGNED_HIP`), within a
10-minute budget on one H200 (:data:`NAVIGATE_ITERATIONS`, :data:`NAVIGATE_MINUTES`; docs/training.md, "Walking to any
goal").
"""

from __future__ import annotations

import copy
import math
from dataclasses import dataclass, field, replace

from hexnewton.config import (
    ACTION_MODES,
    CPGConfig,
    HexConfig,
    ObsConfig,
    RandomizationConfig,
    RewardConfig,
    SimConfig,
    TaskConfig,
    TerrainConfig,
    apply_overrides,
    terrain_for_goal,
    without_lanes,
)
from hexnewton.learning.agent import AgentConfig, paper_agent
from hexnewton.robot.registry import with_robot

#: The stability shaping of the variant chosen on validation rounds among six (studies/stable_gait): fewest
#: falls, lowest rugged pitch and roll variance; 2 / 0.02 / 0.05 (with a 0.03 s filter) fell 18x as often on rugged
#: ground, 20 / 0.2 / 0.1 20x.
STABLE_SHAPING = dict(w_tilt=5.0, w_ang_vel=0.05, w_action_rate=0.1)
#: contact randomisation, off in the recipe: feet of 10-14 mm radius (nominal 12) and contact time constants of 10-30
#: ms (nominal 20), so that training meets feet that fit between the 2 cm blocks and sink deeper into them
#: (``--env.randomization.foot_radius 0.010 0.014 --env.randomization.contact_timeconst 0.010 0.030``; what it does
#: in Newton and in C MuJoCo: studies/sim2sim/contact_randomisation)
FOOT_CONTACT_RANGES = dict(foot_radius=(0.010, 0.014), contact_timeconst=(0.010, 0.030))

#: The stable-gait curriculum of the complex recipe (studies/stable_gait; studies/time_to_skill): (first
#: iteration, changes) of the reflex gain (``posture_reflex``) and the reward weights, applied from that iteration on;
#: the run ends after 300 iterations (29.5 M env-steps at 4096 envs).
STABLE_STAGES = ((100, dict(posture_reflex=2.0, w_tilt=15.0, w_ang_vel=0.1)), (200, dict(w_tilt=40.0, w_ang_vel=0.3)))
STABLE_ITERATIONS = 300
#: The same curriculum over 1062 iterations, for the 5 m courses (``complex-5m``, ``stairs-8cm``): their episodes are
#: longer, so the terrain curriculum needs more iterations per level (not measured with the 300-iteration schedule).
#: The stable-gait curriculum's reward part (:data:`STABLE_STAGES` without the CPG's levelling reflex), at the same
#: iterations, so at the same env-steps at 4096 envs (9.8 M and 19.7 M): pure DRL's stages
#: (``complex-joint-staged``), which have no CPG to level
STABLE_REWARD_STAGES = tuple((start, {k: v for k, v in changes.items() if k != "posture_reflex"})
                             for start, changes in STABLE_STAGES)
LONG_STABLE_STAGES = ((382, dict(posture_reflex=2.0, w_tilt=15.0, w_ang_vel=0.1)), (744, dict(w_tilt=40.0, w_ang_vel=0.3)))
LONG_STABLE_ITERATIONS = 1062
#: ``complex-margin``'s curriculum lanes: the complex recipe's 10 lanes with the last 3 past the course (lane 6 is the
#: course), up to 9 cm rises on 18 cm treads and 9 cm blocks (lanes 7-9: 7 / 8 / 9 cm rises and blocks on 23 / 20 /
#: 18 cm treads), within the robot's and the CPG's reach (studies/capability/ceiling/report.md). The lane count, so the
#: robots' climb to the top lane, is the complex recipe's.
MARGIN_LANES = dict(levels_past=3, hardest_step_rise=0.09, hardest_step_depth=0.18, hardest_block_height_max=0.09)
#: ``complex-margin``'s randomisation, wider than the recipe's (friction 0.4-1.2, payload -0.2-0.6 kg, gains and effort
#: x0.8-1.2 apart): friction 0.25-1.2, payload -0.2-1.2 kg (torso 1.6 kg) and a motor strength of 0.45-1.2 on gains
#: and effort together, their own spread narrowed to x0.9-1.1 so that the weakest motors keep 0.4 of the nominal gains
#: and torque (the evaluation's motor_strength 0.5 lies inside the range, not at its edge).
MARGIN_RANDOMIZATION = dict(friction=(0.25, 1.2), payload=(-0.2, 1.2), motor_strength=(0.45, 1.2),
                            kp_scale=(0.9, 1.1), effort_scale=(0.9, 1.1))


#: The asymmetric actor-critic's observation: the actor (the policy group) gains the IMU's gyro and its last actions,
#: the critic its own group of what the robot does not sense (hexnewton/mdp/terms/critic.py)
ASYMMETRIC_OBSERVATION = ObsConfig(gyro=True, last_action=True, critic=True)
#: The switch of what every terrain recipe observes (``_recipe``: rugged, stepped, the complex tasks, complex-joint
#: and complex-joint-staged, and the skrl baselines, which train on those tasks' envs and read the policy group only):
#: ``ObsConfig()``, the paper's observation for actor and critic; ``ASYMMETRIC_OBSERVATION`` gives all of them the
#: gyro, the last actions and the critic's group (the golden rollout of the complex and complex-joint cases then
#: changes: tests/mdp/test_golden.py says how to regenerate it).
RECIPE_OBSERVATION = ObsConfig()
#: §3.1's three courses, the ones the terrain recipes' result is chosen on
PAPER_COURSES = ("rugged", "stepped", "complex")
#: The navigate tasks' goals (ours, ``TaskConfig``; mdp/terms/goals.py): each at a bearing anywhere round the robot
#: (-180..180 deg from its heading when set), 1-4 m away, inside +-4 m of the start; reaching one (0.5 m) sets the
#: next; an episode ends on a fall or its time limit (the terrain's, NAVIGATE_EPISODE_STEPS); every start heading
#: (reset_yaw pi)
NAVIGATE_GOALS = dict(random_goals=True, goal_bearing=math.pi, goal_distance_min=1.0, goal_distance_max=4.0,
                      goal_area=4.0, reset_yaw=math.pi, terminations=("nonfinite", "fell", "success", "timeout"),
                      seed=1)  # fmt: skip
#: ours: a signed hip amplitude per side (CPGConfig.a1_range; the paper's tasks (0, 0.5)): a side's stride reverses,
#: so the robot turns on the spot (A1_R = -A1_L); ``--env.cpg.a1_range 0 0.5`` switches it off
SIGNED_HIP = (-0.5, 0.5)
#: the patch's margin beyond the goals' square [m]: room to overshoot a goal's 0.5 m circle and to turn
NAVIGATION_MARGIN = 1.0
#: The navigate tasks' budget on one H200 (<= 10 min from process start; docs/training.md, "Walking to any goal"):
#: at 4096 envs x 24 steps, up to NAVIGATE_ITERATIONS iterations, stopped after NAVIGATE_MINUTES of training (flat,
#: rugged), leaving ~1 min of start-up and ~1.5 min for validation and export
NAVIGATE_ITERATIONS = 1500
NAVIGATE_MINUTES = {"flat": 7.0, "rugged": 7.0}
#: the episode's time limit per terrain [control steps]: 20 s on flat ground (3.2 goals reached per episode); 40 s on
#: the blocks, where the robot walks ~0.1 m/s toward a goal and a 20 s episode reached 0.31 goals: one goal, rarely
#: the turn to the next
NAVIGATE_EPISODE_STEPS = {"flat": 1000, "rugged": 2000}
#: their validation: 256 rounds per candidate, 32 at each of the evaluation's 8 bearings, 2 m, 30 s each
NAVIGATE_VALIDATION = dict(validation_rounds=256, validation_candidates=3, validation_steps=1500)


@dataclass
class Task:
    """One named task: what the robot faces (``env``), how it learns (``agent``) and what it commands."""

    name: str
    description: str
    env: HexConfig = field(default_factory=HexConfig)
    agent: AgentConfig = field(default_factory=AgentConfig)
    #: ``cpg``: the policy sets the CPG's parameters (CPG_RL); ``joint``: the 18 joint targets (pure DRL)
    action_mode: str = "cpg"

    @property
    def gym_id(self) -> str:
        """The Gymnasium id: ``Hexnewton-Complex-5m-v0`` for ``complex-5m``."""
        return "Hexnewton-" + "-".join(w[:1].upper() + w[1:] for w in self.name.split("-")) + "-v0"


TASKS: dict[str, Task] = {}


def register(t: Task) -> Task:
    if t.name in TASKS:
        raise ValueError(f"task '{t.name}' is registered already")
    if t.action_mode not in ACTION_MODES:
        raise ValueError(f"task '{t.name}': action mode must be one of {', '.join(ACTION_MODES)}")
    TASKS[t.name] = t
    _register_gymnasium(t)
    return t


def task(name: str) -> Task:
    """A fresh copy of the registered task ``name``; ValueError naming the tasks for an unknown one."""
    if name not in TASKS:
        raise ValueError(f"unknown task '{name}': choose one of {', '.join(TASKS)} (python train.py --list_tasks)")
    return copy.deepcopy(TASKS[name])


def task_table() -> str:
    """One line per task: name, Gymnasium id, description."""
    width = max(map(len, TASKS))
    gid = max(len(t.gym_id) for t in TASKS.values())
    return "\n".join(f"{t.name:<{width}}  {t.gym_id:<{gid}}  {t.description}" for t in TASKS.values())


def course(terrain: str | TerrainConfig, trained: HexConfig | None = None, overrides: dict | None = None,
           num_envs: int | None = None, device: str | None = None, terrain_seed: int = 0, **task_fields) -> HexConfig:
    """The course a trained controller is played or evaluated on: ``terrain`` (a name: as §3.1 defines it; a
    ``TerrainConfig``: that one) without curriculum lanes (nor lanes drawn past them), no randomisation, with the
    controller's own robot, physics and CPG (``trained``: a checkpoint's config; the defaults for the fixed CPG) and
    ``TaskConfig`` with ``task_fields``; then ``overrides`` ({"terrain.step_rise": 0.07, ...}), ``num_envs`` robots
    on ``device``, terrain seed ``terrain_seed`` and the patch long enough for the goal. The controller observes what
    it was trained to (``trained.obs``); the critic's group, which playing a policy never reads, is not built."""
    trained = trained or HexConfig()
    ground = TerrainConfig(name=terrain) if isinstance(terrain, str) else without_lanes(terrain)
    cfg = with_robot(HexConfig(task=replace(TaskConfig(), **task_fields), terrain=ground), trained.robot)
    cfg = replace(cfg, sim=trained.sim, cpg=trained.cpg, obs=replace(trained.obs, critic=False))
    cfg = apply_overrides(cfg, overrides or {})
    sim = cfg.sim if num_envs is None else replace(cfg.sim, num_envs=num_envs, device=device)
    return replace(cfg, sim=sim, terrain=terrain_for_goal(replace(cfg.terrain, seed=terrain_seed),
                                                          cfg.task.goal_distance))


def navigation_terrain(terrain: str | TerrainConfig, goal_area: float = NAVIGATE_GOALS["goal_area"],
                       margin: float = NAVIGATION_MARGIN) -> TerrainConfig:  # fmt: skip
    """``terrain`` (a name or a config, without curriculum lanes) as one square patch that holds every goal of the
    robots' starts: +-(goal_area + margin) along x around x = 0, and along y as much more as the starts spread
    (``SimConfig.spawn_y_spread`` + ``TaskConfig.reset_lateral``), on the block lattice; blocks (rugged) over all of
    it."""
    t = TerrainConfig(name=terrain) if isinstance(terrain, str) else without_lanes(terrain)
    unit = t.block_size
    half_x = math.ceil((goal_area + margin) / unit - 1e-9) * unit
    half_y = math.ceil((goal_area + margin + SimConfig.spawn_y_spread + TaskConfig.reset_lateral) / unit - 1e-9) * unit
    return replace(t, x_min=-round(half_x, 9), x_max=round(half_x, 9), width=round(2 * half_y, 9),
                   rugged_x_max=round(half_x, 9), rugged_half_width=round(half_y, 9))  # fmt: skip


def _register_gymnasium(t: Task) -> None:
    """Register ``t`` with Gymnasium (when it is installed): ``gym.make(t.gym_id, num_envs=N, device=D)``, on another
    robot ``robot=NAME|FILE|RobotConfig`` (:class:`~hexnewton.tasks.gymnasium_env.HexnewtonGymEnv`)."""
    try:
        import gymnasium
    except ImportError:  # pragma: no cover - gymnasium is a dependency
        return
    if t.gym_id not in gymnasium.registry:
        gymnasium.register(id=t.gym_id, entry_point="hexnewton.tasks.gymnasium_env:HexnewtonGymEnv",
                           kwargs={"task": t.name}, disable_env_checker=True)  # fmt: skip


def _recipe(terrain: str, goal_distance: float = TaskConfig.goal_distance, posture: bool = False,
            **terrain_fields) -> HexConfig:
    """The paper's terrains as hexnewton trains on them (module docstring)."""
    return HexConfig(
        terrain=terrain_for_goal(TerrainConfig(name=terrain, levels=10, start_levels=3, **terrain_fields),
                                 goal_distance),
        sim=SimConfig(frame_dt=0.02, substeps=4),
        cpg=CPGConfig(a2_range=(0.9, 1.3), param_tau=0.1, posture=posture),
        task=TaskConfig(goal_distance=goal_distance, seed=1),
        reward=RewardConfig(**STABLE_SHAPING),
        randomization=RandomizationConfig(enabled=True),
        obs=replace(RECIPE_OBSERVATION),
    )


def _navigate(terrain: str) -> HexConfig:
    """The terrain recipe's physics, randomisation and shaping (:func:`_recipe`) walking to :data:`NAVIGATE_GOALS` on
    :func:`navigation_terrain`'s patch (no curriculum lanes), with :data:`SIGNED_HIP`; on flat ground without the
    knee-lift floor (nothing to step over)."""
    cfg = _recipe(terrain)
    a2 = CPGConfig.a2_range if terrain == "flat" else cfg.cpg.a2_range
    return replace(cfg, terrain=navigation_terrain(terrain), cpg=replace(cfg.cpg, a1_range=SIGNED_HIP, a2_range=a2),
                   task=TaskConfig(**NAVIGATE_GOALS, max_episode_steps=NAVIGATE_EPISODE_STEPS[terrain]))


def _navigate_agent(terrain: str) -> AgentConfig:
    return AgentConfig(max_iterations=NAVIGATE_ITERATIONS, max_minutes=NAVIGATE_MINUTES[terrain], **NAVIGATE_VALIDATION)


def _margin_recipe() -> HexConfig:
    """The complex recipe with :data:`MARGIN_LANES`, :data:`MARGIN_RANDOMIZATION` and the stability fine from 0.8 rad
    (as ``stairs-8cm``: standing on 8 and 9 cm stairs pitches the torso up to 24.6 and 27.3 deg,
    studies/capability/ceiling/report.md, "Stairs": within a few degrees of the pi/6 fine)."""
    cfg = _recipe("complex", posture=True, **MARGIN_LANES)
    return replace(cfg, randomization=replace(cfg.randomization, **MARGIN_RANDOMIZATION),
                   reward=replace(cfg.reward, stability_tilt=0.8))


#: the terrain recipes' deterministic validation (AgentConfig.validation_rounds): 256 rounds per candidate on each of
#: §3.1's three courses, at most 60 s each (the step of one GPU's env costs about the same for 1024 robots as for 256:
#: three courses took 64 s on an H100 against 26 s for one, studies/time_to_skill/report.md)
TERRAIN_VALIDATION = dict(validation_rounds=256, validation_candidates=4, validation_steps=3000,
                          validation_terrains=PAPER_COURSES)
#: flat ground's, sized for the CPU main job: 16 rounds per candidate, at most 12 s each (the goal takes ~9 s)
FLAT_VALIDATION = dict(validation_rounds=16, validation_candidates=3, validation_steps=600)


def _stable_agent(long: bool = False, **validation) -> AgentConfig:
    v = {**TERRAIN_VALIDATION, **validation}
    if long:
        return AgentConfig(max_iterations=LONG_STABLE_ITERATIONS, stages=LONG_STABLE_STAGES, **v)
    return AgentConfig(max_iterations=STABLE_ITERATIONS, stages=STABLE_STAGES, **v)


register(Task("flat", "flat ground, the plain MDP (Table 1 with our goal and off-course terms), 300 iterations",
              HexConfig(task=TaskConfig(seed=1)), AgentConfig(**FLAT_VALIDATION)))
register(Task("rugged", "2 cm blocks of 0-6 cm (§3.1), the terrain recipe, 300 iterations", _recipe("rugged"),
              AgentConfig(**TERRAIN_VALIDATION)))
register(Task("stepped", "15 stairs of 6 cm rise, 25 cm deep (§3.1), the terrain recipe, 300 iterations",
              _recipe("stepped"), AgentConfig(**TERRAIN_VALIDATION)))
register(Task("complex", "1.5 m of blocks then 1.5 m of stairs (§3.1) with the body posture and the stable-gait "
              "curriculum, 300 iterations (about 3 minutes on one H100)", _recipe("complex", posture=True), _stable_agent()))
register(Task("complex-5m", "the complex course walked 5 m (goal 5.5 m ahead) with the complex recipe",
              _recipe("complex", goal_distance=5.5, posture=True), _stable_agent(long=True)))
register(Task("stairs-8cm", "15 stairs of 8 cm rise walked 5 m with the complex recipe; the stability fine starts "
              "at 0.8 rad, climbing pitches the torso 19-25 deg",
              replace(_recipe("stepped", goal_distance=5.5, posture=True, step_rise=0.08),
                      reward=RewardConfig(stability_tilt=0.8, **STABLE_SHAPING)),
              _stable_agent(long=True, validation_terrains=())))  # validated on its own 8 cm course
register(Task("complex-margin", "the complex recipe trained past its course: curriculum lanes up to 9 cm rises, 18 cm "
              "treads and 9 cm blocks, friction 0.25-1.2, motor strength 0.45-1.2, payload -0.2-1.2 kg; the stability "
              "fine from 0.8 rad; 300 iterations", _margin_recipe(), _stable_agent()))
register(Task("complex-asymmetric", "the complex recipe with an asymmetric critic (its own group: base velocities, the "
              "ground around the feet and ahead, leg contact forces, the randomised physics, the CPG's phases) and the "
              "gyro and last actions in the actor's observation", replace(_recipe("complex", posture=True),
                                                                         obs=ASYMMETRIC_OBSERVATION), _stable_agent()))
register(Task("paper", "the complex course with Table 1's reward and Table 2's PPO exactly (no curriculum, posture, "
              "shaping or randomisation; the paper's 15 parameters)",
              HexConfig(terrain=TerrainConfig(name="complex"), task=TaskConfig(seed=1),
                        reward=RewardConfig().paper_reward()), paper_agent()))
register(Task("complex-joint", "pure DRL on the complex course: the 18 joint targets, the complex recipe's "
              "terrain, physics and reward without the CPG", _recipe("complex"), AgentConfig(**TERRAIN_VALIDATION),
              action_mode="joint"))
register(Task("complex-joint-staged", "pure DRL on the complex course as complex-joint, with the stable-gait "
              "curriculum's reward weights (w_tilt 5 -> 15 -> 40, w_ang_vel 0.05 -> 0.1 -> 0.3 at iterations 100 and "
              "200, as the complex task's CPG_RL)", _recipe("complex"),
              AgentConfig(stages=STABLE_REWARD_STAGES, **TERRAIN_VALIDATION), action_mode="joint"))
register(Task("navigate-flat", "walk to goals in every direction (-180..180 deg, 1-4 m; ours) on flat ground with a "
              "signed hip amplitude, the terrain recipe's physics and randomisation; <= 10 min on one H200",
              _navigate("flat"), _navigate_agent("flat")))
register(Task("navigate-rugged", "walk to goals in every direction on a 10 m square of 2 cm blocks of 0-6 cm (§3.1's "
              "rugged ground, no curriculum lanes) with the rugged recipe and a signed hip amplitude; <= 10 min on one "
              "H200", _navigate("rugged"), _navigate_agent("rugged")))


__all__ = ["ACTION_MODES", "ASYMMETRIC_OBSERVATION", "FLAT_VALIDATION", "FOOT_CONTACT_RANGES", "LONG_STABLE_STAGES",
           "MARGIN_LANES", "MARGIN_RANDOMIZATION", "NAVIGATE_EPISODE_STEPS", "NAVIGATE_GOALS", "NAVIGATE_ITERATIONS",
           "NAVIGATE_MINUTES", "NAVIGATE_VALIDATION", "NAVIGATION_MARGIN", "PAPER_COURSES", "RECIPE_OBSERVATION",
           "SIGNED_HIP", "STABLE_REWARD_STAGES", "STABLE_SHAPING", "STABLE_STAGES", "TASKS", "TERRAIN_VALIDATION", "Task",
           "course", "navigation_terrain", "register", "task", "task_table"]

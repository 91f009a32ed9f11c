"""The paper's MDP (§2.4) as an rsl-rl-lib 5.5.1 ``VecEnv`` over the batched Newton world.

One ``step(actions)`` is one control step (``TaskConfig.control_dt``). Apart from the action copy, it is a
single captured graph (a CUDA graph on GPU, Warp's capture on CPU) of Warp kernels on preallocated arrays, through
five files:

    [latency, pushes (kernels/events.py)] -> actions to CPG parameters (kernels/cpg.py)
    -> [CPG + mapping (kernels/cpg.py) + physics (physics/world.py)] x frames x substeps
    -> episode ends, rewards, the goal switch (mdp/terms/) -> done flags and the episode ring (mdp/events.py)
    -> [curriculum lane change (mdp/events.py)] -> resets of finished envs (mdp/events.py, physics/world.py)
    -> observations (mdp/terms/) [+ noise (kernels/events.py)]

The bracketed parts run with ``RandomizationConfig.enabled`` and ``TerrainConfig.levels``; the per-env physical draws
are ``events.randomize_physics``, once, when the env is built. With ``ObsConfig.critic`` the observations also hold
the critic's group (``mdp/terms/critic.py``): ``get_observations`` returns ``{"policy", "critic"}`` and
:attr:`HexapodEnv.obs_groups` names both (rsl-rl's critic reads them, the actor ``policy`` alone).

torch sees every buffer zero-copy (``wp.to_torch``), and nothing goes back to the host inside a step. What
``step`` and ``get_observations`` return are device copies of those buffers, made after the graph: rsl-rl keeps
the observation an action was computed from until after the next ``step`` (its storage copies it only in
``process_env_step``), so a view would hand it the next observation instead (the stored observations would be
one step late, and the adaptive learning rate would sit at its 1e-5 floor).
Finished envs auto-reset. ``extras["time_outs"]`` marks time-limit ends. ``extras["log"]`` carries:
- the mean of each reward term;
- success, fall, off-course, timeout and non-finite rates, with distance (along the goal's course), length and the
  goals reached, over the last 1024 finished episodes;
- ``Episode/nonfinite_resets_total``: how many blown-up envs (NaN/Inf or runaway state, ``mdp/terms/terminations.py``)
  were reset since the env was built. Their reward stays finite (0 if the position itself is not) and their
  observation comes from the fresh start, so training never sees a NaN;
- ``Episode/contact_overflow_frames``: frames with dropped contacts so far (checked every 250 steps);
- with a curriculum, ``Curriculum/mean_level`` and ``Curriculum/top_level_share``.

Action modes:
- ``cpg`` (15 actions): omega, A1[2], A2[6], A3[6], each scaled to its range (the paper's CPG_RL);
  with ``CPGConfig.posture`` (ours, kernels/cpg.py) 18: the 15 and the body posture P_h, P_p, P_r, knee
  offsets that level the body over uneven footholds; the observation adds their 3 filtered values (62,
  layout ``cpg_posture``);
- ``joint`` (18 actions): joint targets about the standing pose, ``TaskConfig.joint_action_scale`` rad per unit
  action, clipped to the limits (the pure-DRL comparison). Its observation
  lacks the CPG parameters (44 values instead of 59); the reward is the same.
"""

from __future__ import annotations

import math

import numpy as np
import torch
import warp as wp
from rsl_rl.env import VecEnv
from tensordict import TensorDict

from hexnewton import startup
from hexnewton.config import ACTION_MODES, HexConfig, control_decimation
from hexnewton.errors import HexnewtonError
from hexnewton.kernels.cpg import CPGController, joint_actions_kernel
from hexnewton.kernels.events import advance_counter_kernel, delay_actions_kernel, observation_noise_kernel, push_kernel
from hexnewton.mdp.events import (
    DISTANCE,
    ENDS,
    GOALS,
    LENGTH,
    LEVEL,
    bookkeeping_kernel,
    curriculum_kernel,
    lane_count_kernel,
    placement_kernel,
    randomize_physics,
    reset_envs_kernel,
    start_levels,
    strict_from,
)
from hexnewton.mdp.status import SUCCESS
from hexnewton.mdp.terms import (
    BASE_LAYOUTS,
    CRITIC_DIM,
    LAYOUTS,
    OBS_DIM,
    SWITCH_SEED,
    CriticInputs,
    EndInputs,
    GoalBuffers,
    ObsInputs,
    RewardInputs,
    TaskParams,
    check_goals,
    config_params,
    critic_kernel,
    goal_switch_kernel,
    height_field_from_grid,
    layout_name,
    make_rewards_kernel,
    make_status_kernel,
    make_struct,
    obs_span,
    observation_noise,
    observations_kernel,
    physics_columns,
    reward_table,
    reward_weights,
)
from hexnewton.physics.graphs import capture_graph
from hexnewton.physics.model_build import ModelBuild
from hexnewton.physics.precompile import compile_modules, loaded_variants, variant_names
from hexnewton.physics.world import World
from hexnewton.robot import BASE_Q, foot_offset, leg_bounds
from hexnewton.robot.registry import check_scales
from hexnewton.terrain.heightmap import course_names, env_groups, group_offset_y

RING = 1024  # finished episodes the logged rates average over

class HexapodEnv(VecEnv):
    """N hexapods, one terrain, the paper's observation, action, reward and terminations. ``build``: the world's
    model built earlier (:class:`~hexnewton.physics.model_build.ModelBuild`, ``train.py`` beside its imports)."""

    def __init__(self, cfg: HexConfig, action_mode: str = "cpg", build: ModelBuild | None = None):
        if action_mode not in ACTION_MODES:
            raise HexnewtonError(f"unknown action mode '{action_mode}': choose one of {', '.join(ACTION_MODES)}")
        self.cfg = cfg
        self.action_mode = action_mode
        self.world = world = World(cfg, build=build)
        # each env's physical draws (friction, masses, gains, contacts), once, before anything is stepped
        self.physical_draws = randomize_physics(world, cfg.task.seed) if cfg.randomization.enabled else {}
        task = cfg.task
        self.decimation = control_decimation(task.control_dt, world.frame_dt)
        self.num_envs = world.num_envs
        posture = action_mode == "cpg" and cfg.cpg.posture
        self.base_layout = "cpg_posture" if posture else action_mode
        self.obs_layout = layout_name(self.base_layout, cfg.obs)
        self.num_actions = cfg.cpg.num_params if action_mode == "cpg" else 18
        self.num_obs = OBS_DIM[self.obs_layout]
        self._target_col = obs_span(self.obs_layout, "target")[0]
        self.max_episode_length = task.max_episode_steps
        self.device = world.device

        self.cpg = CPGController(world) if action_mode == "cpg" else None
        world.set_controller(self.cpg)

        self._buffers()
        self._curriculum_buffers()
        self._randomization_buffers()
        self._critic_buffers()
        self._reset(None)
        self._observe()
        wp.synchronize_device(self.device)
        self.graph = None
        self.common_step_counter = 0
        startup.mark("env buffers")

    def _buffers(self) -> None:
        """The step's buffers, the task's term kernels and the torch views of what rsl-rl reads."""
        cfg, world, n, dev = self.cfg, self.world, self.num_envs, self.device
        task = cfg.task
        # each env's start lane (x, y) and spawn height (the curriculum moves them), its episode's actual start
        # (written by every reset) and the control-step counter the random draws are keyed on
        self.height_field = height_field_from_grid(world.terrain.grid, dev)  # the terms' view of the ground
        self.lane = wp.array(world.spawn_xy.astype(np.float32), dtype=wp.vec2, device=dev)
        self.lane_z = wp.array(np.asarray(world.spawn_z, np.float32), device=dev)
        self.start = wp.clone(self.lane)
        self.goals = GoalBuffers(task, self.start, n, dev)  # each env's goal (mdp/terms/goals.py)
        self.counter = wp.zeros(1, dtype=wp.int32, device=dev)
        self._all = wp.ones(n, dtype=wp.bool, device=dev)

        z = lambda *shape, dtype=wp.float32: wp.zeros(shape, dtype=dtype, device=dev)  # noqa: E731
        self.actions = z(n, self.num_actions)
        self.status, self.rpy = z(n, dtype=wp.int32), z(n, 3)
        self.episode_steps = z(n, dtype=wp.int32)
        self.done, self.done_u8, self.time_out = z(n, dtype=wp.bool), z(n, dtype=wp.uint8), z(n, dtype=wp.uint8)
        # the task's terms (TaskConfig.terminations, RewardConfig.terms): their fused kernels
        self.status_kernel = make_status_kernel(task.terminations)
        self.reward_terms = reward_table(cfg.reward)
        self.rewards_kernel = make_rewards_kernel(self.reward_terms)
        # both are generated for this task after the World's precompile: compiled now, in parallel, not by the
        # first step
        compile_modules(dev, [(self.status_kernel.module, None), (self.rewards_kernel.module, None)])
        self.reward, self.terms, self.prev_xy = z(n), z(n, len(self.reward_terms)), z(n, dtype=wp.vec2)
        self.obs = z(n, self.num_obs)
        # the state at the end of the last step, before finished envs were reset (play.py records these)
        self.last_q, self.last_start = z(n, 7 + 18), wp.zeros(n, dtype=wp.vec2, device=dev)
        self.last_qd = z(n, 6 + 18)
        self.last_cpg_state, self.last_params = z(n, 4), z(n, cfg.cpg.num_params)
        self.prev_actions = z(n, self.num_actions)  # the policy's last actions (action-rate term)
        self._cursor = z(1, dtype=wp.int32)
        self._nonfinite_total = z(1, dtype=wp.int32)  # blown-up envs reset since the env was built
        # finished episodes: status one-hot (5), distance, length, curriculum level, goals reached
        self._ring = wp.full((RING, GOALS + 1), float("nan"), dtype=wp.float32, device=dev)
        self._no_level = z(n, dtype=wp.int32)

        # torch views (zero-copy)
        self._obs_t = wp.to_torch(self.obs)
        self._rew_t = wp.to_torch(self.reward)
        self._done_t = wp.to_torch(self.done_u8)
        self._time_out_t = wp.to_torch(self.time_out)
        self._actions_t = wp.to_torch(self.actions)
        self._terms_t = wp.to_torch(self.terms)
        self._ring_t = wp.to_torch(self._ring)
        self._steps_t = wp.to_torch(self.episode_steps)
        self._nonfinite_t = wp.to_torch(self._nonfinite_total)
        self._overflow_frames_t = torch.zeros((), device=self.device_torch)  # frames with dropped contacts

    def _curriculum_buffers(self) -> None:
        """Each env's curriculum level (``TerrainConfig.levels`` > 0; None without a curriculum), placed on its lane."""
        cfg, world, n, dev = self.cfg, self.world, self.num_envs, self.device
        self.level = None
        if cfg.terrain.levels:
            self.level = wp.array(start_levels(n, cfg.terrain.start_levels), dtype=wp.int32, device=dev)
            self._level_t = wp.to_torch(self.level)
            self._played = wp.clone(self.level)  # the lane each episode is played on (past_share: drawn ones)
            offset = world.spawn_xy[:, 1] + group_offset_y(cfg.terrain, env_groups(cfg.terrain, n))  # lane_courses
            self._lane_offset = wp.array(offset.astype(np.float32), device=dev)
            # every finished episode counted on its lane group and lane (episodes, successes): lanes.py reads it
            self._group = wp.array(env_groups(cfg.terrain, n), dtype=wp.int32, device=dev)
            self.lane_groups = course_names(cfg.terrain)
            self._lane_counts = wp.zeros((len(self.lane_groups) * cfg.terrain.levels, 2), dtype=wp.int32, device=dev)
            wp.launch(placement_kernel, dim=n,
                      inputs=[self.level, cfg.terrain.levels, cfg.terrain.lane_width, self._lane_offset,
                              self.height_field, world.footprint, world.spawn_clearance],
                      outputs=[self.lane, self.lane_z], device=dev)  # fmt: skip

    # ------------------------------------------------------------------ rsl-rl VecEnv API
    @property
    def device_torch(self) -> torch.device:
        """The torch device of the env's tensors, where actions go (``device``: its name, Warp's and rsl-rl's)."""
        return self._obs_t.device

    @property
    def episode_length_buf(self) -> torch.Tensor:
        return self._steps_t

    @episode_length_buf.setter
    def episode_length_buf(self, value: torch.Tensor) -> None:
        # rsl-rl's learn(init_at_random_ep_len=True) assigns a new tensor: copy it into the Warp buffer
        self._steps_t.copy_(value.to(self._steps_t.dtype))

    def reset(self) -> TensorDict:
        """Every robot back to a (randomised) start with its episode counter at 0; returns :meth:`get_observations`.
        Training never needs it (finished robots restart inside ``step``); the Gymnasium adapter's ``reset`` does."""
        self._reset(None)
        self.episode_steps.zero_()
        self._observe()
        return self.get_observations()

    @property
    def obs_groups(self) -> tuple[str, ...]:
        """The groups :meth:`get_observations` returns: ``policy``, and ``critic`` with ``ObsConfig.critic``."""
        return ("policy", "critic") if self.critic_obs is not None else ("policy",)

    def get_observations(self) -> TensorDict:
        """A copy of the current observations (device to device), which the next ``step`` leaves untouched: the
        ``policy`` group and, with ``ObsConfig.critic``, the ``critic`` group."""
        groups = {"policy": self._obs_t.clone()}
        if self.critic_obs is not None:
            groups["critic"] = self._critic_t.clone()
        return TensorDict(groups, batch_size=[self.num_envs], device=self.device_torch)

    def step(self, actions: torch.Tensor) -> tuple[TensorDict, torch.Tensor, torch.Tensor, dict]:
        """One control step of every env: ``actions`` copied into the step's buffer, then, in one captured graph
        (:meth:`_control_step`):

        1. actuation latency and pushes (with randomisation);
        2. the actions to the CPG's parameters (or, in ``joint`` mode, to the joint targets);
        3. the physics frames;
        4. episode ends: each env's status;
        5. rewards;
        6. the goal switch: a robot still running that reached a goal which is not its last gets the next;
        7. done flags, step counters and the finished episodes' ring;
        8. the state at the end of the step kept for recording;
        9. the curriculum's lane changes (with a terrain curriculum);
        10. the resets of the finished envs (each with its episode's first goal);
        11. observations (and their noise, with randomisation; the critic's group, with ``ObsConfig.critic``).

        Returns copies of the observations, rewards and done flags, and the extras (time-outs, log)."""
        # torch writes the actions on its (legacy default) stream; Warp's own streams are blocking streams, so
        # the graph below starts after that copy and torch's later reads wait for the graph. (Wrapping torch's
        # stream with wp.stream_from_torch failed on an H100 with "Warp error: unknown stream".)
        self._actions_t.copy_(actions)
        self._launch()
        self.common_step_counter += 1
        if self.common_step_counter % 250 == 0:  # one host read every 250 steps: contact overflow never silent
            self.world.check_contacts()
            self._overflow_frames_t.fill_(float(self.world.overflow_frames))
        extras = {"time_outs": self._time_out_t.clone(), "log": self._log()}
        return self.get_observations(), self._rew_t.clone(), self._done_t.clone(), extras

    # ------------------------------------------------------------------ the control step
    def _launch(self) -> None:
        if not self.cfg.sim.use_graph:
            self._control_step()
            return
        if self.graph is None:
            first = self.common_step_counter == 0
            before = loaded_variants(self.device) if first else None
            self._capture()
            if first:
                startup.mark("first step and graph capture")
                # what the precompile left to the first step (loaded from Warp's cache or compiled there)
                startup.note("first_step_loaded_modules", variant_names(loaded_variants(self.device) - before))
        wp.capture_launch(self.graph)

    def _capture(self) -> None:
        # the same capture as World's (proven on the H100), on Warp's own stream of the device: CUDA graphs
        # cannot be captured on torch's legacy default stream
        self.graph = capture_graph(self.device, self._control_step, self._state_arrays())

    def _randomization_buffers(self) -> None:
        """Per-step domain randomisation (``RandomizationConfig.enabled``): which envs act late, the previous
        actions, the observation noise per column and the push period in control steps."""
        rz, n, dev = self.cfg.randomization, self.num_envs, self.device
        self.randomized = rz.enabled
        if not rz.enabled:
            return
        rng = np.random.default_rng([self.cfg.task.seed, 0x1A7E])
        self._late = wp.array(rng.random(n) < rz.latency_share, dtype=wp.bool, device=dev)
        self._prev_actions = wp.zeros((n, self.num_actions), dtype=wp.float32, device=dev)
        self._effective_actions = wp.zeros((n, self.num_actions), dtype=wp.float32, device=dev)
        self._obs_noise = wp.array(observation_noise(self.obs_layout, rz), device=dev)
        self._push_steps = max(1, int(round(rz.push_interval / self.cfg.task.control_dt)))

    def _critic_buffers(self) -> None:
        """With ``ObsConfig.critic``: the critic group's buffer, the lower legs' contact forces (tracked by the world
        from now on) and each env's randomised physics, uploaded once; ``critic_obs`` None otherwise."""
        cfg, world, n, dev = self.cfg, self.world, self.num_envs, self.device
        self.critic_obs = None
        if not cfg.obs.critic:
            return
        self._leg_forces, self._foot = world.track_leg_contacts(), wp.vec3(*foot_offset(cfg.robot))  # foot in tibia
        self._lower_legs = wp.array(world.lower_legs, dtype=wp.int32, device=dev)
        late = self._late.numpy() if self.randomized else None
        self.physics = wp.array(physics_columns(self.physical_draws, late, cfg.robot, n), device=dev)
        self.critic_obs = wp.zeros((n, CRITIC_DIM[self.base_layout]), dtype=wp.float32, device=dev)
        self._critic_t = wp.to_torch(self.critic_obs)

    def _state_arrays(self) -> list[wp.array]:
        s = self.world.state_0
        arrays = [s.joint_q, s.joint_qd, s.body_q, s.body_qd, self.episode_steps, self.prev_xy, self.start,
                  self._ring, self._cursor, self.obs, self.reward, self.done_u8, self.time_out, *self.goals.arrays()]
        # (the draw counter stays where the trial run leaves it: the draws need only differ from step to step)
        arrays.append(self.prev_actions)
        if self.cpg is not None:
            arrays += [self.cpg.params, self.cpg.params_target, self.cpg.state]
        if self.level is not None:
            arrays += [self.level, self._played, self.lane, self.lane_z, self._lane_counts]
        if self.randomized:
            arrays += [self._prev_actions]
        if self.critic_obs is not None:
            arrays += [self.critic_obs]
        return arrays

    def _control_step(self) -> None:
        """One control step's launches, in ``step``'s order (with ``sim.use_graph``, captured once as a graph)."""
        actions = self._delay_and_push()
        self._apply_actions(actions)
        self._simulate()
        self._end_episodes()
        self._pay_rewards()
        self._switch_goals()
        self._count_episodes()
        self._keep_last_state()
        self._change_lanes()
        self._reset(self.done)
        self._observe()

    def _delay_and_push(self) -> wp.array:
        """With randomisation, the late envs' actions held back a step and the pushes; the actions this step acts
        on."""
        if not self.randomized:
            return self.actions
        w, t, dev, n = self.world, self.cfg.task, self.device, self.num_envs
        actions = self._effective_actions
        wp.launch(delay_actions_kernel, dim=(n, self.num_actions), inputs=[self.actions, self._late],
                  outputs=[self._prev_actions, actions], device=dev)  # fmt: skip
        rz = self.cfg.randomization
        wp.launch(push_kernel, dim=n, inputs=[self.episode_steps, self._push_steps, rz.push_velocity,
                                              t.seed + 104729, self.counter],
                  outputs=[w.joint_qd_wp], device=dev)  # fmt: skip
        return actions

    def _apply_actions(self, actions: wp.array) -> None:
        """The actions to the CPG's parameters (``cpg``) or to the joint targets (``joint``)."""
        if self.cpg is not None:
            self.cpg.set_actions(actions)
            self.cpg.respond_to_stuck(self.obs, self._target_col)  # the target the policy just observed
            return
        w, t = self.world, self.cfg.task
        wp.launch(joint_actions_kernel, dim=(self.num_envs, self.num_actions),
                  inputs=[actions, w.stand_pose, w.joint_lower, w.joint_upper, t.joint_action_scale, BASE_Q],
                  outputs=[w.joint_target_wp],
                  device=self.device)  # fmt: skip

    def _simulate(self) -> None:
        """The physics frames of one control step."""
        for _ in range(self.decimation):
            self.world.simulate_frame()

    def _end_episodes(self) -> None:
        """Each env's episode status (the task's ``TERMINATIONS`` rows) and its roll, pitch, yaw."""
        w = self.world
        ends = make_struct(EndInputs, joint_q=w.joint_q_wp, joint_qd=w.joint_qd_wp, episode_steps=self.episode_steps,
                           goals=self.goals.struct(), hf=self.height_field, task=self.cfg.task)  # fmt: skip
        wp.launch(self.status_kernel, dim=self.num_envs, inputs=[ends], outputs=[self.status, self.rpy],
                  device=self.device)  # fmt: skip

    def _pay_rewards(self) -> None:
        """Each env's reward and reward terms (the task's ``REWARD_TERMS`` rows); ``prev_xy`` and ``prev_actions``
        for the next step."""
        w, t, r = self.world, self.cfg.task, self.cfg.reward
        rewards = make_struct(RewardInputs, joint_q=w.joint_q_wp, joint_qd=w.joint_qd_wp, rpy=self.rpy,
                              status=self.status, episode_steps=self.episode_steps, actions=self.actions,
                              goals=self.goals.struct(), hf=self.height_field, prev_xy=self.prev_xy,
                              prev_actions=self.prev_actions, task=t, reward=r)  # fmt: skip
        wp.launch(self.rewards_kernel, dim=self.num_envs, inputs=[rewards, reward_weights(r, self.reward_terms)],
                  outputs=[self.reward, self.terms], device=self.device)  # fmt: skip

    def _switch_goals(self) -> None:
        """A robot still running that reached a goal which is not its last gets the next (``mdp/terms/goals.py``)."""
        t = self.cfg.task
        wp.launch(goal_switch_kernel, dim=self.num_envs, inputs=[self.status, self.world.joint_q_wp, self.goals.struct(),
                  config_params(TaskParams, t), t.seed + SWITCH_SEED, self.counter], device=self.device)  # fmt: skip

    def _count_episodes(self) -> None:
        """Done flags and step counters; the finished episodes into the ring."""
        w = self.world
        wp.launch(
            bookkeeping_kernel, dim=self.num_envs,
            inputs=[self.status, w.joint_q_wp, self.start, self.goals.course, self.goals.reached,
                    self._no_level if self.level is None else self._played],
            outputs=[self.episode_steps, self.done, self.done_u8, self.time_out, self._cursor, self._ring,
                     self._nonfinite_total], device=self.device,
        )  # fmt: skip
        if self.level is not None:
            wp.launch(lane_count_kernel, dim=self.num_envs,
                      inputs=[self.status, self._played, self._group, self.cfg.terrain.levels],
                      outputs=[self._lane_counts], device=self.device)  # fmt: skip

    def _keep_last_state(self) -> None:
        """The state at the end of the step, before finished envs are reset (``last_q`` ...: play.py records it)."""
        w = self.world
        wp.copy(self.last_q, w.joint_q_wp)
        wp.copy(self.last_qd, w.joint_qd_wp)
        wp.copy(self.last_start, self.start)
        if self.cpg is not None:
            wp.copy(self.last_cpg_state, self.cpg.state)
            wp.copy(self.last_params, self.cpg.params)

    def _change_lanes(self) -> None:
        """With a terrain curriculum, finished envs change lanes (levels) before they are reset onto them."""
        if self.level is None:
            return
        w, t, tc = self.world, self.cfg.task, self.cfg.terrain
        wp.launch(
            curriculum_kernel, dim=self.num_envs,
            inputs=[self.status, w.joint_q_wp, self.start, self.goals.course, self.goals.goal, t.goal_distance,
                    tc.start_progress > 0.0, tc.levels, tc.climb,
                    strict_from(tc),
                    tc.lane_width, self._lane_offset, self.height_field, w.footprint, w.spawn_clearance,
                    tc.levels_past, tc.past_share, t.seed + 7919, self.counter],
            outputs=[self.level, self._played, self.lane, self.lane_z], device=self.device,
        )  # fmt: skip

    def _reset(self, mask: wp.array | None) -> None:
        t, w, m = self.cfg.task, self.world, mask if mask is not None else self._all
        wp.launch(reset_envs_kernel, dim=self.num_envs,
                  inputs=[m, self.lane, self.lane_z, w.stand_pose, w.joint_lower, w.joint_upper, t.reset_lateral,
                          t.reset_yaw, t.reset_joint_noise, self.cfg.terrain.start_progress if self.level is not None
                          else 0.0, self.height_field, w.footprint, w.spawn_clearance, t.seed, self.counter,
                          config_params(TaskParams, t),
                          self.goals.struct()],
                  outputs=[w.joint_q_wp, w.joint_qd_wp, w.joint_target_wp, self.prev_xy], device=self.device)
        wp.launch(advance_counter_kernel, dim=1, inputs=[self.counter], device=self.device)
        w.restart(m)
        if self.cpg is not None:
            self.cpg.reset(mask)

    def _observe(self) -> None:
        w, ctrl = self.world, self.cpg
        params = ctrl.params if ctrl is not None else self.terms  # unread placeholder in joint mode
        inputs = make_struct(ObsInputs, joint_q=w.joint_q_wp, joint_qd=w.joint_qd_wp, params=params,
                             goals=self.goals.struct(), actions=self.prev_actions, episode_steps=self.episode_steps,
                             hf=self.height_field, task=self.cfg.task)  # fmt: skip
        wp.launch(observations_kernel, dim=self.num_envs, inputs=[inputs, LAYOUTS.index(self.obs_layout)],
                  outputs=[self.obs], device=self.device)  # fmt: skip
        if self.randomized:
            wp.launch(observation_noise_kernel, dim=self.num_envs,
                      inputs=[self._obs_noise, self.cfg.task.seed + 15485863, self.counter], outputs=[self.obs],
                      device=self.device)  # fmt: skip
        if self.critic_obs is not None:
            critic = make_struct(CriticInputs, joint_q=w.joint_q_wp, joint_qd=w.joint_qd_wp, body_q=w.state_0.body_q,
                                 lower_legs=self._lower_legs, foot=self._foot,
                                 forces=self._leg_forces, physics=self.physics,
                                 cpg_state=ctrl.state if ctrl is not None else self.last_cpg_state,
                                 episode_steps=self.episode_steps, hf=self.height_field)  # fmt: skip
            wp.launch(critic_kernel, dim=self.num_envs, inputs=[critic, BASE_LAYOUTS.index(self.base_layout)],
                      outputs=[self.critic_obs], device=self.device)  # fmt: skip

    # ------------------------------------------------------------------ logging
    def _log(self) -> dict[str, torch.Tensor]:
        means = self._terms_t.mean(dim=0)
        log = {f"Reward/{term.name}": means[k] for k, term in enumerate(self.reward_terms)}
        rates = torch.nanmean(self._ring_t, dim=0)
        for end in ENDS:
            log[f"Episode/{end.name}_rate"] = rates[end.code - 1]
        log["Episode/distance_m"] = rates[DISTANCE]
        log["Episode/length_steps"] = rates[LENGTH]
        log["Episode/goals_reached"] = rates[GOALS]
        log["Episode/nonfinite_resets_total"] = self._nonfinite_t[0].float()
        log["Episode/contact_overflow_frames"] = self._overflow_frames_t
        if self.level is not None:
            log["Curriculum/mean_level"] = self._level_t.float().mean()
            log["Curriculum/top_level_share"] = (self._level_t == self.cfg.terrain.levels - 1).float().mean()
            log["Curriculum/top_level_success_rate"] = self._top_level_success()[0]
        return log

    def _top_level_success(self) -> tuple[torch.Tensor, torch.Tensor]:
        """(success rate, episode count) of the ring's episodes played on the last curriculum level (no host
        sync: masks and sums, nan while there is none)."""
        top = self._ring_t[:, LEVEL] == self.cfg.terrain.levels - 1
        count = top.sum()
        return (top & (self._ring_t[:, SUCCESS - 1] == 1.0)).sum() / count, count

    def episode_stats(self) -> dict[str, float]:
        """Host copy of the logged episode rates (syncs; for reports, not for the training loop)."""
        rates = torch.nanmean(self._ring_t, dim=0).cpu().numpy()
        out = {f"{end.name}_rate": float(rates[end.code - 1]) for end in ENDS}
        out.update(distance_m=float(rates[DISTANCE]), length_steps=float(rates[LENGTH]), goals_reached=float(rates[GOALS]),
                   episodes=int(min(int(self._cursor.numpy()[0]), RING)), window=RING,
                   nonfinite_resets_total=int(self._nonfinite_total.numpy()[0]),
                   contact_overflow_frames=int(self.world.overflow_frames))  # fmt: skip
        if self.level is not None:
            rate, count = self._top_level_success()
            out.update(mean_level=float(self.level.numpy().mean()), top_level_success_rate=float(rate),
                       top_level_episodes=int(count))  # fmt: skip
        return out

    def lane_counts(self) -> np.ndarray | None:
        """Host copy (syncs) of the episodes finished per curriculum lane since the env was built: (groups, levels, 2)
        int (groups ``lane_groups``; columns episodes, successes). None without a curriculum."""
        if self.level is not None:
            return self._lane_counts.numpy().reshape(len(self.lane_groups), -1, 2).astype(np.int64)

    def lane_levels(self) -> np.ndarray | None:
        """Host copy (syncs) of each env's level and lane group: (num_envs, 2) int. None without a curriculum."""
        if self.level is not None:
            return np.stack([self.level.numpy(), self._group.numpy()], axis=1).astype(np.int64)

    def set_waypoints(self, points) -> None:
        """Each env's waypoint course in its start frame [m] from the next reset on (``reset()``: now), in place of
        the task's goals: (K, 2) for every env or (N, K, 2), one course per env; K = 0: the task's own goals again."""
        self.goals.set_waypoints(points)
        self.graph = None

    def set_shaping(self, reward, posture_reflex: float) -> None:
        """New reward weights (``RewardConfig``) and levelling reflex gain between iterations (a training curriculum,
        ``tasks.STABLE_STAGES``); the next step captures the graphs again with them."""
        import dataclasses

        if reward.terms != self.cfg.reward.terms:
            raise ValueError("a training curriculum changes reward weights, not the task's reward terms")
        self.cfg = dataclasses.replace(self.cfg, reward=reward,
                                       cpg=dataclasses.replace(self.cfg.cpg, posture_reflex=posture_reflex))
        if self.cpg is not None:
            self.cpg.cfg = self.cfg.cpg
        self.graph = self.world.graph = None

    def set_effort_clamp(self, mode: str) -> None:
        """The servos' effort clamp from now on (``SimConfig.effort_clamp``, a training curriculum's stage:
        :meth:`World.set_effort_clamp`); checkpoints taken after it record it."""
        import dataclasses

        self.world.set_effort_clamp(mode)
        self.cfg = dataclasses.replace(self.cfg, sim=self.world.cfg.sim)

    def close(self) -> None:
        self.graph = None


def make_env(cfg: HexConfig, action_mode: str = "cpg", build: ModelBuild | None = None) -> HexapodEnv:
    """Build the environment (on ``build``'s model where given); configuration errors become ``HexnewtonError`` /
    ``ValueError`` with one line."""
    if not math.isfinite(cfg.task.goal_distance) or cfg.task.goal_distance <= cfg.task.goal_radius:
        raise HexnewtonError("task.goal_distance must exceed task.goal_radius")
    check_goals(cfg.task)
    check_scales(cfg)
    knee = leg_bounds(cfg.robot)[1][1] - cfg.robot.stand_pose[1]  # the knee lift the standing pose leaves
    s = cfg.cpg.amplitude_scale[1]  # the robot's knee scale: the range scaled, as the CPG runs it
    lo, hi = cfg.cpg.a2_range[0] * s, cfg.cpg.a2_range[1] * s
    if not 0 <= lo < hi <= knee + 1e-9:
        raise HexnewtonError(f"cpg.a2_range must satisfy 0 <= LO < HI <= {knee:.3g} (the knee's limit above the "
                             f"standing pose), got {lo:g} {hi:g}" + (f" (x {s:.3g}, the robot's)" if s != 1 else ""))
    way, progress = cfg.task.goal_distance - cfg.task.goal_radius, cfg.terrain.start_progress
    if progress and (not progress < way or cfg.task.random_goals or cfg.task.waypoints):
        raise HexnewtonError(f"terrain.start_progress must be below goal_distance - goal_radius = {way:g} m, on a "
                             f"straight task (one goal ahead), got {progress:g}")
    if not 0 < cfg.reward.stability_tilt < math.pi / 2:
        raise HexnewtonError("reward.stability_tilt must lie in (0, pi/2) rad")
    if not cfg.cpg.param_tau >= 0:
        raise HexnewtonError("cpg.param_tau must be >= 0")
    return HexapodEnv(cfg, action_mode, build)


__all__ = ["ACTION_MODES", "HexapodEnv", "make_env"]

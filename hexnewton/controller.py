"""The CPG controller: mid level (Eq. 3) and low level (Eq. 4) driving a ``World``'s joints every substep.

``CPGController(world, cfg)`` owns, per env:
- ``params_target`` (N, P): the parameters the high level asks for, in physical units (P = 15, or 18 with the
  body posture, ``CPGConfig.posture``);
- ``params`` (N, P): their filtered values, which the oscillators and the mapping actually use;
- ``state`` (N, 4): the oscillators' (x0, y0, x1, y1);
- ``dy`` (N, 2): the oscillators' dy/dt.

Call ``world.set_controller(controller)``. Before every physics substep (inside the captured graph)
the controller launches the Hopf kernel and then the mapping kernel; the mapping writes the 18 joint
targets into Newton's control array. The high level writes actions with ``set_actions`` (policy
actions in [-1, 1]) or ``set_params`` (physical values).
"""

from __future__ import annotations

import math

import numpy as np
import warp as wp

from .config import CPGConfig, RobotConfig
from .kernels.cpg import hopf_cpg_kernel, mapping_kernel, scale_actions_kernel
from .kernels.reference import initial_cpg_state
from .robot import BASE_Q, leg_bounds
from .sim import as_mask


@wp.kernel
def _reset_cpg(
    mask: wp.array[wp.bool],
    init_state: wp.vec4,
    params_target: wp.array2d[wp.float32],
    params: wp.array2d[wp.float32],
    state: wp.array2d[wp.float32],
    dy: wp.array2d[wp.float32],
):
    e = wp.tid()
    if not mask[e]:
        return
    for k in range(params.shape[1]):
        params[e, k] = params_target[e, k]
    for k in range(4):
        state[e, k] = init_state[k]
    dy[e, 0] = 0.0
    dy[e, 1] = 0.0


class CPGController:
    """Batched two-oscillator CPG + mapping function for one ``World``."""

    def __init__(self, world, cfg: CPGConfig | None = None, robot: RobotConfig | None = None):
        self.cfg = cfg = cfg or world.cfg.cpg
        robot = robot or world.cfg.robot
        if not (0.0 < cfg.duty < 1.0):
            raise ValueError(f"cpg.duty must lie in (0, 1), got {cfg.duty}")
        if not (cfg.mu > 0 and cfg.alpha >= 0 and cfg.param_tau >= 0):
            raise ValueError("cpg.mu must be > 0, cpg.alpha and cpg.param_tau >= 0")
        n, dev = world.num_envs, world.device
        self.num_envs, self.device, self.num_params = n, dev, cfg.num_params
        self.dt = world.sim_dt
        self.gain = 1.0 if cfg.param_tau == 0 else 1.0 - math.exp(-self.dt / cfg.param_tau)
        lo, hi = cfg.param_ranges()
        self.lower = wp.array(np.asarray(lo, np.float32), device=dev)
        self.upper = wp.array(np.asarray(hi, np.float32), device=dev)
        fixed = np.tile(np.asarray(cfg.fixed_params(), np.float32), (n, 1))
        self.params_target = wp.array(fixed, dtype=wp.float32, device=dev)
        self.params = wp.array(fixed, dtype=wp.float32, device=dev)
        self.state = wp.array(np.tile(np.asarray(initial_cpg_state(cfg.mu, cfg.theta), np.float32), (n, 1)), device=dev)
        self.dy = wp.zeros((n, 2), dtype=wp.float32, device=dev)
        self._actions = wp.zeros((n, self.num_params), dtype=wp.float32, device=dev)
        self._mask = wp.zeros(n, dtype=wp.bool, device=dev)
        lower, upper = leg_bounds(robot)
        self.stand, self.joint_lower, self.joint_upper = wp.vec3(*robot.stand_pose), wp.vec3(*lower), wp.vec3(*upper)

    # ------------------------------------------------------------------ high-level inputs
    def set_actions(self, actions) -> None:
        """Policy actions (N, P) in [-1, 1] (torch tensor, Warp array or NumPy) -> ``params_target``."""
        if isinstance(actions, wp.array):
            a = actions
        else:
            if isinstance(actions, np.ndarray):
                self._actions.assign(actions.astype(np.float32))
            else:  # torch: one device-side copy into the controller's own buffer (no host round trip)
                wp.to_torch(self._actions).copy_(actions.detach())
            a = self._actions
        wp.launch(scale_actions_kernel, dim=(self.num_envs, self.num_params),
                  inputs=[a, self.lower, self.upper, self.params_target], device=self.device)  # fmt: skip

    def set_params(self, params) -> None:
        """Physical parameters, (P,) for every env or (N, P)."""
        p = np.broadcast_to(np.asarray(params, np.float32), (self.num_envs, self.num_params))
        self.params_target.assign(np.ascontiguousarray(p))

    # ------------------------------------------------------------------ stepping
    def __call__(self, world) -> None:
        c = self.cfg
        wp.launch(
            hopf_cpg_kernel,
            dim=self.num_envs,
            inputs=[self.params_target, self.gain, c.alpha, c.mu, c.delta, c.theta, c.duty, c.steepness, self.dt],
            outputs=[self.params, self.state, self.dy],
            device=self.device,
        )
        wp.launch(
            mapping_kernel,
            dim=self.num_envs,
            inputs=[self.state, self.dy, self.params, 1.0 / math.sqrt(c.mu), self.stand, self.joint_lower,
                    self.joint_upper, BASE_Q, world.state_0.joint_q.reshape(world.joint_q_wp.shape), c.posture_reflex,
                    c.posture_tilt_range[1]],  # fmt: skip
            outputs=[world.joint_target_wp],
            device=self.device,
        )

    def reset(self, mask=None) -> None:
        """Selected envs (all if None): oscillators back to the locked start, parameters at their targets."""
        m = as_mask(mask, self._mask)
        wp.launch(_reset_cpg, dim=self.num_envs,
                  inputs=[m, wp.vec4(*initial_cpg_state(self.cfg.mu, self.cfg.theta)), self.params_target],
                  outputs=[self.params, self.state, self.dy], device=self.device)  # fmt: skip

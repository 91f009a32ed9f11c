"""Control-step rollouts: a World, its CPG controller and the episode bookkeeping of §2.4.4.

``Rollout.step()`` advances one control step (``TaskConfig.control_dt``, a whole number of physics
frames). It then evaluates the end conditions in one kernel and resets the envs whose episode ended: the
robot goes back to the spawn pose, the oscillators to their locked start, and the step counter to 0.
``Rollout.done`` / ``Rollout.status`` say which envs ended at this step and why. The recorder (used by
``play.py --record``) stores, per control step, the arrays the README documents.
"""

from __future__ import annotations

import numpy as np
import warp as wp

from .config import JOINT_NAMES, HexConfig
from .controller import CPGController
from .kernels.terminations import NONFINITE, STATUS_NAMES, episode_status_kernel
from .sim import HexnewtonError, World


@wp.kernel
def _advance_episodes(status: wp.array[wp.int32], steps: wp.array[wp.int32], done: wp.array[wp.bool]):
    e = wp.tid()
    d = status[e] != 0
    done[e] = d
    if d:
        steps[e] = 0
    else:
        steps[e] = steps[e] + 1


class Rollout:
    """N robots on one terrain under the CPG controller, stepped at the control rate with auto-reset."""

    def __init__(self, cfg: HexConfig, world: World | None = None):
        self.cfg = cfg
        task = cfg.task
        self.world = world or World(cfg)
        ratio = task.control_dt / self.world.frame_dt
        if task.control_dt <= 0 or abs(ratio - round(ratio)) > 1e-6:
            raise HexnewtonError(
                f"task.control_dt ({task.control_dt}) must be a positive multiple of sim.frame_dt ({self.world.frame_dt})"
            )
        self.decimation = int(round(ratio))
        self.controller = CPGController(self.world)
        self.world.set_controller(self.controller)
        n, dev = self.world.num_envs, self.world.device
        self.episode_steps = wp.zeros(n, dtype=wp.int32, device=dev)
        self.status = wp.zeros(n, dtype=wp.int32, device=dev)
        self.done = wp.zeros(n, dtype=wp.bool, device=dev)
        self.rpy = wp.zeros((n, 3), dtype=wp.float32, device=dev)
        self.step_count = 0
        self.ended = np.zeros(len(STATUS_NAMES), dtype=np.int64)  # episodes ended, by status

    @property
    def num_envs(self) -> int:
        return self.world.num_envs

    def step(self) -> None:
        t = self.cfg.task
        self.world.step(self.decimation)
        wp.launch(
            episode_status_kernel,
            dim=self.num_envs,
            inputs=[self.world.joint_q_wp, self.episode_steps, self.world.height_field, self.world.start_wp,
                    t.goal_distance, t.goal_radius, t.min_height, t.max_tilt, t.max_abs_y, t.max_episode_steps],  # fmt: skip
            outputs=[self.status, self.rpy],
            device=self.world.device,
        )
        wp.launch(_advance_episodes, dim=self.num_envs, inputs=[self.status], outputs=[self.episode_steps, self.done],
                  device=self.world.device)  # fmt: skip
        self.step_count += 1

    def reset_done(self, status: np.ndarray | None = None) -> np.ndarray:
        """Reset every env whose episode ended at the last step; returns the status codes (N,)."""
        status = self.status.numpy() if status is None else status
        if status.any():
            self.ended += np.bincount(status, minlength=len(STATUS_NAMES))
            self.ended[0] = 0
            self.world.nonfinite_resets += int((status == NONFINITE).sum())
            self.world.reset(self.done)
            self.controller.reset(self.done)
        return status


class Recorder:
    """Collects per-control-step arrays on the host; ``save(path)`` writes one ``.npz``."""

    def __init__(self):
        self.rows: dict[str, list[np.ndarray]] = {k: [] for k in
                                                 ("t", "joint_target", "joint_pos", "base_pos", "base_rpy",
                                                  "cpg_xy", "params", "done")}  # fmt: skip

    def add(self, rollout: Rollout, t: float, status: np.ndarray, pre_reset_q: np.ndarray) -> None:
        ctrl, world = rollout.controller, rollout.world
        self.rows["t"].append(np.float64(t))
        self.rows["joint_target"].append(world.joint_target_wp.numpy()[:, 7:].copy())
        self.rows["joint_pos"].append(pre_reset_q[:, 7:].copy())
        self.rows["base_pos"].append(pre_reset_q[:, 0:3].copy())  # world frame
        self.rows["base_rpy"].append(rollout.rpy.numpy().copy())
        self.rows["cpg_xy"].append(ctrl.state.numpy().reshape(-1, 2, 2).copy())
        self.rows["params"].append(ctrl.params.numpy().copy())
        self.rows["done"].append(status != 0)

    def save(self, path: str) -> None:
        arrays = {k: np.stack(v) for k, v in self.rows.items()}
        arrays["joint_names"] = np.array(JOINT_NAMES)
        np.savez_compressed(path, **arrays)

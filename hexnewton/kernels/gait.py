"""Open-loop sinusoidal tripod gait: the test pattern that shows the world can walk before any CPG exists.

Each leg follows, with phase psi = 2 pi f t + phi_leg (phi = 0 for the tripod {R1, L2, R3}, pi for
{L1, R2, L3}):

    hip   = stand_hip   + A_hip  * sin(psi)                 (foot forward while cos(psi) > 0)
    knee  = stand_knee  + A_knee * max(cos(psi), 0)          (leg lifted while the hip swings forward)
    ankle = stand_ankle - A_knee * max(cos(psi), 0)          (tibia kept near vertical while lifted)

so a leg lifts and swings forward, then pushes backward on the ground: the body moves toward +x.
Targets are clipped to the joint limits. ``phase`` advances by 2 pi f dt each call, per env, on device,
so the kernel lives inside a captured graph.
"""

from __future__ import annotations

import numpy as np
import warp as wp

from ..robot.hexapod import BASE_Q

TRIPOD_PHASE = (0.0, np.pi, 0.0, np.pi, 0.0, np.pi)  # R1, R2, R3, L1, L2, L3


@wp.kernel
def tripod_sine_kernel(
    freq: wp.array[wp.float32],
    amp_hip: wp.array[wp.float32],
    amp_knee: wp.array[wp.float32],
    stand: wp.vec3,
    lower: wp.vec3,
    upper: wp.vec3,
    dt: float,
    target_offset: int,
    phase: wp.array[wp.float32],
    targets: wp.array2d[wp.float32],
):
    e = wp.tid()
    p = phase[e] + 2.0 * wp.pi * freq[e] * dt
    p = p - 2.0 * wp.pi * wp.floor(p / (2.0 * wp.pi))
    phase[e] = p
    for leg in range(6):
        psi = p
        if leg == 1 or leg == 3 or leg == 5:
            psi = p + wp.pi
        lift = amp_knee[e] * wp.max(wp.cos(psi), 0.0)
        hip = stand[0] + amp_hip[e] * wp.sin(psi)
        knee = stand[1] + lift
        ankle = stand[2] - lift
        col = target_offset + 3 * leg
        targets[e, col + 0] = wp.clamp(hip, lower[0], upper[0])
        targets[e, col + 1] = wp.clamp(knee, lower[1], upper[1])
        targets[e, col + 2] = wp.clamp(ankle, lower[2], upper[2])


def tripod_sine_reference(
    phase: np.ndarray,
    freq: np.ndarray,
    amp_hip: np.ndarray,
    amp_knee: np.ndarray,
    stand: np.ndarray,
    lower: np.ndarray,
    upper: np.ndarray,
    dt: float,
) -> tuple[np.ndarray, np.ndarray]:
    """Float64 NumPy reference of ``tripod_sine_kernel``: returns (new phase (N,), targets (N, 18))."""
    p = np.asarray(phase, np.float64) + 2.0 * np.pi * np.asarray(freq, np.float64) * dt
    p = np.mod(p, 2.0 * np.pi)
    psi = p[:, None] + np.asarray(TRIPOD_PHASE)[None, :]  # (N, 6)
    lift = np.asarray(amp_knee, np.float64)[:, None] * np.maximum(np.cos(psi), 0.0)
    hip = stand[0] + np.asarray(amp_hip, np.float64)[:, None] * np.sin(psi)
    out = np.stack([hip, stand[1] + lift, stand[2] - lift], axis=-1)  # (N, 6, 3)
    out = np.clip(out, np.asarray(lower)[None, None, :], np.asarray(upper)[None, None, :])
    return p, out.reshape(len(p), 18)


class TripodSineGait:
    """Drives a ``World``'s joint targets with the tripod pattern at every physics substep."""

    def __init__(self, world, freq: float | np.ndarray = 1.5, amp_hip: float | np.ndarray = 0.3,
                 amp_knee: float | np.ndarray = 0.5):  # fmt: skip
        n, dev = world.num_envs, world.device
        self.world = world
        as_arr = lambda v: wp.array(np.broadcast_to(np.asarray(v, np.float32), (n,)).copy(), device=dev)  # noqa: E731
        self.freq, self.amp_hip, self.amp_knee = as_arr(freq), as_arr(amp_hip), as_arr(amp_knee)
        self.phase = wp.zeros(n, dtype=wp.float32, device=dev)
        rc = world.cfg.robot
        self.stand = wp.vec3(*rc.stand_pose)
        self.lower = wp.vec3(rc.hip_limit[0], rc.knee_limit[0], rc.ankle_limit[0])
        self.upper = wp.vec3(rc.hip_limit[1], rc.knee_limit[1], rc.ankle_limit[1])

    def __call__(self, world) -> None:
        wp.launch(
            tripod_sine_kernel,
            dim=world.num_envs,
            inputs=[self.freq, self.amp_hip, self.amp_knee, self.stand, self.lower, self.upper, world.sim_dt,
                    BASE_Q, self.phase, world.joint_target_wp],  # fmt: skip
            device=world.device,
        )

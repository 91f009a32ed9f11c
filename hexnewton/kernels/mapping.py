"""Low level: the mapping function (Huang et al. 2025, Eq. 4), from oscillator output to the 18 joint targets.

For every leg, with its oscillator's normalised output y = y_osc / sqrt(mu) (in [-1, 1] on the limit cycle):

    hip   = A1[side] * y
    knee  = A2[leg] * (1 - y^2)    while y is rising (dy/dt >= 0, the swing phase, §2.3), else 0
    ankle = -A3[leg] * (1 - y^2)   while y is rising, else 0

Eq. 4 writes the ankle as -A3 * phi_2, but the paper's text calls A3 "the amplitude of the ankle joint",
and the policy's ranges treat A1, A2 and A3 alike as angles. We therefore read A3 as the ankle's own
amplitude, so ankle = -(A3 / A2) * knee. The knee and ankle both vanish at y = +-1, where the edge
changes, so the targets stay continuous. A1 has one value per side: A1[1] for the right legs, A1[2] for
the left. A2 and A3 have one value per leg.

The outputs are offsets from the standing pose. They are clipped to the joint limits and written straight
into Newton's ``control.joint_target_q``. The robot's joint convention (``hexnewton.config``) already
mirrors the left side: hip > 0 swings the foot forward on every leg. So the same formula makes every
stance leg push backward, and no sign flip is needed here.

Tripods: R1, L2, R3 follow oscillator 0; L1, R2, L3 follow oscillator 1. With leg order R1, R2, R3, L1,
L2, L3 that is ``oscillator = leg % 2``.
Parameter layout per env (15): omega, A1_R, A1_L, A2[R1..L3], A3[R1..L3].

Body posture (ours, ``CPGConfig.posture``; off for the paper's 15 parameters): three more parameters
P_h, P_p, P_r (columns 15..17) add a knee offset to every leg in both phases,

    knee += P_h + P_p * fx[leg] + P_r * sy[leg],   fx = +1 front, 0 middle, -1 rear;  sy = +1 right, -1 left

A positive knee angle raises the foot, so in stance P_h lowers the body, P_p > 0 lowers its front (nose down)
and P_r > 0 lowers its right side. With Eq. 4 alone a stance leg holds the standing pose whatever the ground
under it; the posture terms let the high level level the body over uneven footholds (the stance-knee /
pitch feedback of the paper's ref. [19]). A params array of 15 columns leaves them out.

Levelling reflex (ours, ``CPGConfig.posture_reflex``, with the posture only): at every substep the body's
measured pitch and roll (an IMU's reading) feed back into the tilt terms,

    P_p' = clamp(P_p - k * pitch, -tilt_max, tilt_max),   P_r' = clamp(P_r - k * roll, -tilt_max, tilt_max)

so the legs under a raised corner bend within milliseconds while the policy (50 Hz, through the parameter
filter) sets the posture it wants. k = 0 turns the reflex off.
"""

import warp as wp

from .terminations import quat_to_rpy


@wp.kernel
def mapping_kernel(
    state: wp.array2d[wp.float32],
    dy: wp.array2d[wp.float32],
    params: wp.array2d[wp.float32],
    inv_sqrt_mu: float,
    stand: wp.vec3,
    lower: wp.vec3,
    upper: wp.vec3,
    target_offset: int,
    joint_q: wp.array2d[wp.float32],
    reflex: float,
    tilt_max: float,
    targets: wp.array2d[wp.float32],
):
    e = wp.tid()
    posture = params.shape[1] > 15
    tilt_p = float(0.0)
    tilt_r = float(0.0)
    if posture:
        tilt_p = params[e, 16]
        tilt_r = params[e, 17]
        if reflex != 0.0:
            rpy = quat_to_rpy(wp.normalize(wp.quat(joint_q[e, 3], joint_q[e, 4], joint_q[e, 5], joint_q[e, 6])))
            tilt_p = wp.clamp(tilt_p - reflex * rpy[1], -tilt_max, tilt_max)
            tilt_r = wp.clamp(tilt_r - reflex * rpy[0], -tilt_max, tilt_max)
    for leg in range(6):
        osc = leg % 2
        y = state[e, 2 * osc + 1] * inv_sqrt_mu
        lift = float(0.0)
        if dy[e, osc] >= 0.0:
            lift = wp.max(1.0 - y * y, 0.0)
        a1 = params[e, 1]
        if leg >= 3:
            a1 = params[e, 2]
        knee = stand[1] + params[e, 3 + leg] * lift
        if posture:
            side = float(1.0)
            if leg >= 3:
                side = -1.0
            knee += params[e, 15] + tilt_p * float(1 - leg % 3) + tilt_r * side
        col = target_offset + 3 * leg
        targets[e, col + 0] = wp.clamp(stand[0] + a1 * y, lower[0], upper[0])
        targets[e, col + 1] = wp.clamp(knee, lower[1], upper[1])
        targets[e, col + 2] = wp.clamp(stand[2] - params[e, 9 + leg] * lift, lower[2], upper[2])

"""The paper's hexapod as a Newton articulation."""

from .hexapod import (
    BASE_Q,
    BASE_QD,
    NUM_JOINTS,
    build_hexapod,
    hip_mount,
    joint_limits,
    leg_bounds,
    leg_yaw,
    stand_height,
    torso_mass,
)

__all__ = [
    "BASE_Q",
    "BASE_QD",
    "NUM_JOINTS",
    "build_hexapod",
    "hip_mount",
    "joint_limits",
    "leg_bounds",
    "leg_yaw",
    "stand_height",
    "torso_mass",
]

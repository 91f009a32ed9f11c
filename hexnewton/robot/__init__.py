"""The paper's hexapod: its geometry (:mod:`.geometry`, plain Python) and the Newton articulation (:mod:`.hexapod`,
loaded on first use of ``build_hexapod``, so that the geometry imports without Warp or Newton)."""

from hexnewton.robot.geometry import (
    BASE_Q,
    BASE_QD,
    NUM_JOINTS,
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


def __getattr__(name: str):
    if name == "build_hexapod":
        from hexnewton.robot.hexapod import build_hexapod

        return build_hexapod
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")

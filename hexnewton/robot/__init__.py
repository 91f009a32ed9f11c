"""The hexapod: its geometry (:mod:`.geometry`, plain Python, :mod:`.frames` for a robot given frame by frame) and
the Newton articulation (:mod:`.hexapod`, loaded on first use of ``build_hexapod``, so that the geometry imports without
Warp or Newton); the named robots and ``--robot NAME|FILE`` (:mod:`.registry`), robot files (:mod:`.loader`)."""

from hexnewton.robot.geometry import (
    BASE_Q,
    BASE_QD,
    NUM_JOINTS,
    describe,
    foot_offset,
    footprint,
    hip_mount,
    joint_limits,
    joint_names,
    joint_signs,
    leg_bounds,
    leg_length,
    leg_yaw,
    spawn_clearance,
    stand_height,
    torso_mass,
)

__all__ = [
    "BASE_Q",
    "BASE_QD",
    "NUM_JOINTS",
    "build_hexapod",
    "describe",
    "foot_offset",
    "footprint",
    "hip_mount",
    "joint_limits",
    "joint_names",
    "joint_signs",
    "leg_bounds",
    "leg_length",
    "leg_yaw",
    "spawn_clearance",
    "stand_height",
    "torso_mass",
]


def __getattr__(name: str):
    if name == "build_hexapod":
        from hexnewton.robot.hexapod import build_hexapod

        return build_hexapod
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")

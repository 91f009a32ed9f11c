"""The named robots and ``--robot NAME|FILE``: :data:`ROBOTS` (``paper``, the paper's hexapod, ``RobotConfig()`` bit
for bit; ``mx_phoenix``, a robot 1.6 times its size, ``hexnewton.robot.mx_phoenix``) and :func:`resolve_robot`, a
name or a URDF / MJCF file (:func:`hexnewton.robot.loader.load_robot`) to its description.

A robot of one's own is one more entry here (a ``RobotConfig`` by its dimensions, in a folder of its own with the
sources of its numbers) or simply its file: ``--robot path/to/robot.urdf`` (docs/robots.md)."""

from __future__ import annotations

import os

from hexnewton.errors import HexnewtonError
from hexnewton.robot.mx_phoenix import MX_PHOENIX
from hexnewton.robot_config import RobotConfig

ROBOTS: dict[str, RobotConfig] = {"paper": RobotConfig(), "mx_phoenix": MX_PHOENIX}


def resolve_robot(robot: str | os.PathLike | RobotConfig, joints: tuple[str, ...] | None = None) -> RobotConfig:
    """The description of ``robot``: a name of :data:`ROBOTS`, a ``.urdf`` / ``.xml`` file (``joints``: its 18 leg
    joints in hexnewton's order, where its tree does not show them) or a ``RobotConfig`` as it is; one line
    (``HexnewtonError``) for none of them."""
    if isinstance(robot, RobotConfig):
        if joints:
            raise HexnewtonError(f"--robot_joints names a robot file's joints; robot '{robot.name}' is a description")
        return robot
    if isinstance(robot, os.PathLike):
        robot = os.fspath(robot)
    if not isinstance(robot, str):
        raise HexnewtonError(f"robot {robot!r}: expected a robot's name ({', '.join(ROBOTS)}), a robot file (.urdf or "
                             ".xml) or a RobotConfig")  # fmt: skip
    if robot in ROBOTS:
        if joints:
            raise HexnewtonError(f"--robot_joints names a robot file's joints; robot '{robot}' is a named one")
        return ROBOTS[robot]
    if os.path.splitext(robot)[1].lower() in (".urdf", ".xml") or os.path.sep in robot or os.path.exists(robot):
        from hexnewton.robot.loader import load_robot

        return load_robot(robot, tuple(joints) if joints else None)
    raise HexnewtonError(f"unknown robot '{robot}': choose one of {', '.join(ROBOTS)}, or give a robot file "
                         "(.urdf or .xml)")


def with_robot(cfg, robot: RobotConfig):
    """``cfg`` (a ``HexConfig``) for ``robot``: the robot and its scales, the CPG's amplitudes
    (``CPGConfig.amplitude_scale``) and the task's heights and terrain window (``TaskConfig.height_scale``,
    ``length_scale``), from its joint limits, standing height and footprint against the paper robot's. Everything else
    stays as ``cfg`` has it; for the paper's robot nothing changes."""
    from dataclasses import replace

    from hexnewton.robot.geometry import amplitude_scale, height_scale, length_scale, validate

    try:
        validate(robot)
    except ValueError as exc:
        raise HexnewtonError(f"robot {robot.name}: {exc}") from None
    return replace(cfg, robot=robot, cpg=replace(cfg.cpg, amplitude_scale=amplitude_scale(robot)),
                   task=replace(cfg.task, height_scale=height_scale(robot), length_scale=length_scale(robot)))


def check_scales(cfg) -> None:
    """A one-line error unless ``cfg``'s robot scales are its robot's (:func:`with_robot` sets them)."""
    from hexnewton.robot.geometry import amplitude_scale, height_scale, length_scale

    want = (*amplitude_scale(cfg.robot), height_scale(cfg.robot), length_scale(cfg.robot))
    have = (*cfg.cpg.amplitude_scale, cfg.task.height_scale, cfg.task.length_scale)
    if any(abs(a - b) > 1e-9 for a, b in zip(want, have)):
        raise HexnewtonError(f"the config's robot scales {have} are not robot {cfg.robot.name}'s {want}: configure it "
                             "with hexnewton.robot.registry.with_robot")


def same_robot(a: RobotConfig, b: RobotConfig) -> bool:
    """Whether two descriptions are one robot (where each was read from does not matter)."""
    from dataclasses import replace

    return replace(a, source="") == replace(b, source="")


def check_robot(trained: RobotConfig, robot: RobotConfig | None, what: str, init: bool = True) -> None:
    """One line unless ``robot`` (None: any) is the robot ``what`` (a checkpoint, a bundle) was trained for: a policy
    walks its own robot; ``train.py --init`` starts one for another from it (``init``: an rsl-rl checkpoint, which
    the line then names that way; not a bundle or a skrl baseline's)."""
    if robot is None or same_robot(trained, robot):
        return
    line = f"{what} was trained on robot {trained.name}, not {robot.name}: leave --robot out to run it on its own"
    if init:
        line += f", or train a policy for {robot.name} from it: python train.py --robot {robot.source or robot.name} " \
                f"--init {what}"  # fmt: skip
    raise HexnewtonError(line)

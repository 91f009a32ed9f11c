"""Command-line plumbing shared by every entry point: one clear error line and a non-zero exit, no traceback."""

from __future__ import annotations

import argparse
import os
import re
import sys
from collections.abc import Callable

from hexnewton.config import TERRAINS


#: a value that starts with a minus but is a number or an ``X,Y`` pair (``--waypoints -1,2``), not a flag
NEGATIVE_VALUE = re.compile(r"^-\d*\.?\d+([eE][-+]?\d+)?(,-?\d*\.?\d+([eE][-+]?\d+)?)?$")


class ArgumentParser(argparse.ArgumentParser):
    """argparse, but a usage error is one line (``prog: error: ...``) and exit status 2, an ``X,Y`` pair with a
    negative X is a value (argparse's own test for a negative number, widened), and a flag is spelt out in full: no
    prefix matching (``allow_abbrev=False``: the start of a flag's name is no flag), an unknown flag is one line naming
    the closest known one (:func:`unknown_flag`)."""

    def __init__(self, *args, **kwargs):
        kwargs.setdefault("allow_abbrev", False)  # subparsers (add_parser) are built by this class too
        super().__init__(*args, **kwargs)
        self._negative_number_matcher = NEGATIVE_VALUE

    def error(self, message: str):  # noqa: D102
        argv = self.__dict__.pop("_argv", None)
        flag = self._unknown_flag(argv)  # an unknown flag goes before any other error (a required flag's, ...)
        sys.stderr.write(f"{self.prog}: error: {unknown_flag(flag, self.flags(argv)) if flag else message}\n")
        sys.exit(2)

    def parse_args(self, args=None, namespace=None):  # noqa: D102
        self._argv = list(sys.argv[1:] if args is None else args)
        try:
            return super().parse_args(args, namespace)
        finally:
            self.__dict__.pop("_argv", None)

    def flags(self, argv: list[str] | None = None) -> list[str]:
        """Every option string of this parser and of the subcommand ``argv`` names (every subcommand's without
        one)."""
        out = list(self._option_string_actions)
        for action in self._actions:
            if isinstance(action, argparse._SubParsersAction):
                chosen = next((a for a in argv or () if a in action.choices), None)
                for sub in [action.choices[chosen]] if chosen else action.choices.values():
                    out += [f for f in (sub.flags() if isinstance(sub, ArgumentParser) else sub._option_string_actions)
                            if f not in out]  # fmt: skip
        return out

    def _unknown_flag(self, argv: list[str] | None) -> str | None:
        """The first word of ``argv`` that is written as a flag but is none of :meth:`flags` (None without one), up
        to ``--`` or an option that takes the rest of the line (``--ros-args``)."""
        known = self.flags(argv)
        actions = {**self._option_string_actions}
        for action in self._actions:
            if isinstance(action, argparse._SubParsersAction):
                for sub in action.choices.values():
                    actions.update(sub._option_string_actions)
        for word in argv or ():
            if word == "--" or (word in actions and actions[word].nargs == argparse.REMAINDER):
                return None
            if word.startswith("-") and word != "-" and not NEGATIVE_VALUE.match(word):
                if word.split("=", 1)[0] not in known:
                    return word
        return None


def unknown_flag(flag: str, known: list[str]) -> str:
    """The one-line error for ``flag`` (its word, with or without ``=VALUE``) that no option of ``known`` is: the flag
    it abbreviates, else the closest by spelling (difflib), else where the flags are listed."""
    import difflib

    name = flag.split("=", 1)[0]
    longs = [k for k in known if k.startswith("--")] if name.startswith("--") else list(known)
    prefixed = [k for k in longs if k.startswith(name)]
    close = difflib.get_close_matches(name, prefixed, n=1, cutoff=0) or difflib.get_close_matches(name, longs, n=1,
                                                                                                 cutoff=0.6)
    hint = f"did you mean {close[0]}?" if close else "--help lists the flags"
    return f"unknown flag {name} ({hint})"


def positive_int(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a positive integer, got '{text}'")
    if value <= 0:
        raise argparse.ArgumentTypeError(f"must be a positive integer, got {value}")
    return value


def terrain_name(text: str) -> str:
    if text not in TERRAINS:
        raise argparse.ArgumentTypeError(f"unknown terrain '{text}': choose one of {', '.join(TERRAINS)}")
    return text


def waypoint(text: str) -> tuple[float, float]:
    """``X,Y`` [m] (``--waypoints 2,0 2,2``): one waypoint in the robot's start frame (x along its start heading)."""
    parts = text.split(",")
    try:
        x, y = (float(v) for v in parts) if len(parts) == 2 else (None, None)
    except ValueError:
        x = y = None
    if x is None or not all(abs(v) < 1e3 for v in (x, y)):
        raise argparse.ArgumentTypeError(f"expected a waypoint X,Y in metres (e.g. 2,0), got '{text}'")
    return x, y


def check_writable(path: str, ext: str) -> None:
    """Fail before any simulation if an output file could not be written (never lose a finished rollout)."""
    if not path.endswith(ext):
        raise ValueError(f"{path}: expected a {ext} file name")
    parent = os.path.dirname(os.path.abspath(path))
    if not os.path.isdir(parent) or not os.access(parent, os.W_OK):
        raise ValueError(f"cannot write {path}: {parent} is not a writable directory")


def check_checkpoint_file(path: str, flag: str = "--checkpoint", key: str = "") -> None:
    """Fail in one line if ``path`` is a directory: a checkpoint is a ``.pt`` file. Where the directory holds
    ``model_*.pt`` checkpoints (a run's folder; or runs below it, an experiment's or a ``--log_dir``), the line names
    the newest run's result as ``play.py`` chooses it: ``model_result.pt``, else ``model_best.pt``, else the last
    iteration's. ``key``: what the flag's value carries before the path (``cpg_rl=`` of ``evaluate --checkpoint
    cpg_rl=PATH``)."""
    if not os.path.isdir(path):
        return
    import glob

    def result(run_dir: str) -> str | None:
        names = {os.path.basename(m) for m in glob.glob(os.path.join(run_dir, "model_*.pt"))}
        numbered = [n for n in names if re.fullmatch(r"model_\d+\.pt", n)]
        kept = [n for n in ("model_result.pt", "model_best.pt") if n in names]
        if not names:
            return None
        name = kept[0] if kept else max(numbered, key=lambda n: int(n[6:-3])) if numbered else max(names)
        return os.path.join(run_dir, name)

    newest = result(path)
    if newest is None:  # runs below it (an experiment's folder, a --log_dir): the last by name, named by start time
        below = glob.glob(os.path.join(path, "*")) + glob.glob(os.path.join(path, "*", "*"))
        found = [r for r in map(result, sorted(filter(os.path.isdir, below), key=os.path.basename)) if r]
        newest = found[-1] if found else None
    hint = f"; the newest there: {flag} {key}{newest}" if newest else " (it holds no model_*.pt)"
    raise ValueError(f"{flag} {key}{path} is a directory: expected a checkpoint file (.pt, a run's "
                     f"model_<iteration>.pt or model_result.pt){hint}")


def check_new_dir(path: str, files: tuple[str, ...] = ()) -> None:
    """Fail before any simulation unless ``path`` is a folder that does not exist yet and can be made with its
    missing parents (``os.makedirs``), or, given ``files``, an existing folder that holds none of them (nothing is
    overwritten)."""
    if files and os.path.isdir(path):
        for name in files:
            if os.path.exists(os.path.join(path, name)):
                raise ValueError(f"{path}/{name} exists: choose a new --out (nothing is overwritten)")
        return
    if os.path.exists(path):
        raise ValueError(f"{path} exists: choose a new --out (nothing is overwritten)")
    parent = os.path.dirname(os.path.abspath(path))
    while not os.path.lexists(parent) and os.path.dirname(parent) != parent:  # made with the folder
        parent = os.path.dirname(parent)
    if not os.path.isdir(parent) or not os.access(parent, os.W_OK):
        raise ValueError(f"cannot create {path}: {parent} is not a writable directory")


def add_robot_args(parser, default: str) -> None:
    """``--robot NAME|FILE`` (a named robot, hexnewton.robot.registry, or a URDF / MJCF file) and ``--robot_joints``
    (a robot file's 18 leg joints in hexnewton's order, where its tree does not show them); ``default`` says what
    leaving ``--robot`` out means."""
    parser.add_argument("--robot", metavar="NAME|FILE", default=None,
                        help=f"the robot: paper, mx_phoenix, or a .urdf / .xml file (docs/robots.md); default "
                             f"{default}")  # fmt: skip
    parser.add_argument("--robot_joints", nargs=18, metavar="JOINT", default=None,
                        help="with --robot FILE: its leg joints in hexnewton's order (R1 hip knee ankle, R2 ..., L3), "
                             "where the file's tree does not show them")  # fmt: skip


def add_mjcf_arg(parser) -> None:
    """``--mjcf own|generated``: C MuJoCo's model of a bundle's robot (sim2sim, the ROS node's robot;
    docs/robots.md)."""
    parser.add_argument("--mjcf", choices=("own", "generated"), default=None,
                        help="the robot's model: its own MJCF file as written (own; the default for a robot read from "
                             "one) or the one written from the bundle's description (generated)")  # fmt: skip


def robot_from_args(args):
    """The ``RobotConfig`` of ``--robot`` (None where it is left out); one line for a robot that cannot be read."""
    if args.robot is None:
        if args.robot_joints:
            raise ValueError("--robot_joints names the joints of a --robot FILE")
        return None
    from hexnewton.robot.registry import resolve_robot

    return resolve_robot(args.robot, args.robot_joints)


def add_browser_args(parser) -> None:
    """``--host`` and ``--port`` of the browser viewer (``--viewer viser``)."""
    from hexnewton.physics.viewer import DEFAULT_HOST, DEFAULT_PORT

    parser.add_argument("--host", default=DEFAULT_HOST,
                        help=f"--viewer viser: the address to listen on (default {DEFAULT_HOST}: this machine only; "
                             "0.0.0.0 exposes the page on every interface)")  # fmt: skip
    parser.add_argument("--port", type=positive_int, default=DEFAULT_PORT,
                        help=f"--viewer viser: the port (default {DEFAULT_PORT})")


def announce_browser(url: str, host: str, until: str) -> None:
    """Print where the browser viewer is, how to reach it from another machine, and how long it serves."""
    print(f"viewer viser: open {url} in a browser ({until}; Ctrl-C stops)")
    port = url.rsplit(":", 1)[1]
    if host in ("0.0.0.0", "::"):
        print(f"viewer viser: listening on every interface ({host}): anyone who can reach this machine can watch")
    else:
        print(f"viewer viser: from another machine, ssh -L {port}:localhost:{port} this machine, then open the same "
              "address there")  # fmt: skip


def run(main: Callable[[list[str] | None], int | None], prog: str, argv: list[str] | None = None) -> int:
    """Run ``main``; user errors (HexnewtonError, ValueError) become one stderr line and exit status 2, file
    system errors one line and exit status 1."""
    from hexnewton.errors import HexnewtonError

    try:
        return int(main(argv) or 0)
    except (HexnewtonError, ValueError) as exc:
        sys.stderr.write(f"{prog}: error: {exc}\n")
        return 2
    except OSError as exc:  # a log directory that cannot be written, a full disk, ...
        sys.stderr.write(f"{prog}: error: {exc}\n")
        return 1
    except KeyboardInterrupt:
        sys.stderr.write(f"{prog}: interrupted\n")
        return 130


# ----------------------------------------------------------------------------------------------------
# config overrides generated from the dataclasses: --env.<section>.<field> VALUE, --agent.<...>.<field> VALUE
# ----------------------------------------------------------------------------------------------------

_NONE = ("none", "null")


def _field_parser(hint, choices=None):
    """(argparse type, nargs, metavar) for a field annotated ``hint``."""
    import ast
    import types
    import typing

    args = typing.get_args(hint)
    optional = (typing.get_origin(hint) in (typing.Union, types.UnionType)) and type(None) in args
    if optional:
        hint = next(a for a in args if a is not type(None))
        args = typing.get_args(hint)

    def nullable(parse, what):
        def convert(text: str):
            if optional and text.lower() in _NONE:
                return None
            try:
                value = parse(text)
            except (ValueError, SyntaxError):
                raise argparse.ArgumentTypeError(f"expected {what}{' or none' if optional else ''}, got '{text}'")
            if choices is not None and value not in choices:
                raise argparse.ArgumentTypeError(f"'{text}' is not one of {', '.join(map(str, choices))}")
            return value

        return convert

    def boolean(text: str) -> bool:
        low = text.lower()
        if low not in ("true", "false", "1", "0", "yes", "no", "on", "off"):
            raise ValueError(text)
        return low in ("true", "1", "yes", "on")

    scalars = {bool: (boolean, "true or false"), int: (int, "an integer"), float: (float, "a number"),
               str: (str, "a string")}  # fmt: skip
    if hint in scalars:
        return nullable(*scalars[hint]), None, "NONE|" * optional + {bool: "true|false", int: "INT", float: "FLOAT",
                                                                      str: "|".join(choices or ()) or "TEXT"}[hint]
    origin = typing.get_origin(hint)
    if origin is tuple and args and all(a in (int, float) for a in args if a is not Ellipsis):
        parse, what = scalars[args[0]]
        # an optional fixed-length tuple takes its numbers or the single word none (checked by _NumbersOrNone)
        nargs = "+" if Ellipsis in args or optional else len(args)
        return nullable(parse, what), nargs, ("INT" if args[0] is int else "X")
    if origin is tuple and args == (str, Ellipsis):  # names (a task's terms): one or more words
        return nullable(str, "a name"), "+", "NAME"
    # anything else (tuples of tuples, the curriculum's stages): a Python literal
    return nullable(ast.literal_eval, "a Python literal such as ((1, 2), (3, 4))"), None, "LITERAL"


def add_config_args(parser, prefix: str, obj, skip: tuple[str, ...] = (), title: str | None = None) -> None:
    """Add ``--<prefix>.<path> VALUE`` for every field of dataclass instance ``obj`` (recursively), its current value
    shown as the default; ``skip`` lists paths (``sim.num_envs``) that have a conventional flag of their own (a field
    whose metadata says ``flag: False`` has none: the robot's name and frames, ``--robot``'s). The
    parsed values land in ``args.overrides`` as {path: value} (only those given)."""
    import dataclasses
    import typing

    group = parser.add_argument_group(title or f"--{prefix}.*: any field of the {type(obj).__name__} tree")

    def walk(o, path: str) -> None:
        hints = typing.get_type_hints(type(o))
        for f in dataclasses.fields(o):
            value, sub = getattr(o, f.name), f"{path}{f.name}"
            if sub in skip or f.metadata.get("flag", True) is False:
                continue
            if dataclasses.is_dataclass(value):
                walk(value, sub + ".")
                continue
            convert, nargs, metavar = _field_parser(hints[f.name], f.metadata.get("choices"))
            shown = "none" if value is None else " ".join(map(str, value)) if nargs and value else value
            inner = next((a for a in typing.get_args(hints[f.name]) if typing.get_origin(a) is tuple), None)
            fixed = nargs == "+" and inner is not None and Ellipsis not in typing.get_args(inner)
            extra = dict(action=_NumbersOrNone, length=len(typing.get_args(inner))) if fixed else {}
            group.add_argument(f"--{prefix}.{sub}", dest=f"override:{prefix}:{sub}", type=convert, nargs=nargs,
                               metavar=metavar, default=argparse.SUPPRESS, help=f"(default: {shown})",
                               **extra)  # fmt: skip

    walk(obj, "")


class _NumbersOrNone(argparse.Action):
    """An optional fixed-length tuple field (``foot_radius: tuple[float, float] | None``): its ``length`` numbers
    or the single word none; ValueError (one error line through :func:`run`) otherwise."""

    def __init__(self, *args, length: int, **kwargs):
        super().__init__(*args, **kwargs)
        self.length = length

    def __call__(self, parser, namespace, values, option_string=None):
        if values == [None]:
            values = None
        elif None in values or len(values) != self.length:
            raise ValueError(f"{option_string}: give {self.length} numbers or none")
        setattr(namespace, self.dest, values)


def config_overrides(args, prefix: str) -> dict:
    """{path: value} of the ``--<prefix>.*`` options that were given (see :func:`add_config_args`)."""
    tag = f"override:{prefix}:"
    return {k[len(tag):]: (tuple(v) if isinstance(v, list) else v) for k, v in vars(args).items() if k.startswith(tag)}

"""Command-line plumbing shared by every entry point: one clear error line and a non-zero exit, no traceback."""

from __future__ import annotations

import argparse
import sys
from collections.abc import Callable

from .config import TERRAINS


class ArgumentParser(argparse.ArgumentParser):
    """argparse, but a usage error is one line (``prog: error: ...``) and exit status 2."""

    def error(self, message: str):  # noqa: D102
        sys.stderr.write(f"{self.prog}: error: {message}\n")
        sys.exit(2)


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


def run(main: Callable[[list[str] | None], int | None], prog: str, argv: list[str] | None = None) -> int:
    """Run ``main``; user errors (HexnewtonError, ValueError) become one stderr line and exit status 2, file
    system errors one line and exit status 1."""
    from .errors import HexnewtonError

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

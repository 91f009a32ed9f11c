"""Ending a training run cleanly: Ctrl-C and SIGTERM raise :class:`TrainingStopped`, which both trainers (rsl-rl's
:class:`~hexnewton.learning.runner.HexRunner` and the skrl baselines' :class:`~hexnewton.learning.baselines.BaselineTrainer`) catch
to save what was learnt; the command then exits with :func:`exit_status`. Plain Python: no torch, no Warp.
"""

from __future__ import annotations

import signal

#: the signals that end a training run cleanly
STOP_SIGNALS = (signal.SIGINT, signal.SIGTERM)


class TrainingStopped(Exception):
    """Raised by the signal handler (Ctrl-C, SIGTERM) or at the end of an iteration (``train.py
    --agent.max_minutes`` / ``--agent.target_success``, the baselines' ``--max_minutes``) to end training cleanly."""


def raise_stopped(signum, frame) -> None:
    """Signal handler: raise :class:`TrainingStopped` named after the signal (``SIGINT``, ``SIGTERM``)."""
    raise TrainingStopped(signal.Signals(signum).name)


def exit_status(reason: str) -> int:
    """A finished run's exit status: 128 + the signal's number when a stop signal ended it (``reason`` names it:
    130 for Ctrl-C, 143 for SIGTERM, the shell's convention), else 0: what was learnt is saved either way, and a
    queue that reads the status never takes a stopped run for a finished one."""
    return next((128 + int(sig) for sig in STOP_SIGNALS if reason == sig.name), 0)


def catch_stop_signals() -> dict:
    """Make Ctrl-C and SIGTERM raise :class:`TrainingStopped`; returns the handlers they had ({signal: handler}),
    for the caller to restore."""
    return {sig: signal.signal(sig, raise_stopped) for sig in STOP_SIGNALS}

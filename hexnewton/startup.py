"""Where a command's start-up goes: named phases, each timed from the end of the one before, the first from the
process's own start (``/proc/self/stat``), so that imports and the interpreter count too.

    from hexnewton import startup
    startup.mark("terrain")          # the time since the last mark (or since the process started) is "terrain"
    print(startup.summary())          # "start-up 21.4 s: python and imports 4.1, terrain 0.3, ..."
    startup.note("first_step_loaded_modules", [...])   # a detail kept beside the phases (timing.json)

The physics world marks its build phases (terrain, scene, finalize, solver, collision pipeline, kernels), the env
its graph capture (the first step: lazy kernel loads and solver allocations), the runner the first iteration;
``train.py`` prints the summary after the first iteration and writes every phase into the run's ``timing.json``, with
the notes (the Warp modules the first step loaded: those the parallel precompile left to it).
Plain Python: no Warp, no torch.
"""

from __future__ import annotations

import os
import time


def process_start() -> float:
    """The process's start as a ``time.time()`` value (Linux: from ``/proc``; elsewhere: this module's import)."""
    try:
        with open("/proc/self/stat") as f:
            fields = f.read().rsplit(")", 1)[1].split()
        ticks = os.sysconf("SC_CLK_TCK")
        with open("/proc/uptime") as f:
            uptime = float(f.read().split()[0])
        return time.time() - uptime + int(fields[19]) / ticks  # field 22 of stat: start time after boot
    except (OSError, ValueError, IndexError):
        return _IMPORTED


_IMPORTED = time.time()
START = process_start()
_phases: dict[str, float] = {}
_notes: dict[str, object] = {}
_last = START


def mark(name: str) -> float:
    """End the phase ``name`` now; returns its seconds (a name marked twice adds up)."""
    global _last
    now = time.time()
    seconds = now - _last
    _phases[name] = _phases.get(name, 0.0) + seconds
    _last = now
    return seconds


def restart() -> None:
    """Forget the phases and notes so far; the next phase is timed from now. For a command run again in the same
    process (the tests call ``train.main`` several times): its record is its own."""
    global _last
    _phases.clear()
    _notes.clear()
    _last = time.time()


def note(name: str, value) -> None:
    """Keep a detail of the start-up (JSON-serialisable) beside the phases, e.g. what the first step compiled."""
    _notes[name] = value


def timed_imports(*modules: str) -> dict[str, float]:
    """Import ``modules`` one after another, each with whatever it needs that is not loaded yet, and keep their
    seconds in the note ``imports_s`` (where "python and imports" goes; a module loaded before costs 0), after
    those of an earlier call."""
    import importlib

    seconds = {}
    for name in modules:
        t0 = time.time()
        importlib.import_module(name)
        seconds[name] = round(time.time() - t0, 2)
    note("imports_s", {**_notes.get("imports_s", {}), **seconds})  # a second call adds its modules
    return seconds


def notes() -> dict[str, object]:
    """The details kept with :func:`note`."""
    return dict(_notes)


def phases() -> dict[str, float]:
    """The phases so far, in order, in seconds."""
    return dict(_phases)


def since_start() -> float:
    """Seconds since the process started."""
    return time.time() - START


#: the notes of seconds the summary line shows, by their label there
_SECONDS_NOTES = {"imports_s": "imports", "model_build_beside_s": "model built beside the imports"}


def summary() -> str:
    """One line: the seconds since the process started and each phase's."""
    parts = ", ".join(f"{k} {v:.1f}" for k, v in _phases.items())
    line = f"start-up {since_start():.1f} s from process start: {parts}"
    for name, value in _notes.items():
        if isinstance(value, list):  # the count here, the items in timing.json
            line += f"; {name.replace('_', ' ')}: {len(value)}"
        elif name in _SECONDS_NOTES:  # {what: seconds}
            line += f"; {_SECONDS_NOTES[name]}: " + ", ".join(f"{k} {v:.1f}" for k, v in value.items())
    return line


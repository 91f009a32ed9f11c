"""The console scripts ``pyproject.toml`` declares (``[project.scripts]``): ``hexnewton-train``, ``hexnewton-play``,
``hexnewton-evaluate``, ``hexnewton-export``, ``hexnewton-bench`` and ``hexnewton-ros``. Each runs its command line's
``main`` through :func:`hexnewton.apps.cli.run` under the name its usage line shows, so it answers as ``python
train.py``, ``python play.py`` or ``python -m hexnewton.apps.<name>`` does: the same flags, the same one-line errors
and the same exit status."""

from __future__ import annotations

from hexnewton.apps.cli import run


def train() -> int:
    """``hexnewton-train``: ``python train.py``."""
    from hexnewton.apps.train import main

    return run(main, "python train.py")


def play() -> int:
    """``hexnewton-play``: ``python play.py``."""
    from hexnewton.apps.play import main

    return run(main, "python play.py")


def evaluate() -> int:
    """``hexnewton-evaluate``: ``python -m hexnewton.apps.evaluate``."""
    from hexnewton.apps.evaluate import main

    return run(main, "python -m hexnewton.apps.evaluate")


def export() -> int:
    """``hexnewton-export``: ``python -m hexnewton.apps.export``."""
    from hexnewton.apps.export import main

    return run(main, "python -m hexnewton.apps.export")


def bench() -> int:
    """``hexnewton-bench``: ``python -m hexnewton.apps.bench``."""
    from hexnewton.apps.bench import main

    return run(main, "python -m hexnewton.apps.bench")


def ros() -> int:
    """``hexnewton-ros``: ``python -m hexnewton.apps.ros``."""
    from hexnewton.apps.ros import main

    return run(main, "python -m hexnewton.apps.ros")

"""skrl, the baselines' one optional dependency (the ``baselines`` extra of ``pyproject.toml``): imported only where a
baseline is built or trained, so that the rest of the package installs and runs without it."""

from __future__ import annotations

from hexnewton.errors import HexnewtonError

#: the skrl the baselines are written against (pyproject.toml's ``baselines`` extra pins the same)
SKRL = "skrl==2.1.*"
#: how to install it from a clone
INSTALL = 'pip install -e ".[baselines]"'


def require_skrl():
    """The ``skrl`` module; a one-line :class:`~hexnewton.errors.HexnewtonError` (exit status 2 from a command line)
    saying what to install where it is missing."""
    try:
        import skrl
    except ImportError:
        raise HexnewtonError(f"the skrl baselines (SAC-, TD3-, A2C-CPG) need skrl, which is not installed: {INSTALL} "
                             f"(or pip install \"{SKRL}\")") from None  # fmt: skip
    return skrl

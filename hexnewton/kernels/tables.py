"""What the term tables of ``rewards.py``, ``terminations.py`` and ``observations.py`` share.

Each of those modules declares its terms once, as a tuple of frozen dataclass rows (name, parameters, a Warp
function, a float64 NumPy function). One fused kernel per table runs every row's Warp function in table order:
``for k in range(wp.static(len(TABLE)))`` is unrolled at code generation, and ``wp.static(TABLE[k].func)`` calls the
row's function directly, so the compiled kernel is the hand-written one (no indirection, one launch).

The term functions read the configuration through :data:`TaskParams` and :data:`RewardParams`, Warp structs generated
from ``TaskConfig`` and ``RewardConfig``: one member per scalar field (float, int, bool), same name. A term that
needs a new parameter therefore needs only the config field (``i.task.<field>`` / ``i.reward.<field>`` in the term).
:func:`make_struct` fills a struct instance and converts the config dataclasses.
"""

from __future__ import annotations

import dataclasses

import warp as wp
from warp._src.codegen import Struct

from ..config import RewardConfig, TaskConfig

_SCALARS = {bool: wp.bool, int: wp.int32, float: wp.float32}


def config_struct(cls: type) -> Struct:
    """A Warp struct ``<Name>Params`` with the scalar fields (float, int, bool) of the dataclass ``cls``."""
    fields = {f.name: _SCALARS[type(f.default)] for f in dataclasses.fields(cls) if type(f.default) in _SCALARS}
    name = cls.__name__.removesuffix("Config") + "Params"
    return wp.struct(type(name, (), {"__annotations__": fields, "__module__": __name__, "__qualname__": name}))


TaskParams = config_struct(TaskConfig)
RewardParams = config_struct(RewardConfig)


def config_params(struct: Struct, cfg) -> object:
    """An instance of a :func:`config_struct` struct holding ``cfg``'s values."""
    s = struct()
    for name in struct.vars:
        setattr(s, name, getattr(cfg, name))
    return s


def make_struct(struct: Struct, **values) -> object:
    """An instance of ``struct`` with every member given by name; a config dataclass given for a
    :func:`config_struct` member is converted."""
    missing, unknown = set(struct.vars) - set(values), set(values) - set(struct.vars)
    if missing or unknown:
        raise TypeError(f"{struct.key}: missing {sorted(missing)}, unknown {sorted(unknown)}")
    s = struct()
    for name, value in values.items():
        member = struct.vars[name].type
        if isinstance(member, Struct) and dataclasses.is_dataclass(value):
            value = config_params(member, value)
        setattr(s, name, value)
    return s

"""What the term tables share: the configuration as Warp structs and the task's choice of rows.

The term functions read the configuration through :data:`TaskParams` and :data:`RewardParams`, Warp structs generated
from ``TaskConfig`` and ``RewardConfig``: one member per scalar field (float, int, bool), same name, so a term reads any
such field as ``inputs.task.<field>`` / ``inputs.reward.<field>``. :func:`make_struct` fills a kernel's inputs struct
and converts the config dataclasses; :func:`choose` picks the rows a task names."""

import dataclasses

import warp as wp
from hexnewton.physics.private_api import WarpStruct as Struct  # Warp has no public name for its struct type

from hexnewton.config import RewardConfig, TaskConfig


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


def choose(table: tuple, names: tuple[str, ...], what: str) -> tuple:
    """The rows of ``table`` named in ``names``, in table order; ValueError (one line) for a name that is no row."""
    known = [row.name for row in table]
    unknown = [name for name in names if name not in known]
    if unknown:
        raise ValueError(f"{what}: no term {', '.join(unknown)}; choose from {', '.join(known)}")
    return tuple(row for row in table if row.name in names)

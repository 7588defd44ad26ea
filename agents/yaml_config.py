"""YAML config files as typed, validated dataclasses: one reader for every program's config.

    recipe = from_yaml(RecipeConfig, "agents/configs/recipe.yaml")

A config file is a mapping whose keys are the fields of a frozen dataclass; a field whose type is a
dataclass takes a mapping of its fields (``polish_stall: {budget: 1500, sigma: 0.3}``), a tuple of
dataclasses a list of mappings, and lists become tuples. An unknown key, a missing field or a bad
value is a one-line ``ValueError`` naming the file and the key (the dataclasses validate their
values and name the allowed range).
"""

from __future__ import annotations

import dataclasses
import typing
from pathlib import Path
from types import NoneType, UnionType

import yaml


def read_yaml(path: str | Path) -> dict:
    """The mapping in the YAML file ``path``; ``ValueError`` if it cannot be read or is not a mapping."""
    try:
        data = yaml.safe_load(Path(path).read_text())
    except OSError as e:
        raise ValueError(f"{path}: cannot be read ({e.strerror or e})") from None
    except yaml.YAMLError as e:
        raise ValueError(f"{path}: not valid YAML ({str(e).splitlines()[0]})") from None
    if not isinstance(data, dict):
        raise ValueError(f"{path}: a config file is a mapping of keys, not {type(data).__name__}")
    return data


def _dataclass_of(kind):
    """The dataclass ``kind`` names (also inside ``X | None``), or None."""
    if dataclasses.is_dataclass(kind):
        return kind
    if isinstance(kind, UnionType) or typing.get_origin(kind) is typing.Union:
        found = [k for k in typing.get_args(kind) if k is not NoneType and dataclasses.is_dataclass(k)]
        return found[0] if len(found) == 1 else None
    return None


def _as_tuples(value):
    return tuple(_as_tuples(v) for v in value) if isinstance(value, list) else value


def _value(kind, value, where: str):
    """A YAML value as the field type ``kind`` asks: a dataclass from a mapping, a tuple of dataclasses
    from a list of mappings, lists as tuples, anything else as it is."""
    if value is None:
        return None
    cls = _dataclass_of(kind)
    if cls is not None:
        return build(cls, value, where)
    if typing.get_origin(kind) is tuple:
        args = typing.get_args(kind)
        if len(args) == 2 and args[1] is Ellipsis and dataclasses.is_dataclass(args[0]):
            if not isinstance(value, list):
                raise ValueError(f"{where}: {value!r} must be a list of mappings of {_names(args[0])}")
            return tuple(build(args[0], v, f"{where}[{i}]") for i, v in enumerate(value))
    return _as_tuples(value)


def _names(cls) -> str:
    return ", ".join(f.name for f in dataclasses.fields(cls))


def build(cls, data, where: str):
    """The dataclass ``cls`` from the mapping ``data`` (``where``: the file and key it came from, for
    errors); unknown keys and bad values are a ``ValueError`` naming ``where``."""
    if not isinstance(data, dict):
        raise ValueError(f"{where}: {data!r} must be a mapping of {_names(cls)}")
    fields = {f.name: f for f in dataclasses.fields(cls) if f.init}
    unknown = sorted(set(data) - set(fields))
    if unknown:
        raise ValueError(f"{where}: unknown key(s) {unknown}; the keys are {sorted(fields)}")
    hints = typing.get_type_hints(cls)
    values = {name: _value(hints[name], value, f"{where}.{name}") for name, value in data.items()}
    missing = [name for name, f in fields.items() if name not in values
               and f.default is dataclasses.MISSING and f.default_factory is dataclasses.MISSING]
    if missing:
        raise ValueError(f"{where}: missing key(s) {missing}")
    try:
        return cls(**values)
    except (TypeError, ValueError) as e:
        raise ValueError(f"{where}: {e}") from None


def from_yaml(cls, path: str | Path):
    """The dataclass ``cls`` from the YAML file ``path`` (its top-level keys are ``cls``'s fields)."""
    return build(cls, read_yaml(path), str(path))


__all__ = ["build", "from_yaml", "read_yaml"]

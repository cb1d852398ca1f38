"""Typed settings from plain dictionaries (YAML files, ROS parameter trees).

Every tunable value is a field of a frozen dataclass, declared once with its default and
unit (in the name). ``from_dict`` rejects unknown keys and wrong types with one clear line
naming the source and the key, so a typo in a launch file never passes silently.
"""
from __future__ import annotations

import dataclasses
import math
import typing
from pathlib import Path

import yaml


class ConfigError(ValueError):
    """A parameter file or tree has an unknown key, a wrong type or an invalid value."""


def load_yaml(path: str | Path) -> dict:
    path = Path(path)
    try:
        data = yaml.safe_load(path.read_text())
    except FileNotFoundError:
        raise ConfigError(f"{path}: file not found") from None
    except yaml.YAMLError as exc:
        why = " ".join(str(exc).split())       # one line: YAML's errors span several
        raise ConfigError(f"{path}: not valid YAML: {why}") from None
    if data is None:
        return {}
    if not isinstance(data, dict):
        raise ConfigError(f"{path}: expected a mapping at the top level")
    return data


def _coerce(value, hint, where: str):
    origin = typing.get_origin(hint)
    if dataclasses.is_dataclass(hint):
        if not isinstance(value, dict):
            raise ConfigError(f"{where}: expected a mapping, got {value!r}")
        return from_dict(hint, value, where)
    if origin is typing.Union:  # Optional[X]
        args = [a for a in typing.get_args(hint) if a is not type(None)]
        return None if value is None else _coerce(value, args[0], where)
    if origin is tuple:
        args = typing.get_args(hint)
        if not isinstance(value, (list, tuple)):
            raise ConfigError(f"{where}: expected a list, got {value!r}")
        item = args[0] if args else float
        return tuple(_coerce(v, item, f"{where}[{i}]") for i, v in enumerate(value))
    if hint is bool:
        if not isinstance(value, bool):
            raise ConfigError(f"{where}: expected true/false, got {value!r}")
        return value
    if hint is float:
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise ConfigError(f"{where}: expected a number, got {value!r}")
        return float(value)
    if hint is int:
        if isinstance(value, bool) or not isinstance(value, int):
            raise ConfigError(f"{where}: expected an integer, got {value!r}")
        return value
    if hint is str:
        if not isinstance(value, str):
            raise ConfigError(f"{where}: expected a string, got {value!r}")
        return value
    return value


T = typing.TypeVar("T")


def from_dict(cls: type[T], data: dict, source: str) -> T:
    """Build dataclass ``cls`` from ``data``; missing keys keep their defaults."""
    hints = typing.get_type_hints(cls)
    names = [f.name for f in dataclasses.fields(cls)]
    unknown = sorted(set(data) - set(names))
    if unknown:
        raise ConfigError(f"{source}: unknown parameter(s) {unknown}; known: {names}")
    kwargs = {k: _coerce(v, hints[k], f"{source}/{k}") for k, v in data.items()}
    try:
        obj = cls(**kwargs)
    except TypeError as exc:  # a required field without default is missing
        raise ConfigError(f"{source}: {exc}") from None
    check = getattr(obj, "validate", None)
    if check is not None:
        check(source)
    return obj


def require(cond: bool, source: str, key: str, message: str) -> None:
    """Raise a ConfigError naming ``source/key`` unless ``cond`` holds."""
    if not cond:
        raise ConfigError(f"{source}/{key}: {message}")


def positive(source: str, obj, *keys: str) -> None:
    for key in keys:
        v = getattr(obj, key)
        require(isinstance(v, (int, float)) and math.isfinite(v) and v > 0, source, key,
                f"must be a positive number, got {v!r}")


def from_params(cls: type[T], params: dict, source: str, warn) -> T:
    """Like ``from_dict`` for a node's private parameters: unknown keys get one warning line
    (through ``warn``) and are ignored, so a typo is visible but the node keeps going."""
    names = {f.name for f in dataclasses.fields(cls)}
    unknown = sorted(set(params) - names)
    if unknown:
        warn(f"{source}: ignoring unknown parameter(s) {unknown}; known: {sorted(names)}")
    return from_dict(cls, {k: v for k, v in params.items() if k in names}, source)

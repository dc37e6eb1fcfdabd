"""Small helpers to validate mappings loaded from YAML with errors that say where.

Every reader walks its document with a :class:`Node`, which knows the file and the
dotted key path, so a problem deep in a file is reported as
``configs/robots/x.yaml: joints[3].servo.id: must be an integer, got 'a'``.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any, Iterable

import yaml

from sim2real.errors import ConfigError


def load_yaml(path: Path) -> Any:
    """Read a YAML file with ``yaml.safe_load``; syntax errors become :class:`ConfigError`."""
    try:
        text = Path(path).read_text()
    except OSError as exc:
        raise ConfigError(str(path), "", f"cannot read file: {exc.strerror}") from exc
    except UnicodeDecodeError as exc:
        raise ConfigError(str(path), "", "not a YAML file: binary, not UTF-8 text") from exc
    try:
        return yaml.safe_load(text)
    except yaml.YAMLError as exc:
        raise ConfigError(str(path), "", f"invalid YAML: {exc}") from exc


class Node:
    """A value inside a loaded document, with its file and key path for error messages."""

    def __init__(self, value: Any, source: str, path: str = ""):
        self.value = value
        self.source = source
        self.path = path

    def error(self, problem: str, key: str | None = None) -> ConfigError:
        return ConfigError(self.source, self._join(key) if key is not None else self.path, problem)

    def _join(self, key: str | int) -> str:
        if isinstance(key, int):
            return f"{self.path}[{key}]"
        return f"{self.path}.{key}" if self.path else str(key)

    # -- structure ---------------------------------------------------------------
    def mapping(self, required: Iterable[str] = (), optional: Iterable[str] = ()) -> "Node":
        """Check that this is a mapping with exactly the allowed keys."""
        if not isinstance(self.value, dict):
            raise self.error(f"must be a mapping, got {type(self.value).__name__}")
        required, optional = list(required), list(optional)
        allowed = set(required) | set(optional)
        for key in self.value:
            if key not in allowed:
                raise self.error(
                    f"unknown key {key!r} (allowed: {', '.join(sorted(allowed))})", key=str(key)
                )
        for key in required:
            if key not in self.value:
                raise self.error(f"missing required key {key!r}", key=key)
        return self

    def has(self, key: str) -> bool:
        return isinstance(self.value, dict) and key in self.value

    def __getitem__(self, key: str | int) -> "Node":
        return Node(self.value[key], self.source, self._join(key))

    def get(self, key: str, default: Any = None) -> "Node":
        if self.has(key):
            return self[key]
        return Node(default, self.source, self._join(key))

    def free_mapping(self) -> dict:
        """A mapping with any keys (names chosen by the user, e.g. presets)."""
        if not isinstance(self.value, dict):
            raise self.error(f"must be a mapping, got {type(self.value).__name__}")
        return self.value

    def items(self) -> list[tuple[str, "Node"]]:
        return [(str(k), self[k]) for k in self.free_mapping()]

    def list(self, min_len: int = 0) -> list["Node"]:
        if not isinstance(self.value, list):
            raise self.error(f"must be a list, got {type(self.value).__name__}")
        if len(self.value) < min_len:
            raise self.error(f"must have at least {min_len} entries")
        return [self[i] for i in range(len(self.value))]

    # -- scalars -------------------------------------------------------------------
    def number(self, lo: float | None = None, hi: float | None = None, positive: bool = False) -> float:
        v = self.value
        if isinstance(v, bool) or not isinstance(v, (int, float)):
            raise self.error(f"must be a number, got {v!r}")
        v = float(v)
        if not math.isfinite(v):
            raise self.error(f"must be finite, got {v!r}")
        if positive and v <= 0:
            raise self.error(f"must be > 0, got {v!r}")
        if lo is not None and v < lo:
            raise self.error(f"must be >= {lo}, got {v!r}")
        if hi is not None and v > hi:
            raise self.error(f"must be <= {hi}, got {v!r}")
        return v

    def integer(self, lo: int | None = None, hi: int | None = None) -> int:
        v = self.value
        if isinstance(v, bool) or not isinstance(v, int):
            raise self.error(f"must be an integer, got {v!r}")
        if lo is not None and v < lo:
            raise self.error(f"must be >= {lo}, got {v}")
        if hi is not None and v > hi:
            raise self.error(f"must be <= {hi}, got {v}")
        return v

    def string(self, choices: Iterable[str] | None = None) -> str:
        v = self.value
        if not isinstance(v, str) or not v:
            raise self.error(f"must be a non-empty string, got {v!r}")
        if choices is not None:
            choices = list(choices)
            if v not in choices:
                raise self.error(f"must be one of {', '.join(choices)}; got {v!r}")
        return v

    def boolean(self) -> bool:
        if not isinstance(self.value, bool):
            raise self.error(f"must be true or false, got {self.value!r}")
        return self.value

    def pair(self) -> tuple[float, float]:
        """A ``[low, high]`` pair of numbers with low < high."""
        items = self.list()
        if len(items) != 2:
            raise self.error(f"must be [low, high], got {self.value!r}")
        lo, hi = items[0].number(), items[1].number()
        if not lo < hi:
            raise self.error(f"low must be below high, got {self.value!r}")
        return lo, hi

    def vector(self, n: int, positive: bool = False) -> tuple[float, ...]:
        items = self.list()
        if len(items) != n:
            raise self.error(f"must have {n} numbers, got {self.value!r}")
        return tuple(item.number(positive=positive) for item in items)


def dataclass_from_mapping(cls: type, values: Any, source: str, prefix: str, what: str) -> Any:
    """Build a frozen config dataclass from a YAML mapping, checking each value against its
    field's default type; unknown keys and wrong types raise :class:`ConfigError`."""
    import dataclasses

    if values is None:
        values = {}
    if not isinstance(values, dict):
        raise ConfigError(source, prefix.rstrip("."), f"must be a mapping, got {type(values).__name__}")
    fields = {f.name: f for f in dataclasses.fields(cls)}
    kwargs: dict[str, Any] = {}
    for key, value in values.items():
        where = f"{prefix}{key}"
        if key not in fields:
            raise ConfigError(source, where, f"unknown {what} parameter {key!r}")
        default = fields[key].default
        if isinstance(default, bool):
            ok = isinstance(value, bool)
        elif isinstance(default, int):
            ok = isinstance(value, int) and not isinstance(value, bool)
        elif isinstance(default, float):
            ok = isinstance(value, (int, float)) and not isinstance(value, bool)
            value = float(value) if ok else value
            if ok and not math.isfinite(value):
                raise ConfigError(source, where, f"must be finite, got {value!r}")
        else:
            ok = isinstance(value, str) and bool(value)
        if not ok:
            kind = ("true or false" if isinstance(default, bool) else "an integer" if isinstance(default, int)
                    else "a number" if isinstance(default, float) else "a non-empty string")
            raise ConfigError(source, where, f"must be {kind}, got {value!r}")
        kwargs[key] = value
    return cls(**kwargs)

"""The field checker of controller files: type, shape and range checks that name the field.

Every problem is one :class:`ConfigError` line, ``FILE: FIELD: problem``, the field a JSON key
path (``a.b[0]``, :func:`join_key`); values are echoed through
:func:`sim2real.robot.validation.show`, the one cutter of user input in messages.  The format's
checks (:mod:`sim2real.controller.checks`) and the checks against a robot
(:mod:`sim2real.controller.robot_checks`) both speak through it.

    c = FieldChecker("walker.json")
    c.number(data["tick_s"], "tick_s", 0.001, 1.0)   # ConfigError("walker.json", "tick_s", ...) if not
"""

from __future__ import annotations

import math
from typing import Any

from sim2real.controller.json_reader import NonFinite
from sim2real.errors import ConfigError
from sim2real.robot.validation import show


def join_key(path: str, key: Any) -> str:
    """``path`` extended by ``key`` as a message names a field: ``a.b``, ``a[0]``, ``a['odd key']``."""
    if isinstance(key, int):
        return f"{path}[{key}]"
    if isinstance(key, str) and key.isidentifier():
        return f"{path}.{key}" if path else key
    return f"{path}[{show(key)}]"


class FieldChecker:
    """Type, shape and range checks that name the field: ``FILE: FIELD: problem``."""

    def __init__(self, source: str):
        self.source = source

    def error(self, key: str, problem: str) -> ConfigError:
        return ConfigError(self.source, key, problem)

    def obj(self, value: Any, key: str, required: tuple[str, ...] = (), optional: tuple[str, ...] = (),
            free: bool = False) -> dict[str, Any]:
        if not isinstance(value, dict):
            raise self.error(key, f"must be an object, got {show(value)}")
        for name in required:
            if name not in value:
                raise self.error(join_key(key, name), "missing")
        if not free:
            allowed = required + optional
            for name in value:
                if name not in allowed:
                    raise self.error(join_key(key, name), f"unknown key (allowed: {', '.join(allowed)})")
        return value

    def string(self, value: Any, key: str) -> str:
        if not isinstance(value, str) or not value:
            raise self.error(key, f"must be a non-empty string, got {show(value)}")
        return value

    def names(self, value: Any, key: str, min_len: int = 0) -> list[str]:
        if not isinstance(value, list):
            raise self.error(key, f"must be a list of names, got {show(value)}")
        if len(value) < min_len:
            raise self.error(key, f"must have at least {min_len} entr{'y' if min_len == 1 else 'ies'}")
        for i, name in enumerate(value):
            self.string(name, f"{key}[{i}]")
        if len(set(value)) != len(value):
            twice = next(n for i, n in enumerate(value) if n in value[:i])
            raise self.error(key, f"{show(twice)} appears twice")
        return value

    def number(self, value: Any, key: str, lo: float, hi: float, lo_open: bool = False) -> float:
        if isinstance(value, bool) or not isinstance(value, (int, float, NonFinite)):
            raise self.error(key, f"must be a number, got {show(value)}")
        if isinstance(value, NonFinite) or isinstance(value, float) and not math.isfinite(value):
            raise self.error(key, f"must be a finite number, got {show(value)}")
        if value < lo or (lo_open and value == lo) or value > hi:
            raise self.error(key, f"must be within {'(' if lo_open else '['}{lo:g}, {hi:g}], got {show(value)}")
        return float(value)

    def same_names(self, key: str, got: list[str], want: list[str], why: str) -> None:
        if got == want:
            return
        if len(got) != len(want):
            raise self.error(key, f"has {len(got)} names where {why} has {len(want)}: {show(want)}")
        i = next(i for i, (a, b) in enumerate(zip(got, want)) if a != b)
        raise self.error(f"{key}[{i}]", f"is {show(got[i])} where {why} has {show(want[i])}")

    def finite_everywhere(self, value: Any, key: str) -> None:
        """Free-form blocks (task, provenance) may hold anything JSON allows, finite numbers only."""
        if isinstance(value, dict):
            for k, v in value.items():
                self.finite_everywhere(v, join_key(key, k))
        elif isinstance(value, list):
            for i, v in enumerate(value):
                self.finite_everywhere(v, f"{key}[{i}]")
        elif isinstance(value, NonFinite) or (isinstance(value, float) and not math.isfinite(value)):
            raise self.error(key, f"must be a finite number, got {show(value)}")


def difference(what: str, extra: list[str], lacking: list[str]) -> str:
    """What a list of names has beyond ``what`` and lacks of it, in words."""
    parts = [f"has {show(extra)} beyond {what}"] if extra else []
    return "; ".join(parts + ([f"lacks {show(lacking)} of {what}"] if lacking else []))

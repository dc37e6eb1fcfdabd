"""Hardened JSON decoding: controller files' bytes to Python values, every refusal one line.

:func:`read_bounded` then :func:`decode` turn a file into JSON values before anything looks
at what they mean (:mod:`sim2real.controller.checks` does that); every problem is one
:class:`~sim2real.errors.ConfigError`, ``FILE: : problem``.  They refuse:

* more than ``MAX_BYTES`` (4 MiB; a 300-connection controller is under 20 KB), checked
  before reading, and what is not a regular file (:mod:`sim2real.input_files`);
* text that is not UTF-8 (a UTF-8 byte-order mark is skipped);
* brackets nested more than ``MAX_DEPTH`` deep, scanned before decoding (:func:`nesting_depth`)
  so that decoding cannot recurse;
* a key twice in one object (:func:`unique_keys`; JSON would keep the last silently);
* text that is not JSON, or a number Python cannot read (an integer of 5,000 digits).

``NaN`` and ``Infinity`` (not JSON, but Python's decoder reads them) decode to
:class:`NonFinite` markers, so that the check can name the field that holds one.  Trace
sidecars (:mod:`sim2real.hardware.trace`) use the depth scan and the duplicate-key hook too.
"""

from __future__ import annotations

import codecs
import json
import re
from pathlib import Path
from typing import Any

import numpy as np

from sim2real.errors import ConfigError
from sim2real.input_files import decode_utf8, read_regular_bytes
from sim2real.robot.validation import show

MAX_BYTES = 4 * 1024 * 1024  # a 300-connection controller is < 20 KB; 4 MiB holds ~200,000
MAX_DEPTH = 64  # the format nests 3 deep, provenance's config about 6

_ESCAPE = re.compile(rb"\\.", re.DOTALL)  # in valid JSON a backslash starts a 2-byte escape


def read_bounded(path: Path | str, source: str) -> bytes:
    """The file's bytes, refused unread when larger than ``MAX_BYTES`` (a 300-connection
    controller is about 20 KB) or not a regular file (a FIFO would block the open, a device
    never end: :mod:`sim2real.input_files`)."""
    return read_regular_bytes(path, source, limit=MAX_BYTES, what="controller")


class NonFinite:
    """What ``NaN``/``Infinity`` decode to, so that the field holding one can be named."""

    __slots__ = ("literal",)

    def __init__(self, literal: str):
        self.literal = literal

    def __repr__(self) -> str:
        return self.literal


class DuplicateKey(Exception):
    """A JSON object names one key twice (``args[0]``: the key)."""


def unique_keys(pairs: list[tuple[str, Any]]) -> dict[str, Any]:
    """``object_pairs_hook`` for ``json.loads``: a key given twice in one object raises
    :class:`DuplicateKey` instead of the last one silently winning."""
    obj = dict(pairs)
    if len(obj) != len(pairs):
        seen: set[str] = set()
        for key, _ in pairs:
            if key in seen:
                raise DuplicateKey(key)
            seen.add(key)
    return obj


def nesting_depth(raw: bytes) -> tuple[int, int]:
    """(deepest bracket nesting, 1-based line where it first passes ``MAX_DEPTH``, else 0)
    of JSON text, brackets inside strings ignored: a linear scan, no recursion."""
    b = np.frombuffer(_ESCAPE.sub(b"", raw), dtype=np.uint8)
    outside = np.bitwise_xor.accumulate((b == ord('"')).view(np.uint8)) == 0  # quote parity
    step = ((b == ord("[")) | (b == ord("{"))).astype(np.int32) - ((b == ord("]")) | (b == ord("}")))
    level = np.cumsum(step * outside, dtype=np.int32)
    depth = int(level.max(initial=0))
    if depth <= MAX_DEPTH:
        return depth, 0
    where = int(np.argmax(level > MAX_DEPTH))
    return depth, int(np.count_nonzero(b[:where] == ord("\n"))) + 1


def decode(raw: bytes, source: str) -> Any:
    """UTF-8 JSON text to Python values; ``NaN``/``Infinity`` become :class:`NonFinite`
    markers for the check."""
    if raw.startswith(codecs.BOM_UTF8):
        raw = raw[len(codecs.BOM_UTF8):]
    text = decode_utf8(raw, source, "not UTF-8 text (binary, or another encoding?)")
    depth, line = nesting_depth(raw)
    if depth > MAX_DEPTH:
        raise ConfigError(source, "", f"JSON nested {depth} levels deep (line {line}); "
                          f"a controller nests at most {MAX_DEPTH}")
    try:
        return json.loads(text, parse_constant=NonFinite, object_pairs_hook=unique_keys)
    except json.JSONDecodeError as exc:
        raise ConfigError(source, "", f"not valid JSON (truncated?): {exc.msg} (line {exc.lineno} "
                          f"column {exc.colno})") from None
    except DuplicateKey as exc:
        raise ConfigError(source, "", f"key {show(exc.args[0])} appears twice in one object "
                          "(JSON keys must be unique)") from None
    except RecursionError:  # not reached after the depth scan; kept as the last guard
        raise ConfigError(source, "", "JSON nested too deep") from None
    except ValueError as exc:  # e.g. an integer of more than 4300 digits
        raise ConfigError(source, "", f"not valid JSON: {str(exc).split(';')[0]}") from None

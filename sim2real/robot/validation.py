"""Small helpers to read YAML safely and validate what it holds, with errors that say where.

Every reader walks its document with a :class:`Node`, which knows the file and the
dotted key path, so a problem deep in a file is reported as
``configs/robots/x.yaml: joints[3].servo.id: must be an integer, got 'a'``.

:func:`load_yaml` is the one way in for every YAML file the project reads (robots, evolution
and reality configs, firmware profiles, fault files, a run folder's ``config.yaml``).  It
refuses, naming the file, before building any value:

* what is not a regular file (a directory, a FIFO or a device: never opened for reading,
  :mod:`sim2real.input_files`), more than ``MAX_YAML_BYTES`` (256 KiB, refused unread; the
  largest shipped file is 10 KB), text that is not UTF-8 or holds NUL bytes;
* collections nested more than ``MAX_YAML_DEPTH`` (64) deep, and a document of more than
  ``MAX_YAML_NODES`` (20,000) values counted with every alias expanded (``*a`` counts all that
  ``&a`` holds, each time; a text counts one more per 100 characters): a "billion laughs"
  alias bomb stops at the first alias past the bound; an alias inside its own anchor is
  refused too;
* a key given twice in one mapping (YAML would keep the last silently), naming the key path
  and both lines; merge keys (``<<: *base``) may still be overridden;
* an empty document (nothing, or only comments): every reader needs settings.

It uses ``yaml.SafeLoader``'s semantics (no tags that build Python objects).  Messages never
hold a value whole: :func:`show` cuts it to a few dozen characters.
"""

from __future__ import annotations

import math
import re
import reprlib
from pathlib import Path
from typing import Any, Iterable

import yaml
from yaml.nodes import MappingNode, Node as YamlNode, ScalarNode, SequenceNode

from sim2real.errors import ConfigError
from sim2real.input_files import decode_utf8, read_regular_bytes

MAX_YAML_BYTES = 256 * 1024  # the largest shipped YAML (a firmware profile) is 10 KB
MAX_YAML_DEPTH = 64  # as controller JSON; the project's formats nest at most 6 deep
MAX_YAML_NODES = 20_000  # values in a document, aliases expanded; shipped files hold < 1,500
_SHOWN_KEY = 40  # characters of a key in a key path


# -- values in messages ----------------------------------------------------------------
_REPR = reprlib.Repr()  # Python 3.11's takes no keywords
_REPR.maxstring, _REPR.maxother, _REPR.maxlong = 40, 40, 40
_REPR.maxlist = _REPR.maxtuple = _REPR.maxset = _REPR.maxfrozenset = 4
_REPR.maxdict, _REPR.maxlevel = 3, 2


def show(value: Any) -> str:
    """``repr(value)`` cut to a few dozen characters: what a message may echo of user input
    (a value from a file may be megabytes long, or an alias bomb)."""
    try:
        text = _REPR.repr(value)
    except (ValueError, RecursionError):  # e.g. an int of more digits than str() allows
        text = f"<{type(value).__name__}>"
    return text if len(text) <= 80 else text[:77] + "..."


def show_name(text: str) -> str:
    """A name or path given by the user, quoted: whole up to 255 characters (a file name's
    limit), cut like :func:`show` beyond (a "path" read from a file may be anything)."""
    return repr(text) if len(text) <= 255 else show(text)


def show_key(key: Any) -> str:
    """A mapping key as it appears in a key path, cut to ``_SHOWN_KEY`` characters."""
    text = key if isinstance(key, str) else show(key)
    return text if len(text) <= _SHOWN_KEY else text[:_SHOWN_KEY - 3] + "..."


# YAML 1.1 (PyYAML) reads a float only with a dot in the mantissa and a sign in the exponent:
# 1.0e+308 is a number, 1.0e308 and 1e6 are text.  Python's float() reads them all.
_NUMBER_TEXT = re.compile(r"[-+]?(\d[\d_]*\.?[\d_]*|\.\d[\d_]*)([eE][-+]?\d+)?")


def _as_yaml_number(text: str) -> str | None:
    """How to write ``text`` (a number YAML 1.1 reads as a string) so that YAML reads a number,
    or None if it is not such a number."""
    text = text.strip()
    if not _NUMBER_TEXT.fullmatch(text):
        return None
    mantissa, _, exponent = text.replace("E", "e").partition("e")
    if mantissa.lstrip("+-").startswith("."):
        mantissa = mantissa.replace(".", "0.", 1)
    if "." not in mantissa:
        mantissa += ".0"
    elif mantissa.endswith("."):
        mantissa += "0"
    if exponent and exponent[0] not in "+-":
        exponent = "+" + exponent
    return f"{mantissa}e{exponent}" if exponent else mantissa


def _not_a_number(value: Any, kind: str) -> str:
    """The problem with ``value`` where ``kind`` ("a number", "an integer") was expected,
    saying so when YAML read a number as text (``1.0e308``, ``1e6``)."""
    if isinstance(value, str) and len(value) <= 40 and (written := _as_yaml_number(value)) is not None:
        if kind == "an integer":
            whole = float(value.replace("_", ""))
            if not (whole.is_integer() and abs(whole) < 1e15):
                return f"must be an integer, got {show(value)} (text to YAML 1.1)"
            written = str(int(whole))
        if "e" not in value.lower():  # a plain number is a string only in quotes
            plain = written if kind == "an integer" else value.strip()
            return f"{show(value)} is text (in quotes?), not a number: write {plain} without them"
        return f"{show(value)} is text to YAML 1.1, not a number: write {written}"
    if isinstance(value, bool):
        return f"must be {kind}, got {value!r} (YAML reads yes/no/on/off as true/false)"
    return f"must be {kind}, got {show(value)}"


# -- reading ---------------------------------------------------------------------------
class _Refused(Exception):
    """A document refused while it was being read: ``args`` are (key path, problem)."""


class _BoundedLoader(yaml.SafeLoader):
    """``yaml.SafeLoader`` that refuses, while composing (before any value is built), nesting
    deeper than ``MAX_YAML_DEPTH``, more than ``MAX_YAML_NODES`` values with aliases expanded
    and an alias inside its own anchor; and, while constructing, a key given twice in one
    mapping."""

    def __init__(self, stream: str):
        super().__init__(stream)
        self._depth = 0
        self._nodes = 0  # values composed so far, aliases expanded
        self._aliases = 0
        self._sizes: dict[int, int] = {}  # id(node) -> values it holds, itself included (once complete)
        self._root: YamlNode | None = None

    def _count(self, n: int, mark: yaml.Mark, alias: str | None) -> None:
        self._nodes += n
        if self._nodes <= MAX_YAML_NODES:
            return
        line = mark.line + 1
        if alias is not None:
            raise _Refused("", f"alias *{show_key(alias)} (line {line}) expands the document to more than "
                           f"{MAX_YAML_NODES} values (an alias repeats all that its anchor holds): refused "
                           "before building it")
        raise _Refused("", f"more than {MAX_YAML_NODES} values{' with its aliases expanded' if self._aliases else ''}"
                       f" (line {line}): too large for a configuration")

    def compose_node(self, parent: YamlNode | None, index: Any) -> YamlNode:
        event = self.peek_event()
        if isinstance(event, yaml.AliasEvent):
            target = self.anchors.get(event.anchor)
            if target is not None:  # (an undefined alias is the composer's own error)
                size = self._sizes.get(id(target))
                if size is None:  # its anchor's collection is still being composed
                    raise _Refused("", f"alias *{show_key(event.anchor)} (line {event.start_mark.line + 1}) is "
                                   "inside its own anchor: a value that holds itself")
                self._aliases += 1
                self._count(size, event.start_mark, event.anchor)
            return super().compose_node(parent, index)
        collection = isinstance(event, (yaml.SequenceStartEvent, yaml.MappingStartEvent))
        if collection:
            self._depth += 1
            if self._depth > MAX_YAML_DEPTH:
                raise _Refused("", f"nested more than {MAX_YAML_DEPTH} levels deep (line "
                               f"{event.start_mark.line + 1}); a configuration nests a few")
        before = self._nodes
        # a text counts one more per 100 characters: an alias of a long text repeats all of it
        self._count(1 + (len(event.value) // 100 if isinstance(event, yaml.ScalarEvent) else 0), event.start_mark, None)
        node = super().compose_node(parent, index)
        self._depth -= collection
        self._sizes[id(node)] = self._nodes - before
        return node

    def construct_document(self, node: YamlNode) -> Any:
        self._root = node
        return super().construct_document(node)

    def construct_mapping(self, node: YamlNode, deep: bool = False) -> dict:
        if isinstance(node, MappingNode):
            seen: dict[Any, int] = {}  # key -> the line it first appears on
            for key_node, _ in node.value:  # before merge keys (<<) are flattened in: those may be overridden
                if not isinstance(key_node, ScalarNode) or key_node.tag == "tag:yaml.org,2002:merge":
                    continue
                key, line = self.construct_object(key_node), key_node.start_mark.line + 1
                try:
                    hash(key)
                except TypeError:  # unhashable: the constructor's own error follows
                    continue
                if key in seen:
                    raise _Refused(_join_path(_path_to(self._root, node), key),
                                   f"given twice in one mapping (lines {seen[key]} and {line}); YAML would keep "
                                   "the last silently: remove one")
                seen[key] = line
        return super().construct_mapping(node, deep=deep)


def _join_path(path: str, key: Any) -> str:
    key = show_key(key)
    return f"{path}.{key}" if path else key


def _path_to(root: YamlNode | None, target: YamlNode) -> str:
    """The key path of ``target`` in the composed document ``root`` (for a message)."""
    stack: list[tuple[YamlNode, str]] = [(root, "")] if root is not None else []
    seen: set[int] = set()
    while stack:
        node, path = stack.pop()
        if node is target:
            return path
        if id(node) in seen:
            continue
        seen.add(id(node))
        if isinstance(node, MappingNode):
            for key_node, value_node in node.value:
                key = key_node.value if isinstance(key_node, ScalarNode) else "?"
                stack.append((value_node, _join_path(path, key)))
        elif isinstance(node, SequenceNode):
            stack.extend((item, f"{path}[{i}]") for i, item in enumerate(node.value))
    return ""


def _read_text(path: Path) -> str:
    """The file's text: a regular file (a FIFO or a device refused unopened, and the opened
    file checked again: :mod:`sim2real.input_files`) of at most ``MAX_YAML_BYTES``, refused
    unread if larger; UTF-8 without NUL bytes."""
    source = str(path)
    raw = read_regular_bytes(path, source, limit=MAX_YAML_BYTES, what="configuration")
    text = decode_utf8(raw, source, "not a YAML file: binary, or not UTF-8 text")
    if "\0" in text:
        line = text.count("\n", 0, text.index("\0")) + 1
        raise ConfigError(source, "", f"not a YAML file: binary (a NUL byte at line {line})")
    return text


def load_yaml(path: Path | str) -> Any:
    """A YAML file's contents, read with ``yaml.SafeLoader``'s semantics within the bounds of
    the module docstring; every refusal (and every syntax error) is a :class:`ConfigError`
    naming the file."""
    source = str(path)
    text = _read_text(Path(path))
    return parse_yaml(text, source)


def parse_yaml(text: str, source: str) -> Any:
    """YAML text (of at most ``MAX_YAML_BYTES``) to its value, as :func:`load_yaml` reads it."""
    if len(text.encode("utf-8", "surrogatepass")) > MAX_YAML_BYTES:
        raise ConfigError(source, "", f"more than {MAX_YAML_BYTES} bytes is too large for a configuration")
    loader = None
    try:
        loader = _BoundedLoader(text)  # its reader refuses control characters at once
        doc = loader.get_single_data()
    except _Refused as exc:
        raise ConfigError(source, *exc.args) from None
    except yaml.YAMLError as exc:
        raise ConfigError(source, "", f"invalid YAML: {_yaml_problem(exc)}") from None
    except (ValueError, TypeError, OverflowError) as exc:  # a constructor's: e.g. an int of 5,000 digits
        raise ConfigError(source, "", f"invalid YAML: {_cut(str(exc).split(';')[0], 200)}") from None
    except RecursionError:  # not reached within MAX_YAML_DEPTH; the last guard
        raise ConfigError(source, "", f"nested too deep (at most {MAX_YAML_DEPTH} levels)") from None
    finally:
        if loader is not None:
            loader.dispose()
    if doc is None:
        empty = all(not line.strip() or line.lstrip().startswith("#") for line in text.splitlines())
        problem = ("the file is empty (nothing but blank lines and comments)" if empty
                   else "the document is empty (null)")
        raise ConfigError(source, "", f"{problem}: it must hold the settings")
    return doc


def _yaml_problem(exc: yaml.YAMLError) -> str:
    """A YAML error on one line: what, where (line and column), cut short (PyYAML's own
    message spans lines, and may quote a tag or key of any length)."""
    if not isinstance(exc, yaml.MarkedYAMLError):
        return _cut(" ".join(str(exc).split()), 200)
    mark = exc.problem_mark or exc.context_mark
    where = f" (line {mark.line + 1}, column {mark.column + 1})" if mark is not None else ""
    what = "; ".join(_cut(" ".join(part.split()), 120) for part in (exc.context, exc.problem) if part)
    return f"{what}{where}"


def _cut(text: str, n: int) -> str:
    return text if len(text) <= n else text[:n - 3] + "..."


class Node:
    """A value inside a loaded document, with its file and key path for error messages."""

    def __init__(self, value: Any, source: str, path: str = ""):
        self.value = value
        self.source = source
        self.path = path

    def error(self, problem: str, key: str | None = None) -> ConfigError:
        return ConfigError(self.source, self._join(key) if key is not None else self.path, problem)

    def _join(self, key: Any) -> str:
        if isinstance(key, int) and not isinstance(key, bool):
            return f"{self.path}[{key}]"
        return _join_path(self.path, key)

    def _kind(self) -> str:
        return _kind(self.value) if self.path else _document_kind(self.value)

    # -- structure ---------------------------------------------------------------
    def mapping(self, required: Iterable[str] = (), optional: Iterable[str] = ()) -> "Node":
        """Check that this is a mapping with exactly the allowed keys."""
        if not isinstance(self.value, dict):
            raise self.error(f"must be a mapping, got {self._kind()}")
        required, optional = list(required), list(optional)
        allowed = set(required) | set(optional)
        for key in self.value:
            if key not in allowed:
                raise self.error(f"unknown key {show(key)} (allowed: {', '.join(sorted(allowed))})", key=str(key))
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
            raise self.error(f"must be a mapping, got {self._kind()}")
        return self.value

    def items(self) -> list[tuple[str, "Node"]]:
        return [(str(k), self[k]) for k in self.free_mapping()]

    def list(self, min_len: int = 0, max_len: int | None = None) -> list["Node"]:
        if not isinstance(self.value, list):
            raise self.error(f"must be a list, got {self._kind()}")
        if len(self.value) < min_len:
            raise self.error(f"must have at least {min_len} entries")
        if max_len is not None and len(self.value) > max_len:
            raise self.error(f"must have at most {max_len} entries, got {len(self.value)}")
        return [self[i] for i in range(len(self.value))]

    # -- scalars -------------------------------------------------------------------
    def number(self, lo: float | None = None, hi: float | None = None, positive: bool = False,
               unit: str = "", why: str = "") -> float:
        """A finite number (an int or a float, not a boolean) within the bounds given; ``unit``
        (e.g. "m") and ``why`` (e.g. "a plausible segment: 0.002-1.5 m") go into the message of
        a value out of bounds."""
        v = self.value
        if isinstance(v, bool) or not isinstance(v, (int, float)):
            raise self.error(_not_a_number(v, "a number"))
        try:
            v = float(v)
        except OverflowError:  # an integer beyond a float's range
            raise self.error(f"must be a finite number, got an integer of {len(str(self.value))} digits") from None
        if not math.isfinite(v):
            raise self.error(f"must be finite, got {v!r}")
        u, why = (f" {unit}" if unit else ""), (f" ({why})" if why else "")
        if positive and v <= 0:
            raise self.error(f"must be > 0{u}{why}, got {v!r}")
        if lo is not None and v < lo:
            raise self.error(f"must be >= {lo}{u}{why}, got {v!r}")
        if hi is not None and v > hi:
            raise self.error(f"must be <= {hi}{u}{why}, got {v!r}")
        return v

    def integer(self, lo: int | None = None, hi: int | None = None, why: str = "") -> int:
        v = self.value
        if isinstance(v, bool) or not isinstance(v, int):
            raise self.error(_not_a_number(v, "an integer"))
        shown = v if abs(v) < 10**15 else f"an integer of {len(str(abs(v)))} digits"
        why = f" ({why})" if why else ""
        if lo is not None and v < lo:
            raise self.error(f"must be >= {lo}{why}, got {shown}")
        if hi is not None and v > hi:
            raise self.error(f"must be <= {hi}{why}, got {shown}")
        return v

    def string(self, choices: Iterable[str] | None = None) -> str:
        v = self.value
        if not isinstance(v, str) or not v:
            hint = " (YAML reads yes/no/on/off as true/false: quote it)" if isinstance(v, bool) else ""
            raise self.error(f"must be a non-empty string, got {show(v)}{hint}")
        if choices is not None:
            choices = list(choices)
            if v not in choices:
                raise self.error(f"must be one of {', '.join(choices)}; got {show(v)}")
        return v

    def boolean(self) -> bool:
        if not isinstance(self.value, bool):
            raise self.error(f"must be true or false, got {show(self.value)}")
        return self.value

    def pair(self, lo: float | None = None, hi: float | None = None, unit: str = "",
             why: str = "") -> tuple[float, float]:
        """A ``[low, high]`` pair of numbers with low < high, each within [lo, hi]."""
        items = self.list()
        if len(items) != 2:
            raise self.error(f"must be [low, high], got {show(self.value)}")
        low, high = (item.number(lo, hi, unit=unit, why=why) for item in items)
        if not low < high:
            raise self.error(f"low must be below high, got {show(self.value)}")
        return low, high

    def vector(self, n: int, positive: bool = False, lo: float | None = None, hi: float | None = None,
               unit: str = "", why: str = "") -> tuple[float, ...]:
        items = self.list()
        if len(items) != n:
            raise self.error(f"must have {n} numbers, got {show(self.value)}")
        return tuple(item.number(lo, hi, positive=positive, unit=unit, why=why) for item in items)


def _document_kind(value: Any) -> str:
    """What a whole document is instead of a mapping: its type only - a file that is not a
    configuration at all (a path read from somewhere: ``/etc/hostname``) is never echoed."""
    noun = type(value).__name__
    return f"{'an' if noun[:1] in 'aeiou' else 'a'} {noun}: is it the right file?"


def _kind(value: Any) -> str:
    """What a value is, for "must be a mapping, got ..." (its type; a short value itself)."""
    return type(value).__name__ if isinstance(value, (dict, list)) else f"{type(value).__name__} {show(value)}"


def dataclass_from_mapping(cls: type, values: Any, source: str, prefix: str, what: str) -> Any:
    """Build a frozen config dataclass from a YAML mapping, checking each value against its
    field's default type; unknown keys and wrong types raise :class:`ConfigError`."""
    import dataclasses

    if values is None:
        values = {}
    if not isinstance(values, dict):
        got = _kind(values) if prefix else _document_kind(values)
        raise ConfigError(source, prefix.rstrip("."), f"must be a mapping, got {got}")
    fields = {f.name: f for f in dataclasses.fields(cls)}
    kwargs: dict[str, Any] = {}
    for key, value in values.items():
        where = f"{prefix}{show_key(key)}"
        if key not in fields:
            raise ConfigError(source, where, f"unknown {what} parameter {show(key)}")
        default = fields[key].default
        if isinstance(default, bool):
            ok = isinstance(value, bool)
        elif isinstance(default, int):
            ok = isinstance(value, int) and not isinstance(value, bool)
        elif isinstance(default, float):
            ok = isinstance(value, (int, float)) and not isinstance(value, bool)
            if ok:
                try:
                    value = float(value)
                except OverflowError:
                    raise ConfigError(source, where, "must be a finite number, got an integer of "
                                      f"{len(str(value))} digits") from None
                if not math.isfinite(value):
                    raise ConfigError(source, where, f"must be finite, got {value!r}")
        else:
            ok = isinstance(value, str) and bool(value)
        if not ok:
            kind = ("true or false" if isinstance(default, bool) else "an integer" if isinstance(default, int)
                    else "a number" if isinstance(default, float) else "a non-empty string")
            problem = (_not_a_number(value, kind) if kind in ("an integer", "a number")
                       else f"must be {kind}, got {show(value)}")
            raise ConfigError(source, where, problem)
        kwargs[key] = value
    return cls(**kwargs)

"""A model file's XML tree walked, and every file it names checked, before MuJoCo opens any.

    doc = parse_model_xml(text, "robot.xml")       # bounded depth, no DTD: ConfigError otherwise
    check_model_files(doc, "mjcf", package_dirs)    # includes, assets, counts, numbers

MuJoCo's parser opens an MJCF's ``<include>`` files while it parses, and its meshes,
textures, skins and height fields while it compiles, all itself: a named pipe there blocks it
for ever, a device never ends, a directory or a symlink loop gives a raw error.  So this module
reads the tree first, with the project's bounded reader, and refuses with the file, the line
and the element named:

* every file named (``<include file>``, ``<model file>``, any MJCF ``file*`` attribute, a
  URDF's ``<mesh filename>``) that exists but is not a regular file, is larger than
  ``MAX_ASSET_BYTES``, or lies outside the folders a model's files may come from; a missing
  include, texture, skin or height field, with a near match (``.STL`` for ``.stl``) named;
  missing meshes are left to :mod:`.files`, which lists them all at once;
* includes deeper than ``MAX_INCLUDE_DEPTH`` or in a cycle; XML nested deeper than
  ``MAX_XML_DEPTH`` (the standard library's writer and walks recurse); a DTD (entity
  expansion is how XML bombs grow);
* more bodies, joints or geoms than a robot has, counting what ``<replicate>``,
  ``<composite>`` and ``<flexcomp>`` expand to (MuJoCo would compile a million bodies slowly
  and our checks are quadratic in them);
* NaN or infinity in a numeric attribute (MuJoCo only warns), and a joint axis of length 0.

Where MuJoCo 4.0.0 looks for a file (checked by experiment): a relative ``<include file>`` in
the main file's folder, then in the including file's folder; an asset's ``file`` in the main
file's folder joined with ``meshdir`` (meshes, skins, height fields) or ``texturedir``
(textures), each falling back to ``assetdir``, then in the folder of the file that names it;
``strippath`` drops the folders of the name first.  Every place that exists is checked.
"""

from __future__ import annotations

import math
import os
import xml.etree.ElementTree as ET
from dataclasses import dataclass, field
from pathlib import Path
from typing import Iterable, Iterator
from xml.parsers import expat

from sim2real.errors import ConfigError
from sim2real.input_files import kind_problem, read_regular_bytes

# Bounds, each far above any real robot and far below what hangs or exhausts the tool.
MAX_MODEL_BYTES = 16 << 20  # an XML model file or include; large URDFs (Talos, Atlas) are < 1 MB
MAX_ASSET_BYTES = 64 << 20  # a mesh, texture, skin or height field: real CAD meshes are tens of MB at most
MAX_TOTAL_BYTES = 512 << 20  # every file of a model together (Menagerie's largest robots: ~100 MB)
MAX_XML_DEPTH = 200  # an MJCF nests a body per link: a humanoid's finger tip is ~20 deep, a 50-link snake ~55
MAX_INCLUDE_DEPTH = 8  # Menagerie's scene.xml includes the robot: depth 1
MAX_INCLUDES = 100  # <include> elements in all: a model split by part has a dozen
MAX_ELEMENTS = 100_000  # XML elements in all: a large humanoid MJCF holds a few thousand
MAX_JOINTS = 200  # OP3 has 20 hinges, the largest humanoids with hands ~60-70
MAX_BODIES = 500  # a body per joint, plus a URDF's fixed sensor and tool frames
MAX_GEOMS = 5000  # convex decompositions give tens of collision pieces per link
PSEUDO_FILESYSTEMS = (Path("/proc"), Path("/sys"))  # their "regular" files are the kernel's, no model's

# MJCF and URDF attributes that hold names, paths or words, never numbers: "nan" or "inf" is a
# fine name for a body there.  Every other attribute that parses as numbers is checked.
_WORD_ATTRIBUTES = frozenset({
    "name", "class", "childclass", "prefix", "suffix", "content_type", "mesh", "material", "texture",
    "hfield", "skin", "joint", "joint1", "joint2", "jointinparent", "body", "body1", "body2", "site",
    "site1", "site2", "geom", "geom1", "geom2", "tendon", "tendon1", "tendon2", "actuator", "target",
    "objname", "refname", "cranksite", "slidersite", "plugin", "instance", "model",
    "namespace", "link", "reference", "filename", "modelname"})
_WORD_ELEMENTS = frozenset({"text", "config"})  # <custom><text data>, a plugin's <config key value>: words
_ASSET_DIR = {"texture": "texturedir"}  # other MJCF assets (mesh, skin, hfield, flexcomp) use meshdir
_EXPANDING = {"replicate": "count", "composite": "count", "flexcomp": "count"}


@dataclass(frozen=True)
class XmlDocument:
    """A parsed XML file and the line each element starts on (keyed by the element itself)."""

    path: Path
    root: ET.Element
    lines: dict[ET.Element, int] = field(repr=False)


class _Refused(Exception):
    pass


def parse_model_xml(text: str, path: Path | str, max_depth: int = MAX_XML_DEPTH) -> XmlDocument:
    """``text`` as a tree, or :class:`ConfigError` naming ``path``: not XML, a DTD or entity
    declaration, nesting deeper than ``max_depth``, more than ``MAX_ELEMENTS`` elements.
    Built without recursion, so no depth can raise RecursionError here."""
    source = str(path)
    parser = expat.ParserCreate()
    lines: dict[ET.Element, int] = {}
    stack: list[ET.Element] = []
    top: list[ET.Element] = []

    def start(tag: str, attrs: dict[str, str]) -> None:
        if len(stack) >= max_depth:
            raise _Refused(f"line {parser.CurrentLineNumber}: XML nested more than {max_depth} elements deep "
                           "(no robot model is; a body per link makes a humanoid ~20 deep)")
        if len(lines) >= MAX_ELEMENTS:
            raise _Refused(f"more than {MAX_ELEMENTS} XML elements (a large humanoid has a few thousand)")
        element = ET.SubElement(stack[-1], tag, attrs) if stack else ET.Element(tag, attrs)
        lines[element] = parser.CurrentLineNumber
        if not stack:
            top.append(element)
        stack.append(element)

    def doctype(*_args) -> None:  # before any entity is declared, let alone expanded
        raise _Refused(f"line {parser.CurrentLineNumber}: a DTD (<!DOCTYPE>) is not accepted in a model file: "
                       "no robot model needs one, and entity expansion in it is how XML bombs grow")

    parser.StartElementHandler = start
    parser.EndElementHandler = lambda _tag: stack.pop()
    parser.StartDoctypeDeclHandler = doctype
    parser.EntityDeclHandler = doctype
    try:
        parser.Parse(text, True)
    except _Refused as exc:
        raise ConfigError(source, "", str(exc)) from None
    except expat.ExpatError as exc:
        raise ConfigError(source, "", f"not an XML model file: {expat.ErrorString(exc.code)}: line {exc.lineno}, "
                          f"column {exc.offset}") from None
    return XmlDocument(Path(path), top[0], lines)


def check_model_files(doc: XmlDocument, kind: str, package_dirs: Iterable[Path] = ()) -> None:
    """Walk the model ``doc`` (``"mjcf"`` or ``"urdf"``) and its includes; :class:`ConfigError`
    naming the model file, the line and the element for anything MuJoCo must not be given."""
    walk = _Walk(doc, [Path(d) for d in package_dirs])
    if kind == "urdf":
        walk.urdf()
    else:
        walk.mjcf(doc, (doc.path.resolve(),), doc.path.resolve().parent)
    walk.check_counts()


def near_match(path: Path) -> Path | None:
    """A file beside ``path`` whose name differs only in case, or in its extension
    (``thigh.STL``, ``thigh.obj`` for ``thigh.stl``), or None; a folder that differs in case
    is followed too.  Looks at no more than 10,000 names a folder."""
    folder = path.parent
    if not folder.is_dir():
        found = near_match(folder) if folder != folder.parent else None
        if found is None or not found.is_dir():
            return None
        folder = found
    name, stem = path.name.lower(), path.stem.lower()
    best = None
    try:
        with os.scandir(folder) as entries:
            for _, entry in zip(range(10_000), entries):
                lower = entry.name.lower()
                if lower == name and entry.name != path.name:
                    return folder / entry.name
                if best is None and Path(lower).stem == stem and lower != name:
                    best = folder / entry.name
    except OSError:
        return None
    return best


# -- the walk --------------------------------------------------------------------------------
@dataclass
class _Place:
    """Where an element sits: its file, its depth, how often ``<replicate>``/``<composite>``
    repeat it, and the nearest named element around it (to name an unnamed one)."""

    doc: XmlDocument
    depth: int
    times: int
    around: str
    section: str  # the top-level MJCF section it is in: worldbody, default, asset, ...
    chain: tuple[Path, ...] = ()  # real paths of the files that include (or attach) its file, its own last


class _Walk:
    def __init__(self, doc: XmlDocument, package_dirs: list[Path]):
        self.top = doc
        self.model_dir = doc.path.resolve().parent
        self.package_dirs = package_dirs
        # a model's files come from its folder or the one above (ROS: pkg/urdf + pkg/meshes;
        # converters: robot/mjcf + robot/meshes), or from a package folder the user names
        self.roots = [self.model_dir, self.model_dir.parent, *(Path(os.path.realpath(d)) for d in package_dirs)]
        self.total_bytes = 0
        self.includes = 0
        self.bodies = self.joints = self.geoms = 0
        self.compiler: dict[str, str] = {}

    # -- MJCF --
    def mjcf(self, doc: XmlDocument, chain: tuple[Path, ...], model_dir: Path) -> None:
        elements = list(self._mjcf_elements(doc, chain, model_dir))  # includes read and checked
        for element, _place in elements:
            if element.tag == "compiler":  # MuJoCo reads every <compiler> first; the last setting holds
                self.compiler.update({k: v for k, v in element.attrib.items() if k.endswith("dir")
                                      or k == "strippath"})
        for element, place in elements:
            self._numbers(element, place)
            if element.tag == "include":
                continue
            for attr, value in element.attrib.items():
                if attr.startswith("file") and value:
                    self._asset(element, place, attr, value, model_dir)
            if place.section == "worldbody":
                self._count(element, place)
            elif element.tag == "joint" and place.section == "default":
                self._axis(element, place, "axis")

    def _mjcf_elements(self, doc: XmlDocument, chain: tuple[Path, ...], model_dir: Path
                       ) -> Iterator[tuple[ET.Element, _Place]]:
        """Each element of ``doc`` in document order, an include's content in its place."""
        stack = [(child, _Place(doc, 1, 1, "", child.tag, chain)) for child in reversed(list(doc.root))]
        while stack:
            element, place = stack.pop()
            if place.depth > MAX_XML_DEPTH:
                self._refuse(element, place, f"XML nested more than {MAX_XML_DEPTH} elements deep, counting includes")
            yield element, place
            if element.tag == "include":  # its file's content takes its place, at its depth
                included = self._include(element, place, model_dir)
                inner = (*place.chain, Path(os.path.realpath(included.path)))
                stack += [(child, _Place(included, place.depth, place.times, place.around,
                                         child.tag if place.depth == 1 else place.section, inner))
                          for child in reversed(list(included.root))]
                continue
            times = place.times * _repeats(element, self, place)
            name = element.get("name")
            around = f"<{element.tag} name={_short(name, 40)!r}>" if name else place.around
            stack += [(child, _Place(place.doc, place.depth + 1, times, around, place.section, place.chain))
                      for child in reversed(list(element))]

    def _include(self, element: ET.Element, place: _Place, model_dir: Path) -> XmlDocument:
        self.includes += 1
        if self.includes > MAX_INCLUDES:
            self._refuse(element, place, f"more than {MAX_INCLUDES} <include> elements (a model split by part has "
                         "a dozen)")
        if len(place.chain) > MAX_INCLUDE_DEPTH:
            self._refuse(element, place, f"includes nested more than {MAX_INCLUDE_DEPTH} deep")
        file = element.get("file")
        if not file:
            return XmlDocument(place.doc.path, ET.Element("mujoco"), {})  # MuJoCo says what is missing
        path = self._existing(element, place, "file", file, [model_dir / file, place.doc.path.parent / file],
                              MAX_MODEL_BYTES, missing_is_error=True)
        included = self._read_xml(element, place, path)
        if included.root.tag != "mujoco":
            self._refuse(element, place, f"{self._show(path)} is no MJCF: its root element is "
                         f"<{str(included.root.tag)[:40]}>, not <mujoco>")
        return included

    def _read_xml(self, element: ET.Element, place: _Place, path: Path) -> XmlDocument:
        """The XML file ``path`` that ``element`` names, parsed; refused when it is one that
        ``element``'s own file comes from (a cycle)."""
        real = Path(os.path.realpath(path))
        if real in place.chain:
            loop = " -> ".join(self._show(p) for p in (*place.chain[place.chain.index(real):], real))
            self._refuse(element, place, f"a cycle of includes: {loop}")
        try:
            raw = read_regular_bytes(path, str(path), limit=MAX_MODEL_BYTES, what="model file")
            text = raw.decode("utf-8-sig")
            return parse_model_xml(text, path)
        except UnicodeDecodeError:
            self._refuse(element, place, f"{self._show(path)} is not XML text (binary, or not UTF-8)")
        except ConfigError as exc:  # named from the model the user gave, through this element
            self._refuse(element, place, f"{self._show(path)}: {exc.problem}")

    def _asset(self, element: ET.Element, place: _Place, attr: str, value: str, model_dir: Path) -> None:
        """A file an MJCF element names: checked where MuJoCo would open it."""
        name = Path(value).name if self.compiler.get("strippath") == "true" else value
        if element.tag == "model":  # another MJCF: walked as a model of its own
            candidates = [model_dir / name, place.doc.path.parent / name]
            path = self._existing(element, place, attr, value, candidates, MAX_MODEL_BYTES, missing_is_error=True)
            self._model(element, place, path)
            return
        folder = self.compiler.get(_ASSET_DIR.get(element.tag, "meshdir")) or self.compiler.get("assetdir", "")
        candidates = [Path(name)] if Path(name).is_absolute() else [model_dir / folder / name,
                                                                     place.doc.path.parent / name]
        self._existing(element, place, attr, value, candidates, MAX_ASSET_BYTES,
                       missing_is_error=element.tag != "mesh")  # missing meshes: files.py lists them all

    def _model(self, element: ET.Element, place: _Place, path: Path) -> None:
        if len(place.chain) > MAX_INCLUDE_DEPTH:
            self._refuse(element, place, f"models and includes nested more than {MAX_INCLUDE_DEPTH} deep")
        sub = self._read_xml(element, place, path)
        real = Path(os.path.realpath(path))
        inner = _Walk(sub, self.package_dirs)
        inner.total_bytes, inner.includes, inner.roots = self.total_bytes, self.includes, self.roots
        inner.top, inner.model_dir = self.top, self.model_dir  # refusals name the user's file
        inner.mjcf(sub, (*place.chain, real), real.parent)
        self.total_bytes, self.includes = inner.total_bytes, inner.includes
        # attached once per <attach>, or not at all: counted once, the common case
        self.bodies += inner.bodies * place.times
        self.joints += inner.joints * place.times
        self.geoms += inner.geoms * place.times

    def _count(self, element: ET.Element, place: _Place) -> None:
        tag = element.tag
        if tag == "body":
            self.bodies += place.times
        elif tag in ("joint", "freejoint"):
            self.joints += place.times
            self._axis(element, place, "axis")
        elif tag == "geom":
            self.geoms += place.times
        elif tag in ("composite", "flexcomp"):
            made = place.times * _repeats(element, self, place)
            self.bodies += made
            self.geoms += made

    # -- URDF --
    def urdf(self) -> None:
        doc = self.top
        compiler = doc.root.find("mujoco/compiler")
        if compiler is not None:
            self.compiler.update(compiler.attrib)
        strip = self.compiler.get("strippath") == "true"
        folder = self.compiler.get("meshdir") or self.compiler.get("assetdir", "")
        stack = [(child, _Place(doc, 1, 1, "", child.tag)) for child in reversed(list(doc.root))]
        while stack:
            element, place = stack.pop()
            self._numbers(element, place)
            if place.depth == 1 and element.tag == "link":
                self.bodies += 1
            elif place.depth == 1 and element.tag == "joint":
                self.joints += 1
                axis = element.find("axis")
                if axis is not None:
                    self._axis(axis, _Place(doc, 2, 1, f"<joint name={element.get('name')!r}>", "joint"), "xyz")
            elif place.depth == 2 and element.tag in ("visual", "collision"):
                self.geoms += 1
            elif element.tag == "mesh" and element.get("filename"):
                self._existing(element, place, "filename", element.get("filename"),
                               mesh_candidates(element.get("filename"), self.model_dir, folder, strip,
                                                self.package_dirs), MAX_ASSET_BYTES, missing_is_error=False)
            name = element.get("name")
            around = f"<{element.tag} name={name!r}>" if name else place.around
            stack += [(child, _Place(doc, place.depth + 1, 1, around, place.section))
                      for child in reversed(list(element))]

    # -- the checks --
    def _existing(self, element: ET.Element, place: _Place, attr: str, value: str, candidates: list[Path],
                  limit: int, missing_is_error: bool) -> Path | None:
        """The first of ``candidates`` that exists, checked; every other that exists checked
        too (MuJoCo opens the first it can).  None when none exists and that is allowed."""
        found = None
        for path in candidates:
            if not os.path.lexists(path):
                continue
            try:
                st = os.stat(path)
            except FileNotFoundError:
                continue  # a dangling symlink: as missing
            except OSError as exc:
                self._refuse(element, place, f'{attr}="{_short(value)}": {self._show(path)} cannot be read: '
                             f"{exc.strerror or exc}")
            problem = kind_problem(st.st_mode)
            if problem is not None:
                self._refuse(element, place, f'{attr}="{_short(value)}": {self._show(path)} {problem}')
            real = Path(os.path.realpath(path))
            if any(real == p or p in real.parents for p in PSEUDO_FILESYSTEMS) or not any(
                    real == r or r in real.parents for r in self.roots):
                self._refuse(element, place, f'{attr}="{_short(value)}": {self._show(path)} is outside the folders a '
                             f"model's files may come from ({', '.join(str(r) for r in self.roots)}): move it beside "
                             "the model, or name its folder with --package-dir (model.package_dirs in a robot YAML)")
            if st.st_size > limit:
                self._refuse(element, place, f'{attr}="{_short(value)}": {self._show(path)} has {st.st_size} bytes, '
                             f"more than the {limit >> 20} MB a model's file may have")
            self.total_bytes += st.st_size
            if self.total_bytes > MAX_TOTAL_BYTES:
                self._refuse(element, place, f"the model's files hold more than {MAX_TOTAL_BYTES >> 20} MB together")
            found = found or path
        if found is None and missing_is_error:
            tried = ", ".join(self._show(p) for p in dict.fromkeys(candidates))
            near = next((m for m in map(near_match, candidates) if m is not None), None)
            hint = f"; there is {self._show(near)} (names differ in case or extension)" if near else ""
            self._refuse(element, place, f'{attr}="{_short(value)}": not found (looked for {tried}){hint}')
        return found

    def _numbers(self, element: ET.Element, place: _Place) -> None:
        if element.tag in _WORD_ELEMENTS:
            return
        for attr, value in element.attrib.items():
            if attr in _WORD_ATTRIBUTES or attr.startswith("file") or attr.endswith("dir"):
                continue
            bad = next((t for t in value.split() if not math.isfinite(_number(t))), None)
            if bad is not None:
                what = "NaN" if math.isnan(_number(bad)) else "infinite"
                self._refuse(element, place, f"{attr} holds {_short(bad, 20)!r}: {what}, not a number a model "
                             "can hold")

    def _axis(self, element: ET.Element, place: _Place, attr: str) -> None:
        values = [_number(t) for t in element.get(attr, "").split()]
        if len(values) == 3 and all(v == 0.0 for v in values):
            self._refuse(element, place, f'{attr}="{element.get(attr)}": a joint axis of length 0 has no direction')

    def check_counts(self) -> None:
        for count, limit, what, why in (
                (self.joints, MAX_JOINTS, "joints", "OP3 has 20, the largest humanoids with hands ~60-70"),
                (self.bodies, MAX_BODIES, "bodies", "a body per joint and some fixed frames"),
                (self.geoms, MAX_GEOMS, "geoms", "a few dozen collision pieces per link")):
            if count > limit:
                raise ConfigError(str(self.top.path), "", f"{count} {what} (counting what <replicate>, <composite> "
                                  f"and <flexcomp> make), more than the {limit} a robot model may have ({why})")

    def _refuse(self, element: ET.Element, place: _Place, problem: str):
        line = place.doc.lines.get(element)
        where = "" if place.doc is self.top else f"{self._show(place.doc.path)} "
        where += f"line {line}: " if line else ""
        name = element.get("name")
        this = f"<{element.tag} name={_short(name, 40)!r}>" if name else f"<{element.tag}>"
        if not name and place.around:
            this += f" in {place.around}"
        raise ConfigError(str(self.top.path), "", f"{where}{this}: {problem}")

    def _show(self, path: Path) -> str:
        """``path`` relative to the model's folder when inside it."""
        absolute = Path(os.path.abspath(path))
        return str(absolute.relative_to(self.model_dir)) if self.model_dir in absolute.parents else str(path)


def _repeats(element: ET.Element, walk: _Walk, place: _Place) -> int:
    """How many copies of its content a ``<replicate>``, ``<composite>`` or ``<flexcomp>`` makes."""
    attr = _EXPANDING.get(element.tag)
    if attr is None or attr not in element.attrib:
        return 1
    product = 1
    for token in element.get(attr, "").split():
        value = _number(token)
        if not math.isfinite(value):
            walk._refuse(element, place, f"{attr} holds {_short(token, 20)!r}, not a count")
        product *= max(1, int(min(value, 1e12)))
        product = min(product, 10**15)
    return product


def mesh_candidates(file: str, folder: Path, meshdir: Path | str, strippath: bool, dirs: list[Path]) -> list[Path]:
    """Where a mesh file is looked for: a ``package://`` path in each package folder ``dirs``
    (as ``PKG/rest`` and as ``rest``), an absolute path as itself, anything else in
    ``folder / meshdir`` (MuJoCo's rule for MJCF and for URDF alike; ``strippath`` keeps the
    file name only)."""
    if file.startswith("package://"):
        package, _, rest = file[len("package://"):].partition("/")
        return [c for d in dirs for c in (d / package / rest, d / rest)]
    if file.startswith("file://"):
        file = file[len("file://"):]
    name = Path(file).name if strippath else file
    return [Path(name)] if Path(name).is_absolute() else [folder / meshdir / name]


def _number(token: str) -> float:
    """``token`` as MuJoCo's ``strtod`` reads it (hex floats too), or 0.0 when it is no number."""
    try:
        return float(token)
    except ValueError:
        try:
            return float.fromhex(token)
        except OverflowError:  # strtod reads it as infinite
            return -math.inf if token.startswith("-") else math.inf
        except ValueError:
            return 0.0


def _short(text: str, limit: int = 80) -> str:
    return text if len(text) <= limit else text[:limit] + "..."

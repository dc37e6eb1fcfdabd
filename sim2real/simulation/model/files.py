"""A user's robot model file (MJCF or URDF) read into a MuJoCo ``MjSpec``, or refused clearly.

    spec = load_model_spec("robot.urdf", package_dirs=["~/ws/src"])   # ConfigError naming the file
    root = add_free_joint(spec)         # the URDF's base floats: before any compile (see below)
    model = compile_model(spec, "robot.urdf")                          # compiles a copy

The format is told by the root element (``<mujoco>`` or ``<robot>``), not by the name.  Before
MuJoCo sees it the file is read through the project's bounded reader (a regular file of at
most ``MAX_MODEL_BYTES``) and refused, with the file named and what to do:

* un-expanded xacro (a ``.xacro`` name, the xacro namespace or ``<xacro:`` elements, or
  ``$(find ...)`` / ``${...}`` left in attributes), with how to expand it;
* text that is not XML, XML entities, a root element that is no robot;
* mesh files that are missing or unreadable: every one at once, each with where it was looked
  for, and for ``package://PKG/PATH`` how to name the package root (``--package-dir DIR``:
  tried as ``DIR/PKG/PATH`` and ``DIR/PATH``);
* a model without one hinge joint (nothing a servo could turn);
* anything :mod:`.guard` refuses before MuJoCo opens a file: includes, textures, skins,
  height fields and meshes that are no regular files (a FIFO would block MuJoCo), too large or
  outside the model's folders; include cycles; deep nesting; more bodies, joints or geoms than a
  robot has; NaN or infinity in a number; a joint axis of length 0.

URDF in MuJoCo 4.0.0 (checked by experiment): visuals are discarded at parse unless the file
says otherwise, so they are kept here by turning ``discardvisual`` off in the text MuJoCo
parses (``drop_visuals=True`` leaves MuJoCo's default); ``package://`` paths are kept verbatim,
so each mesh path is resolved here and set absolute.  The base link hangs fixed under the
world, and ``compile`` runs ``fusestatic`` *on the spec itself*: a base without joints is
fused into the world, and its children then hang from the worldbody.  So
:func:`add_free_joint` must come before any compile, and :func:`compile_model` compiles a copy.

Checks of what the model holds live beside this module: :mod:`.inertias` (implausible
inertias, recomputed from the collision geometry) and :mod:`.importing.mirror` (left/right pairs
from geometry).
"""

from __future__ import annotations

import re
import xml.etree.ElementTree as ET
from dataclasses import dataclass, field
from pathlib import Path
from typing import Iterable

import mujoco

from sim2real.errors import ConfigError
from sim2real.input_files import read_regular_bytes, regular_file_problem
from sim2real.simulation.model.guard import (
    MAX_MODEL_BYTES,
    XmlDocument,
    check_model_files,
    mesh_candidates,
    near_match,
    parse_model_xml,
)
from sim2real.simulation.model.body_roles import check_unique_names
from sim2real.simulation.model.robot_model import is_collision_geom

XACRO_NAMESPACE = "http://www.ros.org/wiki/xacro"
_SUBSTITUTION = re.compile(r"\$\((?:find|arg|env|optenv|eval|dirname|anon)\b[^)]*\)|\$\{[^}]*\}")
HINGE = mujoco.mjtJoint.mjJNT_HINGE
FREE = mujoco.mjtJoint.mjJNT_FREE


def model_format(path: Path | str) -> str:
    """``"mjcf"`` or ``"urdf"``: the kind of model file ``path`` is, told by its root element."""
    return _read_model_xml(Path(path))[1]


def load_model_spec(path: Path | str, package_dirs: Iterable[Path | str] = (), *,
                    drop_visuals: bool = False) -> mujoco.MjSpec:
    """The model in ``path`` (MJCF or URDF) as an uncompiled spec, every mesh file found.

    ``package_dirs``: folders to find ``package://PKG/PATH`` meshes in (as ``DIR/PKG/PATH``,
    then ``DIR/PATH``).  ``drop_visuals``: delete the geoms that only show (contype and
    conaffinity 0; for a URDF, its ``<visual>`` elements) and the meshes only they use, so a
    missing visual mesh does not matter.  A URDF's base stays fixed to the world: see
    :func:`add_free_joint`.  Every refusal is a :class:`ConfigError` naming the file."""
    spec, problems = _load(Path(path), package_dirs, drop_visuals)
    if problems:
        raise ConfigError(str(path), "", problems.message())
    check_unique_names(spec, path)
    if not any(j.type == HINGE for j in spec.joints):
        raise ConfigError(str(path), "", "the model has no hinge (revolute) joint: nothing a servo could turn")
    return spec


def missing_meshes(path: Path | str, package_dirs: Iterable[Path | str] = (), *,
                   drop_visuals: bool = False) -> list[str]:
    """Every mesh file of the model that is missing or unreadable, one line each (with where
    it was looked for), without refusing: what :func:`load_model_spec` would list."""
    return list(_load(Path(path), package_dirs, drop_visuals)[1].lines)


def _load(path: Path, package_dirs: Iterable[Path | str], drop_visuals: bool) -> tuple[mujoco.MjSpec, "_MeshProblems"]:
    source = str(path)
    doc, kind = _read_model_xml(path)
    dirs = [Path(d).expanduser() for d in package_dirs]
    check_model_files(doc, kind, dirs)  # before MuJoCo opens any file the model names
    if kind == "urdf":
        spec = _parse(source, lambda: mujoco.MjSpec.from_string(_urdf_text(doc.root, keep_visuals=not drop_visuals)))
        spec.modelfiledir = str(path.resolve().parent) + "/"  # from_string has no folder of its own
    else:
        spec = _parse(source, lambda: mujoco.MjSpec.from_file(str(path)))
        if drop_visuals:
            _drop_visual_geoms(spec)
    return spec, _resolve_meshes(spec, kind, path.resolve().parent, dirs)


def root_body(spec: mujoco.MjSpec) -> str:
    """The body that floats: the one with a free joint, else the one body under the world
    (a URDF's base link).  :class:`ConfigError` when neither is unique."""
    free = [j.parent.name for j in spec.joints if j.type == FREE]
    if len(free) == 1:
        return free[0]
    if len(free) > 1:
        raise ConfigError(_name(spec), "", f"{len(free)} bodies float (free joints on {', '.join(free)}): "
                          "a robot has one")
    top = [b.name for b in spec.worldbody.bodies]
    if len(top) != 1:
        raise ConfigError(_name(spec), "", f"{len(top)} bodies hang from the world ({', '.join(top) or 'none'}) "
                          "and none has a free joint: which is the robot's root?")
    return top[0]


def add_free_joint(spec: mujoco.MjSpec, body: str | None = None) -> str:
    """A free joint on ``body`` (default :func:`root_body`), unless it has one; its name.

    Call it before compiling ``spec``: a compile fuses a jointless base into the world and
    the body is gone (``mujoco.MjSpec.compile`` changes the spec it compiles)."""
    name = body or root_body(spec)
    found = spec.body(name)
    if found is None:
        raise ConfigError(_name(spec), "", f"no body {name!r}: was the spec compiled already? (compiling fuses "
                          "a jointless URDF base into the world; add the free joint first)")
    if any(j.type == FREE for j in found.joints):
        return name
    if found.parent is None or found.parent.name != "world":
        raise ConfigError(_name(spec), "", f"body {name!r} does not hang from the world: only a root body can float")
    if len(found.joints):
        kinds = ", ".join(str(j.type).split("_")[-1].lower() for j in found.joints)
        raise ConfigError(_name(spec), "", f"root body {name!r} already moves on joints ({kinds}): "
                          "a free joint would duplicate them")
    found.add_freejoint()
    return name


def compile_model(spec: mujoco.MjSpec, source: str | None = None) -> mujoco.MjModel:
    """``spec`` compiled, from a copy (a compile fuses static bodies in the spec it is given);
    MuJoCo's refusal as a :class:`ConfigError` naming ``source``."""
    try:
        return spec.copy().compile()
    except ValueError as exc:
        raise ConfigError(source or _name(spec), "", f"MuJoCo cannot compile the model: {_one_line(exc)}") from None


# -- reading the file -------------------------------------------------------------------------
def _read_model_xml(path: Path) -> tuple[XmlDocument, str]:
    source = str(path)
    raw = read_regular_bytes(path, source, limit=MAX_MODEL_BYTES, what="model file")
    try:
        text = raw.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        raise ConfigError(source, "", f"not an XML model file: binary, or not UTF-8 text (byte "
                          f"0x{raw[exc.start]:02x} at offset {exc.start})") from None
    if not text.strip():
        raise ConfigError(source, "", "the file is empty: it must hold an MJCF or URDF model")
    xacro = _xacro_sign(path, text)
    if xacro:
        raise ConfigError(source, "", _xacro_problem(path, xacro))
    if "<!ENTITY" in text:  # no robot needs them; expansion is how XML bombs work
        raise ConfigError(source, "", "XML entity declarations (<!ENTITY) are not accepted in a model file")
    doc = parse_model_xml(text, path)  # bounded depth, no DTD
    root = doc.root
    subst = next((m.group(0) for el in root.iter() for v in el.attrib.values() if (m := _SUBSTITUTION.search(v))), None)
    if subst:
        raise ConfigError(source, "", _xacro_problem(path, f"the substitution {subst[:60]!r}"))
    kind = {"mujoco": "mjcf", "robot": "urdf"}.get(root.tag)
    if kind is None:
        hint = " (SDF is not read: convert it to URDF or MJCF)" if root.tag == "sdf" else ""
        raise ConfigError(source, "", f"not a robot model: the root element is <{str(root.tag)[:40]}>, not "
                          f"<mujoco> (MJCF) or <robot> (URDF){hint}")
    return doc, kind


def _xacro_sign(path: Path, text: str) -> str | None:
    if path.name.lower().endswith(".xacro"):
        return "its name ends in .xacro"
    # what a comment holds is not the model (expanded xacro keeps commented-out properties)
    text = re.sub(r"<!--.*?-->", "", text, flags=re.DOTALL)
    if "xmlns:xacro" in text or XACRO_NAMESPACE in text:
        return "it declares the xacro namespace"
    if "<xacro:" in text:
        return "it holds <xacro:...> elements"
    return None


def _xacro_problem(path: Path, sign: str) -> str:
    stem = path.name[: -len(".xacro")] if path.name.lower().endswith(".xacro") else path.stem
    out = stem if stem.lower().endswith(".urdf") else f"{stem}.urdf"
    return (f"an un-expanded xacro file ({sign}): expand it to plain URDF first, with ROS: "
            f"`xacro {path.name} > {out}`; without ROS: `pip install xacrodoc` then "
            f"`xacrodoc {path.name} -o {out}` (add `-d DIR` for each folder holding its packages)")


def _urdf_text(root: ET.Element, keep_visuals: bool) -> str:
    """The URDF as MuJoCo should parse it: its ``<mujoco><compiler discardvisual>`` set as
    asked, whatever the file says (MuJoCo discards a URDF's visuals at parse by default)."""
    ext = root.find("mujoco")
    if ext is None:
        ext = ET.SubElement(root, "mujoco")
    compiler = ext.find("compiler")
    if compiler is None:
        compiler = ET.SubElement(ext, "compiler")
    compiler.set("discardvisual", "false" if keep_visuals else "true")
    return ET.tostring(root, encoding="unicode")


def _parse(source: str, parse) -> mujoco.MjSpec:
    try:
        return parse()
    except ValueError as exc:
        raise ConfigError(source, "", f"MuJoCo cannot read the model: {_one_line(exc)}") from None


def _drop_visual_geoms(spec: mujoco.MjSpec) -> None:
    for geom in list(spec.geoms):
        if not is_collision_geom(geom.contype, geom.conaffinity):
            spec.delete(geom)
    used = {g.meshname for g in spec.geoms if g.type == mujoco.mjtGeom.mjGEOM_MESH}
    for mesh in list(spec.meshes):
        if mesh.name not in used:
            spec.delete(mesh)


# -- mesh files ------------------------------------------------------------------------------
@dataclass
class _MeshProblems:
    lines: list[str] = field(default_factory=list)  # one per mesh file
    packages: set[str] = field(default_factory=set)  # package names of package:// paths not found
    folder: Path = Path()

    def __bool__(self) -> bool:
        return bool(self.lines)

    def message(self) -> str:
        n = len(self.lines)
        text = f"{n} mesh file{'s are' if n > 1 else ' is'} missing or unreadable:" + "".join(
            f"\n  - {line}" for line in self.lines)
        if self.packages:
            text += (f"\n  package://PKG/PATH is looked for as DIR/PKG/PATH and DIR/PATH for each "
                     f"--package-dir DIR: give the folder that holds the package folder "
                     f"{', '.join(sorted(self.packages))}" + _package_guess(self.folder, self.packages))
        return text


def _resolve_meshes(spec: mujoco.MjSpec, kind: str, folder: Path, dirs: list[Path]) -> _MeshProblems:
    """Each mesh file made absolute (a URDF's) or checked where MuJoCo will look (an MJCF's);
    the missing or unreadable ones, all of them."""
    problems = _MeshProblems(folder=folder)
    users = _mesh_users(spec)
    meshdir = Path(spec.meshdir) if spec.meshdir else Path()
    for mesh in spec.meshes:
        if not mesh.file:
            continue  # vertices given inline
        where = f" (used by {users[mesh.name]})" if mesh.name in users else ""
        package = mesh.file[len("package://"):].split("/", 1)[0] if mesh.file.startswith("package://") else None
        candidates = mesh_candidates(mesh.file, folder, meshdir, spec.strippath, dirs)
        if not candidates:  # package:// and no --package-dir
            problems.packages.add(package)
            problems.lines.append(f"{mesh.file}{where}: a package:// path, and no package folder was given")
            continue
        found = next((c for c in candidates if regular_file_problem(c) is None), None)
        if found is None:
            if package:
                problems.packages.add(package)
            tried = ", ".join(str(c) for c in candidates)
            why = regular_file_problem(candidates[0]) if len(candidates) == 1 else "not found"
            near = next((m for m in map(near_match, candidates) if m is not None), None)
            hint = f"; there is {near} (names differ in case or extension)" if near else ""
            problems.lines.append(f"{mesh.file}{where}: {why} (looked for {tried}){hint}")
        elif kind == "urdf":
            # absolute: a package folder given relative to the working directory (a robot YAML
            # read as `robot.yaml`, `--package-dir ../src`) would be read by MuJoCo from the
            # model's own folder, and not be found there
            mesh.file = str(found.absolute())
    return problems


def _package_guess(folder: Path, packages: set[str]) -> str:
    """A hint when the usual ROS layout (the URDF inside its package) shows the root."""
    for ancestor in (folder, *folder.parents):
        if ancestor.name in packages:
            return f" (the model sits inside {ancestor}: try --package-dir {ancestor.parent})"
    return ""


def _mesh_users(spec: mujoco.MjSpec) -> dict[str, str]:
    users: dict[str, list[str]] = {}
    for geom in spec.geoms:
        if geom.type == mujoco.mjtGeom.mjGEOM_MESH:
            body = geom.parent.name if geom.parent is not None else "?"
            users.setdefault(geom.meshname, [])
            if body not in users[geom.meshname]:
                users[geom.meshname].append(body)
    return {mesh: ("body " if len(b) == 1 else "bodies ") + ", ".join(b[:4]) + (", ..." if len(b) > 4 else "")
            for mesh, b in users.items()}


def _name(spec: mujoco.MjSpec) -> str:
    return spec.modelname or "model"


def _one_line(exc: Exception) -> str:
    return " ".join(str(exc).split())[:400]


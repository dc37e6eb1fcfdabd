"""Hostile YAML and sizes (issue 31, section 2): no input may exhaust memory, time or the disk.

Every kind of YAML the project reads - robot, evolution config, reality file, firmware profile,
a dry run's fault file, a run folder's ``config.yaml`` - goes through one reader
(``sim2real.robot.validation.load_yaml``).  Each kind is swept with each attack (alias bombs,
deep nesting, huge files, duplicate keys, empty files, binary, tags, ...): every one must end in
one short ``ConfigError`` naming the file, quickly, before any value is built.  Then each kind's
physical quantities out of their plausible ranges, numbers YAML reads as text, cycles of
reality files, sizes that allocate (config keys and flags), and simulations that go
numerically unstable, which must never be reported as a result.
"""

from __future__ import annotations

import math
import os
import time
from pathlib import Path
from typing import Callable

import numpy as np
import pytest

from evolve.cli import main
from evolve.config import load_evolve_config
from evolve.limits import MAX_EPISODE_S, MAX_POPULATION
from evolve.run import Run
from sim2real.cli.args import MAX_REPLAY_S
from sim2real.errors import ConfigError
from sim2real.robot import load_robot
from sim2real.robot.paths import data_root
from sim2real.robot.profiles import available_profiles
from sim2real.robot.validation import MAX_YAML_BYTES, MAX_YAML_NODES, load_yaml, parse_yaml, show
from sim2real.simulation.simbus.faults import parse_faults
from sim2real.simulation.reality.file import PLAUSIBLE, Reality, load_reality

ROOT = data_root()
CONTROLLER = ROOT / "configs" / "controllers" / "xl430_biped_no_gyro.json"
MAX_MESSAGE = 400  # characters: a message names file, key and problem, and echoes a few dozen of the value


def _text(relative: str) -> str:
    return (ROOT / relative).read_text()


def _resume(path: Path) -> object:
    """A run folder's config.yaml, read as ``biped evolve --resume`` reads it."""
    (path.parent / "checkpoint.json.gz").write_bytes(b"")  # resume looks for it first
    return Run.resume(path.parent, log=lambda line: None)


# kind -> (file name, a valid document, its reader)
KINDS: dict[str, tuple[str, str, Callable[[Path], object]]] = {
    "robot": ("robot.yaml", _text("configs/robots/xl430_biped.yaml"), load_robot),
    "evolution": ("evolve.yaml", _text("configs/evolve/walk.yaml"), load_evolve_config),
    "reality": ("reality.yaml", _text("configs/reality/randomize.yaml"), load_reality),
    "profile": ("xl430.yaml", _text("firmware_profiles/xl430_w250_t.yaml"), lambda p: available_profiles(p.parent)),
    "faults": ("faults.yaml", "drop: 0.01\nsilent: [{id: 4, at_s: 3.0}]\n", lambda p: parse_faults(str(p))),
    "run config": ("config.yaml", _text("configs/evolve/walk.yaml"), _resume),
}


def write(tmp_path: Path, kind: str, content: str | bytes) -> Path:
    folder = tmp_path / kind.replace(" ", "_")
    folder.mkdir(exist_ok=True)
    path = folder / KINDS[kind][0]
    if isinstance(content, bytes):
        path.write_bytes(content)
    else:
        path.write_text(content)
    return path


def refused(kind: str, path: Path, *fragments: str, within_s: float = 10.0) -> ConfigError:
    """The reader of ``kind`` refuses ``path``: one ConfigError naming the file and every
    fragment, one short line, within ``within_s`` (generous: the old code took minutes)."""
    start = time.monotonic()
    with pytest.raises(ConfigError) as err:
        KINDS[kind][2](path)
    took = time.monotonic() - start
    message = str(err.value)
    assert str(path) in message, message
    assert "\n" not in message and len(message) < MAX_MESSAGE + len(str(path)), message[:1000]
    for fragment in fragments:
        assert fragment in message, (fragment, message)
    assert took < within_s, f"{took:.1f} s to refuse"
    return err.value


def test_every_kind_reads_its_valid_document(tmp_path):
    for kind, (_, text, read) in KINDS.items():
        if kind != "run config":  # resume needs a real checkpoint past its config; the config part is "evolution"
            read(write(tmp_path, kind, text))


# -- attacks on any YAML: refused by the reader, whatever the kind ------------------------------
def _bomb(levels: int = 9) -> str:
    lines = ["a0: &a0 [lol, lol, lol, lol, lol, lol, lol, lol, lol, lol]"]
    lines += [f"a{i}: &a{i} [" + ", ".join([f"*a{i - 1}"] * 10) + "]" for i in range(1, levels)]
    return "\n".join(lines) + "\n"


GENERIC = [
    ("alias bomb", _bomb(), ["alias *a", "expands the document", str(MAX_YAML_NODES)]),
    ("alias bomb in a flow list", "x: [&a [1, 1, 1, 1, 1, 1, 1, 1], &b [*a, *a, *a, *a, *a, *a, *a, *a], "
     "&c [*b, *b, *b, *b, *b, *b, *b, *b], &d [*c, *c, *c, *c, *c, *c, *c, *c], [*d, *d, *d, *d, *d, *d]]\n",
     ["alias *d", "expands"]),
    ("alias bomb through merge keys", "a: &a {x: 1, y: [1, 2, 3, 4, 5, 6, 7, 8, 9, 10]}\n"
     + "".join(f"m{i}: &m{i} {{<<: [*{'a' if i == 0 else f'm{i - 1}'}], k{i}: [" + ", ".join(
         [f"*{'a' if i == 0 else f'm{i - 1}'}"] * 8) + "]}\n" for i in range(8)), ["expands"]),
    ("an alias of a long text, many times", "t: &t " + "x" * 10_000 + "\nl: [" + ", ".join(["*t"] * 300) + "]\n",
     ["alias *t", "expands"]),
    ("alias inside its own anchor", "a: &a [1, 2, *a]\n", ["alias *a", "inside its own anchor"]),
    ("undefined alias", "a: *nowhere\n", ["invalid YAML", "undefined alias"]),
    ("5,000 nested [", "[" * 5000 + "]" * 5000 + "\n", ["nested more than 64 levels", "line 1"]),
    ("5,000 nested {", "{a: " * 5000 + "1" + "}" * 5000 + "\n", ["nested more than 64"]),
    ("nested block mappings", "".join(f"{'  ' * i}k{i}:\n" for i in range(100)) + "  " * 100 + "v: 1\n",
     ["nested more than 64", "line 65"]),
    ("too many values", "x: [" + ", ".join(["0"] * (MAX_YAML_NODES + 5)) + "]\n", ["more than 20000 values"]),
    ("empty", "", ["empty", "blank lines and comments"]),
    ("comments only", "# nothing here\n\n   # nor here\n", ["empty"]),
    ("only null", "~\n", ["empty (null)"]),
    ("only a document marker", "---\n", ["empty"]),
    ("binary", bytes(range(256)) * 8, ["not a YAML file", "binary"]),
    ("NUL bytes in UTF-8", "name: x\0y\n", ["binary (a NUL byte at line 1)"]),
    ("latin-1 text", "name: caf\xe9\n".encode("latin-1"), ["not UTF-8", "byte 0xe9", "line 1"]),
    ("a control character", "name: a\x1bb\n", ["invalid YAML", "unacceptable character"]),
    ("python object tag", "a: !!python/object/apply:os.system [echo owned]\n", ["could not determine a constructor"]),
    ("python name tag", "a: !!python/name:os.system\n", ["could not determine a constructor"]),
    ("custom tag", "a: !include /etc/passwd\n", ["could not determine a constructor"]),
    ("a tag 100 KB long", "a: !" + "x" * 100_000 + " 1\n", ["could not determine a constructor"]),
    ("an integer of 5,000 digits", "a: " + "9" * 5000 + "\n", ["invalid YAML", "4300 digits"]),
    ("an impossible date", "a: 2024-13-45\n", ["invalid YAML", "month"]),
    ("two documents", "a: 1\n---\nb: 2\n", ["expected a single document", "line 2"]),
    ("unhashable key", "? [a, b]\n: 1\n", ["invalid YAML", "unhashable"]),
    ("syntax error", "a: [1, 2\n", ["invalid YAML", "line 2"]),
    ("tab indentation", "a:\n\tb: 1\n", ["invalid YAML"]),
    ("a key given twice", "a: 1\nb: 2\na: 3\n", ["a: given twice", "lines 1 and 3"]),
    ("a nested key given twice", "a:\n  b: {c: 1, c: 2}\n", ["a.b.c: given twice", "lines 2 and 2"]),
    ("a key given twice in a list item", "a:\n  - {x: 1}\n  - {x: 1, y: 2, y: 3}\n", ["a[1].y: given twice"]),
    ("equal keys written differently", "1: a\n1.0: b\n", ["given twice"]),
    ("a plain key of 100 KB", "k" * 100_000 + ": 1\n", ["invalid YAML", "column 100001"]),
    ("an explicit key of 100 KB given twice", ("? " + "k" * 100_000 + "\n: 1\n") * 2, ["given twice", "lines 1 and 3"]),
]


@pytest.mark.parametrize("kind", KINDS)
@pytest.mark.parametrize("attack, content, fragments", GENERIC, ids=[g[0] for g in GENERIC])
def test_every_kind_refuses_every_attack_in_one_short_line(kind, attack, content, fragments, tmp_path):
    refused(kind, write(tmp_path, kind, content), *fragments)


@pytest.mark.parametrize("kind", KINDS)
def test_a_huge_file_is_refused_unread(kind, tmp_path):
    path = write(tmp_path, kind, "")
    with open(path, "wb") as f:  # 12 MB: a sparse file, so the test writes nothing
        f.truncate(12_000_000)
    refused(kind, path, "12000000 bytes is too large", f"at most {MAX_YAML_BYTES}", within_s=1.0)


@pytest.mark.parametrize("kind", KINDS)
def test_a_file_just_over_the_bound_of_valid_yaml_is_refused(kind, tmp_path):
    text = KINDS[kind][1] + "\n" + "# padding\n" * (MAX_YAML_BYTES // 10)  # valid YAML, comments only
    refused(kind, write(tmp_path, kind, text), "too large")


@pytest.mark.parametrize("kind", KINDS)
def test_a_directory_or_a_fifo_is_refused_without_waiting(kind, tmp_path):
    path = write(tmp_path, kind, "")
    path.unlink()
    path.mkdir()  # (the profile reader globs *.yaml: a directory named so is met the same way)
    refused(kind, path, "is a directory")
    path.rmdir()
    os.mkfifo(path)  # opened for reading, a FIFO would wait for a writer forever
    refused(kind, path, "not a regular file", within_s=2.0)


@pytest.mark.parametrize("kind", KINDS)
def test_an_alias_bomb_in_a_real_key_never_prints_it(kind, tmp_path):
    """The issue's robot: the bomb in ``description`` (or the first key of the kind)."""
    text = KINDS[kind][1]
    key = {"robot": "description", "reality": "description", "profile": "source", "faults": "drop"}.get(kind, "seed")
    bomb = "[" + ", ".join(["&a0 [lol, lol, lol, lol, lol, lol, lol, lol, lol, lol]"]
                           + [f"&a{i} [" + ", ".join([f"*a{i - 1}"] * 10) + "]" for i in range(1, 9)]) + "]"
    lines = [f"{key}: {bomb}" if line.startswith(f"{key}:") else line for line in text.splitlines()]
    assert any(line.startswith(f"{key}: [") for line in lines)
    refused(kind, write(tmp_path, kind, "\n".join(lines) + "\n"), "expands the document")


def test_aliases_within_the_bound_and_merge_keys_still_work():
    doc = parse_yaml("base: &b {x: 1, y: [1, 2]}\nover: {<<: *b, x: 3}\nagain: *b\n", "t.yaml")
    assert doc == {"base": {"x": 1, "y": [1, 2]}, "over": {"x": 3, "y": [1, 2]}, "again": {"x": 1, "y": [1, 2]}}


def test_every_shipped_yaml_is_within_the_bounds():
    """No shipped file uses aliases, nests deeper than a few levels or comes near the size bound."""
    files = [p for p in ROOT.rglob("*.yaml") if ".venv" not in p.parts and "runs" not in p.parts]
    assert len(files) > 20
    for path in files:
        assert path.stat().st_size < MAX_YAML_BYTES / 10, path
        load_yaml(path)


def test_no_code_reads_yaml_but_through_load_yaml():
    """The bounds hold only if every reader goes through them (tests may read shipped files)."""
    import re

    direct = re.compile(r"yaml\.(safe_load|load|full_load|unsafe_load|load_all|safe_load_all|compose|parse)\(")
    for folder in ("sim2real", "evolve", "benchmarks"):
        for path in (ROOT / folder).rglob("*.py"):
            if path.name != "validation.py":
                assert not direct.search(path.read_text()), path


# -- duplicate keys, named by kind -------------------------------------------------------------
DUPLICATES = [
    ("robot", "name: another\n", "name: given twice"),
    ("evolution", "seed: 7\n", "seed: given twice"),
    ("reality", "kp_scale: 5.0\n", "kp_scale: given twice"),
    ("profile", "mass_kg: 1.0\n", "mass_kg: given twice"),
    ("faults", "drop: 0.5\n", "drop: given twice"),
    ("run config", "seed: 7\n", "seed: given twice"),
]


@pytest.mark.parametrize("kind, again, problem", DUPLICATES, ids=[d[0] for d in DUPLICATES])
def test_a_key_given_twice_is_refused_naming_key_and_lines(kind, again, problem, tmp_path):
    text = KINDS[kind][1]
    text = text.replace("kp_scale: [0.8, 1.2]", "kp_scale: 0.9") if kind == "reality" else text
    err = refused(kind, write(tmp_path, kind, text + again), problem)
    assert f"and {len(text.splitlines()) + 1})" in str(err)


def test_a_nested_key_given_twice_names_its_path(tmp_path):
    text = KINDS["evolution"][1].replace("  episode_s: 10.0\n", "  episode_s: 10.0\n  episode_s: 1000.0\n")
    refused("evolution", write(tmp_path, "evolution", text), "task.episode_s: given twice")


# -- physical bounds ---------------------------------------------------------------------------
def _robot(old: str, new: str) -> str:
    text = KINDS["robot"][1]
    assert old in text, old
    return text.replace(old, new, 1)


ROBOT_TRUNK = "trunk:  {size: [0.060, 0.110, 0.120], mass: 0.240}"  # checked present by _robot


BAD_ROBOTS = [
    ("mass 1.0e+308", (ROBOT_TRUNK, "trunk: {size: [0.060, 0.110, 0.120], mass: 1.0e+308}"), "body.trunk.mass",
     "must be <= 200.0 kg"),
    ("mass 1.0e-300", (ROBOT_TRUNK, "trunk: {size: [0.060, 0.110, 0.120], mass: 1.0e-300}"), "body.trunk.mass",
     "must be >= 0.005 kg"),
    ("a 1000 m trunk", (ROBOT_TRUNK, "trunk: {size: [0.060, 0.110, 1000.0], mass: 0.240}"), "body.trunk.size[2]",
     "must be <= 1.5 m"),
    ("mass .inf", (ROBOT_TRUNK, "trunk: {size: [0.060, 0.110, 0.120], mass: .inf}"), "body.trunk.mass", "finite"),
    ("mass .nan", (ROBOT_TRUNK, "trunk: {size: [0.060, 0.110, 0.120], mass: .nan}"), "body.trunk.mass", "finite"),
    ("mass a huge integer", (ROBOT_TRUNK, "trunk: {size: [0.060, 0.110, 0.120], mass: 1" + "0" * 400 + "}"),
     "body.trunk.mass", "integer of 401 digits"),
    ("mass text to YAML", (ROBOT_TRUNK, "trunk: {size: [0.060, 0.110, 0.120], mass: 1.0e308}"), "body.trunk.mass",
     "'1.0e308' is text to YAML 1.1, not a number: write 1.0e+308"),
    ("size text to YAML", (ROBOT_TRUNK, "trunk: {size: [0.060, 0.110, 12e-2], mass: 0.240}"), "body.trunk.size[2]",
     "write 12.0e-2"),
    ("mass yes", (ROBOT_TRUNK, "trunk: {size: [0.060, 0.110, 0.120], mass: yes}"), "body.trunk.mass",
     "YAML reads yes/no/on/off as true/false"),
]


@pytest.mark.parametrize("change, key, problem", [b[1:] for b in BAD_ROBOTS], ids=[b[0] for b in BAD_ROBOTS])
def test_a_robot_outside_its_plausible_ranges_is_refused_naming_the_key(change, key, problem, tmp_path):
    refused("robot", write(tmp_path, "robot", _robot(*change)), f": {key}: ", problem)


def test_every_robot_quantity_has_a_range(tmp_path):
    """One out-of-range value for each physical key of a robot config, each refused by its key."""
    import yaml

    base = yaml.safe_load(KINDS["robot"][1])
    cases = {("body", "hip_spacing"): 0.0001, ("body", "foot", "heel"): 2.0, ("body", "foot", "mass"): 500.0,
             ("body", "thigh", "size"): [0.03, 0.03, 3.0], ("joints", 0, "range_deg"): [-720, 0],
             ("joints", 0, "home_deg"): 1000.0, ("joints", 0, "servo", "zero_offset_deg"): 1.0e+6,
             ("control_tick_s",): 100.0, ("physics_dt_s",): 1.0, ("sensor_board", "contact_share"): 2.0,
             ("joints", 0, "name"): "j" * 100}
    for where, value in cases.items():
        doc = yaml.safe_load(KINDS["robot"][1])
        node = doc
        for part in where[:-1]:
            node = node[part]
        node[where[-1]] = value
        path = write(tmp_path, "robot", yaml.safe_dump(doc))
        err = refused("robot", path)
        expected = ".".join(str(p) for p in where).replace(".0.", "[0].").replace("joints.0", "joints[0]")
        assert err.key.startswith(expected), (where, str(err))
    assert base["body"]["trunk"]["mass"] == 0.24


def test_the_human_character_scaled_to_nonsense_is_refused(tmp_path):
    text = _text("configs/robots/human.yaml").replace("density_kg_m3: 1000.0", "density_kg_m3: 1.0e+12")
    path = tmp_path / "human.yaml"
    path.write_text(text)
    with pytest.raises(ConfigError, match=r"body: scaled from anthropometry .* outside the plausible"):
        load_robot(path)
    human = _text("configs/robots/human.yaml").replace("pd_gains: {kp: 300.0", "pd_gains: {kp: 1.0e+9")
    path.write_text(human)
    with pytest.raises(ConfigError, match=r"pd_gains.kp: must be <= 10000"):
        load_robot(path)


BAD_REALITIES = [
    ("latency_ticks: 1.0e+6", "latency_ticks", "plausible 0 to 10 ticks"),
    ("armature_scale: 1.0e+300", "armature_scale", "plausible 0.01 to 20"),
    ("backlash_deg: 90", "backlash_deg", "plausible 0 to 10 deg"),
    ("supply_sag: 2.0", "supply_sag", "plausible 0 to 1"),
    ("stribeck_rad_s: 0.0", "stribeck_rad_s", "plausible 0.001 to 10"),
    ("com_offset_m: [0.0, 5.0]", "com_offset_m", "plausible 0 to 0.1 m"),
    ("heading_drift_deg_s: [-1000, 1000]", "heading_drift_deg_s", "plausible -180 to 180"),
    ("foot_flip: 0.9", "foot_flip", "plausible 0 to 0.5"),
    ("latency_ms: 1.0e+9", "latency_ms", "plausible 0 to 500 ms"),
    ("joints: {right_knee: {kp_scale: 50.0}}", "joints.right_knee.kp_scale", "plausible 0.01 to 10"),
    ("kp_scale: 1.0e308", "kp_scale", "write 1.0e+308"),
    ("kp_scale: .inf", "kp_scale", "finite"),
    ("kp_scale: '1.2'", "kp_scale", "'1.2' is text (in quotes?), not a number: write 1.2 without them"),
    ("description: [&a [1, 2], *a]", "description", "must be a non-empty string"),
]


@pytest.mark.parametrize("line, key, problem", BAD_REALITIES, ids=[b[0] for b in BAD_REALITIES])
def test_a_reality_outside_its_plausible_ranges_is_refused_naming_the_key(line, key, problem, tmp_path):
    err = refused("reality", write(tmp_path, "reality", f"{line}\n"), problem)
    assert err.key == key, str(err)


def test_every_reality_key_has_a_plausible_range_that_holds_the_shipped_and_fitted_values():
    from sim2real.simulation.identify import LATENCY, SERVO_PARAMETERS
    from sim2real.simulation.reality.file import EFFECTS, PERTURBATIONS

    assert set(PLAUSIBLE) == set(PERTURBATIONS) | set(EFFECTS)
    for key, low, high in (*SERVO_PARAMETERS, LATENCY):  # whatever `biped sysid` fits can be read back
        assert PLAUSIBLE[key][0] <= low and high <= PLAUSIBLE[key][1], key
    for key, (value, _) in {**PERTURBATIONS, **EFFECTS}.items():  # nominal inside
        assert PLAUSIBLE[key][0] <= value <= PLAUSIBLE[key][1], key


def test_ranges_centred_beyond_plausible_are_refused(tmp_path):
    (tmp_path / "fit.yaml").write_text("kp_scale: 8.0\n")
    path = tmp_path / "ranges.yaml"
    path.write_text(f"kp_scale: [0.5, 2.0]\ncentre: {tmp_path / 'fit.yaml'}\n")
    with pytest.raises(ConfigError, match=r"ranges.yaml: kp_scale: around its centre fit this is 4 to 16, outside "
                                          r"the plausible 0.01 to 10"):
        load_reality(path)


def test_a_reality_file_that_is_its_own_centre_is_refused_naming_the_chain(tmp_path):
    path = tmp_path / "self.yaml"
    path.write_text(f"kp_scale: 1.1\ncentre: {path}\n")
    with pytest.raises(ConfigError) as err:
        load_reality(path)
    assert str(err.value) == f"{path}: centre: a cycle of centres: {path} -> {path}"


def test_a_loop_through_two_reality_files_is_refused_naming_the_chain(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)  # relative names, as a user writes them
    Path("a.yaml").write_text("kp_scale: 1.1\ncentre: b.yaml\n")
    Path("b.yaml").write_text("kp_scale: 1.0\ncentre: a.yaml\n")
    with pytest.raises(ConfigError) as err:
        load_reality("a.yaml")
    assert str(err.value) == "b.yaml: centre: a cycle of centres: a.yaml -> b.yaml -> a.yaml"


def test_a_relative_centre_is_read_beside_the_file_that_names_it(tmp_path, monkeypatch):
    """From another working folder, as a user runs `biped eval --reality robots/mine/ranges.yaml`."""
    folder = tmp_path / "robots" / "mine"
    folder.mkdir(parents=True)
    (folder / "fit.yaml").write_text("kp_scale: 0.8\n")
    (folder / "ranges.yaml").write_text("kp_scale: [0.9, 1.1]\ncentre: fit.yaml\n")
    monkeypatch.chdir(tmp_path)
    reality = load_reality("robots/mine/ranges.yaml")
    assert reality.centre is not None and reality.centre.name == "fit"
    assert reality.ranges["kp_scale"] == pytest.approx((0.72, 0.88))


def test_a_long_chain_of_centres_is_refused(tmp_path):
    for i in range(12):
        (tmp_path / f"r{i}.yaml").write_text(f"kp_scale: 1.0\ncentre: {tmp_path / f'r{i + 1}.yaml'}\n")
    (tmp_path / "r12.yaml").write_text("kp_scale: 1.0\n")
    with pytest.raises(ConfigError, match="more than 8 reality files each the centre of the one before"):
        load_reality(tmp_path / "r0.yaml")


def test_the_cli_refuses_a_cycle_in_one_line(tmp_path, capsys):
    path = tmp_path / "self.yaml"
    path.write_text(f"kp_scale: 1.1\ncentre: {path}\n")
    code, _, err = _biped(["eval", CONTROLLER, "--reality", path], capsys)
    lines = err.strip().splitlines()  # argparse's usage lines, then the one error line
    assert code == 2 and "Traceback" not in err and sum("error" in line for line in lines) == 1
    assert lines[-1] == f"biped eval: error: argument --reality: {path}: centre: a cycle of centres: {path} -> {path}"


BAD_EVOLUTIONS = [
    ("population_size: 128", "population_size: 100000000", "neat.population_size", f"<= {MAX_POPULATION}"),
    ("generations: 400", "generations: 1000000000000", "generations", "<= 1000000"),
    ("threads: 0", "threads: 100000", "threads", "<= 256"),
    ("episode_s: 10.0", "episode_s: 1.0e+6", "task.episode_s", f"within (0, {MAX_EPISODE_S:g}]"),
    ("episode_s: 10.0", "episode_s: 1.0e6", "task.episode_s", "write 1.0e+6"),
    ("generations: 400", "generations: 1e6", "generations", "write 1000000"),
    ("seed: 1", "seed: 1.0e+3", "seed", "must be an integer"),
    ("harness_generations: 100", "harness_generations: 100\n  harness_stiffness: 1.0e+9", "task.harness_stiffness",
     "within [0, 1000]"),
    ("population_size: 128", "population_size: 10000\nrandomize: {reality: randomize, episodes: 64}",
     "", "control ticks a generation"),
]


@pytest.mark.parametrize("old, new, key, problem", BAD_EVOLUTIONS, ids=[b[1].split("\n")[-1] for b in BAD_EVOLUTIONS])
def test_an_evolution_config_out_of_its_bounds_is_refused_naming_the_key(old, new, key, problem, tmp_path):
    text = KINDS["evolution"][1]
    assert old in text
    if old == "population_size: 128" and "randomize" in new:  # a top-level block after neat
        text = text.replace(old, "population_size: 10000", 1) + new.split("\n")[1] + "\n"
    else:
        text = text.replace(old, new, 1)
    err = refused("evolution", write(tmp_path, "evolution", text), problem)
    assert err.key == key, str(err)


def test_randomize_and_stage_sizes_are_bounded(tmp_path):
    base = KINDS["evolution"][1]
    cases = [("randomize: {reality: randomize, episodes: 1000}\n", "randomize.episodes"),
             ("randomize: {reality: randomize, validation: {draws: 1000000}}\n", "randomize.validation.draws"),
             ("randomize: {reality: randomize, validation: {draws: 10, candidates: 100000}}\n",
              "randomize.validation.candidates"),
             ("randomize: {reality: randomize, push: {speed_m_s: 0.1, every_s: 0.0}}\n", "randomize.push.every_s"),
             ("stages: [" + ", ".join(f"{{name: s{i}, objective: walk, generations: 1}}" for i in range(17)) + "]\n",
              "stages"),
             ("stages: [{name: s, objective: walk, generations: 100000000}]\n", "stages[0].generations")]
    for block, key in cases:
        err = refused("evolution", write(tmp_path, "evolution", base + block))
        assert err.key == key, str(err)


BAD_PROFILES = [
    ("mass_kg: 0.0572", "mass_kg: 100.0", "mass_kg"),
    ("stall_torque_nm: 1.4 ", "stall_torque_nm: 1.0e+6 ", "motor.stall_torque_nm"),
    ("gear_ratio: 258.5", "gear_ratio: 0.0", "motor.gear_ratio"),
    ("armature_kgm2: 0.0042", "armature_kgm2: 1.0e+300", "motor.armature_kgm2"),
    ("p_divisor: 128", "p_divisor: 0", "gains.p_divisor"),
    ("max_tick: 4095", "max_tick: -5", "position.max_tick"),
    ("viscous_friction_nms: 0.0013", "viscous_friction_nms: 5.0", "motor.viscous_friction_nms"),
    ("resolution: 4096", "resolution: 1" + "0" * 30, "position.resolution"),
]


@pytest.mark.parametrize("old, new, key", BAD_PROFILES, ids=[b[1] for b in BAD_PROFILES])
def test_a_profile_outside_its_plausible_ranges_is_refused_naming_the_key(old, new, key, tmp_path):
    text = KINDS["profile"][1]
    assert old in text
    err = refused("profile", write(tmp_path, "profile", text.replace(old, new, 1)))
    assert err.key == key, str(err)


def test_a_register_default_that_does_not_fit_its_bytes_is_refused(tmp_path):
    text = KINDS["profile"][1]
    assert "default: 1060}" in text
    text = text.replace("default: 1060}", "default: 70000}", 1)  # model_number: 2 bytes
    err = refused("profile", write(tmp_path, "profile", text), "must be <= 65535")
    assert err.key == "control_table[0].default"


def test_a_fault_file_entry_is_checked(tmp_path):
    refused("faults", write(tmp_path, "faults", "silent: [{id: 4, at_s: -1.0}]\n"), "silent[0].at_s")
    refused("faults", write(tmp_path, "faults", "drop: 2.0\n"), "drop: must be <= 1.0")


# -- messages never echo a value whole -----------------------------------------------------------
def test_show_cuts_every_value_to_a_few_dozen_characters():
    assert len(show("x" * 1_000_000)) < 50
    assert len(show(list(range(10**5)))) < 50
    deep: list = []
    for _ in range(50):
        deep = [deep, "x" * 1000]
    assert len(show(deep)) <= 80
    assert len(show(10**4000)) <= 80


@pytest.mark.parametrize("kind, text", [
    ("robot", "name: [" + ", ".join(["'" + "x" * 200 + "'"] * 500) + "]\n"),
    ("robot", "x" * 100_000 + ": 1\n"),
    ("evolution", "robot: " + "r" * 100_000 + "\n"),
    ("reality", "kp_scale: '" + "9" * 100_000 + "'\n"),
    ("reality", "joints: {" + "j" * 100_000 + ": {kp_scale: 50.0}}\n"),
    ("faults", "silent: " + "s" * 100_000 + "\n"),
    ("profile", "model: [" + "1, " * 5000 + "1]\nkind: servo\n"),
])
def test_a_long_value_is_never_echoed_whole(kind, text, tmp_path):
    refused(kind, write(tmp_path, kind, text))  # the length check is in `refused`


# -- sizes that allocate, on the command line ---------------------------------------------------
def _biped(argv, capsys) -> tuple[int, str, str]:
    try:
        code = main([str(a) for a in argv])
    except SystemExit as exc:
        code = exc.code
    out = capsys.readouterr()
    return code, out.out, out.err


@pytest.mark.parametrize("argv, flag", [
    (["evolve", "--population", "100000000"], "--population"),
    (["evolve", "--threads", "100000"], "--threads"),
    (["evolve", "--generations", "10000000"], "--generations"),
    (["eval", CONTROLLER, "--episodes", "1000000"], "--episodes"),
    (["eval", CONTROLLER, "--seconds", "1e6"], "--seconds"),
    (["plot", "gait", CONTROLLER, "--seconds", "1e5"], "--seconds"),
    (["render", CONTROLLER, "--seconds", "3600"], "--seconds"),
    (["render", "--strip", CONTROLLER, "--frames", "100000"], "--frames"),
    (["quickstart", "--population", "100000000"], "--population"),
], ids=lambda v: " ".join(map(str, v)) if isinstance(v, list) else v)
def test_a_size_flag_beyond_its_bound_is_refused_naming_the_flag(argv, flag, capsys):
    code, _, err = _biped(argv, capsys)
    assert code == 2 and f"argument {flag}" in err and "within" in err, err


def test_population_times_the_configs_episodes_is_bounded_too(tmp_path, capsys, monkeypatch):
    monkeypatch.setattr(Run, "create", _no_evolution)  # were the check to miss, no evolution starts here
    path = tmp_path / "c.yaml"
    text = _text("benchmarks/records/configs/walk_robust.yaml")
    assert "  episodes: 3\n" in text
    path.write_text(text.replace("  episodes: 3\n", "  episodes: 8\n"))  # 10,000 x 8 x 294 ticks: 23.5 million
    code, _, err = _biped(["evolve", path, "--population", "10000", "--out", tmp_path / "run"], capsys)
    assert code == 2 and "--population 10000:" in err and "control ticks a generation" in err, err
    assert not (tmp_path / "run").exists()


def _no_evolution(*args, **kwargs):
    raise AssertionError("an evolution would have started")


def test_the_flag_bounds_agree_with_the_config_bounds():
    assert MAX_REPLAY_S == MAX_EPISODE_S  # sim2real cannot import evolve: the same number twice
    from sim2real.controller.schema import TICK_RANGE_S
    from sim2real.robot.spec import CONTROL_TICK_S

    assert CONTROL_TICK_S == TICK_RANGE_S


# -- the trace sidecar: bounded and strict like controller JSON ----------------------------------
def _trace(tmp_path: Path) -> Path:
    from sim2real.hardware.trace import TraceWriter

    robot = load_robot()
    home = [j.home_rad for j in robot.joints]
    path = tmp_path / "t.csv"
    writer = TraceWriter(path, robot.joint_names, {"robot": robot.name, "tick_s": 0.034})
    for k in range(4):
        writer.write(k * 0.034, k, home, home, [1, 1], [0.0, 0.0, 1.0], 1e-4, 1e-3, False)
    writer.close()
    return path


@pytest.mark.parametrize("spoil, problem", [
    (lambda p: p.write_text('{"robot": "xl430_biped", "robot": "op3_legs"}'), "'robot' appears twice"),
    (lambda p: p.write_text("[" * 5000 + "]" * 5000), "nested 5000 levels deep"),
    (lambda p: os.truncate(p, 50_000_000), "too large for a trace sidecar"),
    (lambda p: (p.unlink(), os.mkfifo(p)), "not a regular file"),
    (lambda p: p.write_text('{"n": ' + "9" * 5000 + "}"), "4300 digits"),
], ids=["duplicate key", "deep", "huge", "fifo", "huge integer"])
def test_a_hostile_trace_sidecar_is_refused(spoil, problem, tmp_path):
    from sim2real.hardware.trace import Trace

    path = _trace(tmp_path)
    spoil(path.with_suffix(".json"))
    start = time.monotonic()
    with pytest.raises(ConfigError, match=problem):
        Trace.read(path)
    assert time.monotonic() - start < 2.0


# -- numerical instability is reported as such, never as a result ------------------------------
BLOWN_UP = Reality("blown-up", "", {"kp_scale": (math.inf, math.inf)})  # no file can say this: built in code


@pytest.fixture
def mujoco_log(tmp_path, monkeypatch):
    """MuJoCo appends each warning to MUJOCO_LOG.TXT in the working directory: keep them
    out of the project's folder."""
    monkeypatch.chdir(tmp_path)


def test_instability_is_seen_in_mujocos_warnings(mujoco_log):
    import mujoco

    from sim2real.simulation.model.builder import build_model, instability

    model = build_model(load_robot())
    data = mujoco.MjData(model)
    mujoco.mj_resetDataKeyframe(model, data, 0)
    mujoco.mj_step(model, data)
    assert instability(data) is None
    data.qvel[:] = 1e12
    for _ in range(3):
        mujoco.mj_step(model, data)
    assert "numerically unstable" in instability(data)
    assert np.all(np.isfinite(data.qpos))  # MuJoCo reset it: only the warning tells


@pytest.mark.filterwarnings("ignore:invalid value encountered:RuntimeWarning")  # inf gains times 0
def test_eval_and_gait_of_an_unstable_simulation_are_no_result(mujoco_log):
    from evolve.replay import evaluate_controller, gait
    from sim2real.simulation.model.builder import SimulationUnstable

    with pytest.raises(SimulationUnstable, match="2 of 2 episodes went numerically unstable"):
        evaluate_controller(CONTROLLER, seconds=0.5, episodes=2, randomize=BLOWN_UP)
    with pytest.raises(SimulationUnstable, match="numerically unstable"):
        gait(CONTROLLER, seconds=0.5, reality=BLOWN_UP)


def test_compare_of_an_unstable_simulation_is_no_result(mujoco_log):
    from sim2real.simulation.transfer.compare import _simulate
    from sim2real.simulation.model.builder import SimulationUnstable
    from sim2real.simulation.reality.randomize import perturbed_model

    robot = load_robot()
    model, _ = perturbed_model(robot, Reality("blown-up", "", {"armature_scale": (math.inf, math.inf)}))
    times = np.arange(5) * 0.034
    goals = np.tile([j.home_rad for j in robot.joints], (5, 1))
    with pytest.raises(SimulationUnstable, match=r"numerically unstable: .*\) at 0\.00 s of the trace"):
        _simulate(robot, times, goals, None, model)


def test_the_simulated_bus_reports_instability_with_its_ground_truth(mujoco_log):
    """The issue's ``armature_scale: 1e300`` (now refused in a file) behind the simulated bus:
    MuJoCo resets the robot, which then "walks" and reports ``fell: false`` - unless the
    ground truth says it went unstable."""
    from sim2real.simulation.simbus.physics import PhysicsChain

    now = [0.0]
    chain = PhysicsChain(load_robot(), clock=lambda: now[0],
                         reality=Reality("huge armature", "", {"armature_scale": (1e300, 1e300)}))
    assert chain.ground_truth()["unstable"] is None
    while now[0] < 3.0 and not chain.ground_truth()["unstable"]:
        now[0] += 0.25
        chain.advance()
    assert "numerically unstable" in chain.ground_truth()["unstable"]


def test_a_dry_run_whose_simulated_robot_went_unstable_is_no_result(monkeypatch, mujoco_log, capsys):
    from sim2real.cli.deploy_commands import run_exit_code
    from sim2real.simulation.transfer import dry_run as module

    exit_ = module.SimulatedBusProcess.__exit__

    def unstable_exit(self, *exc):  # the simulated bus's report, as its physics writes it when MuJoCo warned
        exit_(self, *exc)
        self.ground_truth["unstable"] = "numerically unstable: NaN, Inf or huge value in the accelerations"

    monkeypatch.setattr(module.SimulatedBusProcess, "__exit__", unstable_exit)
    lines = []
    result = module.dry_run(CONTROLLER, duration_s=0.2, ramp_s=0.1, log=lines.append,
                            simbus_realtime=["--no-realtime"], reality="default")
    assert result["stop_reason"] == "duration reached" and not result["torque_off"]["unconfirmed"]  # stopped safely
    assert result["distance_m"] is None and result["fell"] is None  # but no result
    assert result["unstable"].startswith("numerically unstable")
    assert any("simulated robot went numerically unstable" in line for line in lines)
    capsys.readouterr()
    assert run_exit_code(result, lines.append) == 1
    assert capsys.readouterr().err.strip() == ("biped: error: the simulated robot went numerically unstable: NaN, Inf "
                                               "or huge value in the accelerations: its distance and falls are no result")

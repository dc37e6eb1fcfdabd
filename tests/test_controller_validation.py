"""A controller is checked whole before any servo moves: every bad field is one ConfigError
line naming it, `biped run` stops there with exit code 2 and torque never on, and whatever
the check lets through runs without an exception."""

import copy
import json
import math
import re
import time
from pathlib import Path

import jsonschema
import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import sim2real
from evolve.locomotion.evaluator import neat_layout
from evolve.locomotion.export import controller_from_genome, genome_from_controller
from evolve.locomotion.task import TaskConfig
from evolve.neat import NeatConfig, Population, PopulationNetwork
from sim2real.controller.robot_checks import tick_bounds
from sim2real.controller.file import Controller
from sim2real.controller.json_reader import MAX_BYTES, MAX_DEPTH, nesting_depth
from sim2real.controller.schema import MAX_STEEPNESS, MAX_WEIGHT, TICK_RANGE_S
from sim2real.controller.policy import Policy
from sim2real.controller.symmetry import bias_values, symmetric_layout
from sim2real.errors import ConfigError
from sim2real.robot import load_robot

ROBOT = load_robot()
BAD_FILES = Path(__file__).parent / "data" / "bad_controllers"
SCHEMA = json.loads((Path(sim2real.__file__).parent / "controller" / "schemas" / "controller-v1.schema.json").read_text())
FUZZ = settings(max_examples=200, deadline=None, derandomize=True, database=None,
                suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])


def grown_controller(seed: int = 4) -> dict:
    """An evolved two-module controller (pose below walk) with hidden nodes, as a run writes it."""
    layout = symmetric_layout(ROBOT, ROBOT.control_sets["walk"])
    config = NeatConfig(population_size=20, target_species=3, add_node_prob=0.4, add_link_prob=0.6)
    pop = Population(config, neat_layout(layout), seed=seed, modules=("pose", "walk"))
    rng = np.random.default_rng(seed)
    for _ in range(12):
        pop.step(lambda gs: rng.random(len(gs)))
    genome = max(pop.genomes, key=lambda g: len(g.conns))
    data = controller_from_genome(genome, ROBOT, layout, TaskConfig(), 1.0, {"seed": seed}).to_dict()
    for conn in data["connections"][::2]:
        conn[3] = 0  # half of them in the lower module
    data["hidden"][0][1] = 0
    return data


@pytest.fixture(scope="module")
def valid() -> dict:
    data = grown_controller()
    assert len(data["hidden"]) >= 3 and len(data["connections"]) >= 40
    return data


@pytest.fixture(scope="module")
def valid_path(valid, tmp_path_factory) -> Path:
    path = tmp_path_factory.mktemp("valid") / "controller.json"
    Controller.from_dict(valid).save(path)
    return path


def write(tmp_path: Path, data, name: str = "bad.json") -> Path:
    path = tmp_path / name
    path.write_text(json.dumps(data))  # NaN and inf become the NaN/Infinity literals
    return path


def refused(path: Path, robot=ROBOT) -> str:
    """Controller.load's one-line message for a file it must refuse."""
    with pytest.raises(ConfigError) as info:
        Controller.load(path, robot)
    message = str(info.value)
    assert "\n" not in message and message.startswith(f"{path}: ")
    return message[len(f"{path}: "):]


def test_controllers_the_project_writes_load_and_match_the_schema(valid_path, valid):
    assert Controller.load(valid_path, ROBOT).to_dict() == valid
    assert Controller.load(valid_path).to_dict() == valid
    jsonschema.validate(valid, SCHEMA)


def test_a_300_connection_controller_validates_in_well_under_a_second(valid, tmp_path):
    """The old validation took minutes on such a controller (a guard against that, not a
    speed measurement: about 1 ms here, but a loaded CI machine is many times slower)."""
    data = copy.deepcopy(valid)
    interface = len(data["inputs"]) + 2 + len(data["outputs"])
    data["hidden"] = [[interface + i, i % 2] for i in range(40)]
    rng = np.random.default_rng(0)
    nodes = list(range(interface + 40))
    pairs = set()
    while len(pairs) < 300:
        pairs.add((int(rng.choice(nodes)), int(rng.choice(nodes[len(data["inputs"]) + 2:]))))
    data["connections"] = [[s, d, float(rng.normal()), 1] for s, d in sorted(pairs)]
    path = tmp_path / "c300.json"
    Controller.from_dict(data).save(path)
    times = []
    for _ in range(5):
        start = time.perf_counter()
        Controller.load(path, ROBOT)
        times.append(time.perf_counter() - start)
    assert min(times) < 0.5, times


# -- every field broken in every way -------------------------------------------------------------
DELETE = object()


def _set(path, value):
    def mutate(doc):
        parent = doc
        for key in path[:-1]:
            parent = parent[key]
        if value is DELETE:
            del parent[path[-1]]
        else:
            parent[path[-1]] = value(parent[path[-1]]) if callable(value) else value
    return mutate


inf, nan = math.inf, math.nan
CASES = [  # (name, mutation, the message's start: "FIELD: problem")
    ("version 2", _set(["version"], 2), "version: version 2 is not supported"),
    ("version as text", _set(["version"], "1"), "version: version '1' is not supported"),
    ("version true", _set(["version"], True), "version: version True is not supported"),
    ("version 1.0", _set(["version"], 1.0), "version: version 1.0 is not supported"),
    ("format missing", _set(["format"], DELETE), "format: not a controller file (format missing"),
    ("format other", _set(["format"], "biped-genome"), "format: not a controller file (format 'biped-genome'"),
    ("unknown key", _set(["weights"], [1, 2]), "weights: unknown key"),
    ("robot a string", _set(["robot"], "xl430_biped"), "robot: must be an object"),
    ("robot name missing", _set(["robot", "name"], DELETE), "robot.name: missing"),
    ("robot name a number", _set(["robot", "name"], 3), "robot.name: must be a non-empty string"),
    ("robot name empty", _set(["robot", "name"], ""), "robot.name: must be a non-empty string"),
    ("robot hash a number", _set(["robot", "joint_map_hash"], 12), "robot.joint_map_hash: must be 16 hex digits"),
    ("robot hash short", _set(["robot", "joint_map_hash"], "abc"), "robot.joint_map_hash: must be 16 hex digits"),
    ("robot extra key", _set(["robot", "servos"], 11), "robot.servos: unknown key"),
    ("tick zero", _set(["tick_s"], 0), "tick_s: must be within [0.001, 1], got 0"),
    ("tick negative", _set(["tick_s"], -0.034), "tick_s: must be within [0.001, 1], got -0.034"),
    ("tick too long", _set(["tick_s"], 5.0), "tick_s: must be within [0.001, 1], got 5.0"),
    ("tick too short", _set(["tick_s"], 1e-9), "tick_s: must be within [0.001, 1], got 1e-09"),
    ("tick NaN", _set(["tick_s"], nan), "tick_s: must be a finite number, got NaN"),
    ("tick Infinity", _set(["tick_s"], inf), "tick_s: must be a finite number, got Infinity"),
    ("tick -Infinity", _set(["tick_s"], -inf), "tick_s: must be a finite number, got -Infinity"),
    ("tick a string", _set(["tick_s"], "0.034"), "tick_s: must be a number, got '0.034'"),
    ("tick true", _set(["tick_s"], True), "tick_s: must be a number, got True"),
    ("tick null", _set(["tick_s"], None), "tick_s: must be a number, got None"),
    ("tick a list", _set(["tick_s"], [0.034]), "tick_s: must be a number, got [0.034]"),
    ("tick missing", _set(["tick_s"], DELETE), "tick_s: missing"),
    ("steepness zero", _set(["sigmoid_steepness"], 0), "sigmoid_steepness: must be within (0, 100]"),
    ("steepness negative", _set(["sigmoid_steepness"], -1.0), "sigmoid_steepness: must be within (0, 100]"),
    ("steepness huge", _set(["sigmoid_steepness"], 1e6), "sigmoid_steepness: must be within (0, 100]"),
    ("steepness NaN", _set(["sigmoid_steepness"], nan), "sigmoid_steepness: must be a finite number"),
    ("steepness Infinity", _set(["sigmoid_steepness"], inf), "sigmoid_steepness: must be a finite number"),
    ("inputs empty", _set(["inputs"], []), "inputs: must have at least 1 entry"),
    ("inputs a string", _set(["inputs"], "own_knee"), "inputs: must be a list of names"),
    ("inputs numbers", _set(["inputs", 0], 1), "inputs[0]: must be a non-empty string, got 1"),
    ("inputs duplicate", _set(["inputs", 1], "own_hip_roll"), "inputs: 'own_hip_roll' appears twice"),
    ("inputs fewer", _set(["inputs"], lambda v: v[:-1]), "inputs: has 10 names where the symmetry block"),
    ("inputs extra", _set(["inputs"], lambda v: v + ["heading"]), "inputs: has 12 names where"),
    ("inputs renamed", _set(["inputs", 7], "left_foot"), "inputs[7]: is 'left_foot' where the symmetry block"),
    ("outputs extra", _set(["outputs"], lambda v: v + ["own_ankle_pitch"]), "outputs: has 5 names where"),
    ("outputs fewer", _set(["outputs"], lambda v: v[:-1]), "outputs: has 3 names where"),
    ("outputs empty", _set(["outputs"], []), "outputs: must have at least 1 entry"),
    ("outputs not own", _set(["outputs", 0], "hip_roll"), "outputs[0]: 'hip_roll': the first 3 outputs are the own leg's"),
    ("outputs null", _set(["outputs", 3], None), "outputs[3]: must be a non-empty string, got None"),
    ("outputs reordered", _set(["outputs"], lambda v: [v[1], v[0]] + v[2:]), "inputs[0]: is 'own_hip_roll' where"),
    ("bias empty", _set(["bias"], []), "bias: must be two rows"),
    ("bias one row", _set(["bias"], [[1.0, 1.0]]), "bias: must be two rows"),
    ("bias three rows", _set(["bias"], lambda v: v + [v[0]]), "bias: must be two rows"),
    ("bias ragged", _set(["bias", 1], [1.0]), "bias[1]: must be the two bias node values"),
    ("bias empty rows", _set(["bias"], [[], []]), "bias[0]: must be the two bias node values"),
    ("bias row a number", _set(["bias", 0], 1.0), "bias[0]: must be the two bias node values"),
    ("bias NaN", _set(["bias", 1, 1], nan), "bias[1][1]: must be a finite number, got NaN"),
    ("bias Infinity", _set(["bias", 0, 0], inf), "bias[0][0]: must be a finite number, got Infinity"),
    ("bias too big", _set(["bias", 0, 0], 2.0), "bias[0][0]: must be within [-1, 1], got 2.0"),
    ("bias true", _set(["bias", 0, 0], True), "bias[0][0]: must be a number, got True"),
    ("symmetry a string", _set(["symmetry"], "bilateral"), "symmetry: must be an object"),
    ("symmetry empty", _set(["symmetry"], {}), "symmetry.networks: missing"),
    ("symmetry networks swapped", _set(["symmetry", "networks"], ["left", "right"]), "symmetry.networks: must be"),
    ("symmetry right leg missing", _set(["symmetry", "leg_joints", "right"], DELETE), "symmetry.leg_joints.right: missing"),
    ("symmetry legs ragged", _set(["symmetry", "leg_joints", "left"], lambda v: v[:-1]),
     "symmetry.leg_joints: 3 right joints but 2 left"),
    ("symmetry centre extra", _set(["symmetry", "center_joints"], lambda v: v + ["right_ankle_roll"]),
     "symmetry.center_mirror_for_left: must be one of -1, 1 per centre joint"),
    ("symmetry mirror zero", _set(["symmetry", "center_mirror_for_left", 0], 0),
     "symmetry.center_mirror_for_left[0]: must be -1 or 1, got 0"),
    ("symmetry mirror true", _set(["symmetry", "center_mirror_for_left", 0], True),
     "symmetry.center_mirror_for_left[0]: must be -1 or 1, got True"),
    ("symmetry unknown key", _set(["symmetry", "axis"], "sagittal"), "symmetry.axis: unknown key"),
    ("symmetry joints not driven", _set(["symmetry", "leg_joints", "right", 0], "right_ankle_roll"),
     "symmetry: has ['right_ankle_roll'] beyond joints.driven; lacks ['right_hip_roll'] of joints.driven"),
    ("symmetry joint twice", lambda d: d["symmetry"].update(center_joints=["right_knee"]),
     "symmetry: 'right_knee' is wired twice"),
    ("modules empty", _set(["modules"], []), "modules: must be a non-empty list"),
    ("modules a string", _set(["modules"], "main"), "modules: must be a non-empty list"),
    ("module enabled missing", _set(["modules", 0, "enabled"], DELETE), "modules[0].enabled: missing"),
    ("module disabled", _set(["modules", 1, "enabled"], False), "modules[1].enabled: must be true, got False"),
    ("module enabled text", _set(["modules", 0, "enabled"], "yes"), "modules[0].enabled: must be true, got 'yes'"),
    ("module name a number", _set(["modules", 0, "name"], 3), "modules[0].name: must be a non-empty string"),
    ("module names twice", _set(["modules", 1, "name"], "pose"), "modules: 'pose' appears twice"),
    ("module extra key", _set(["modules", 0, "frozen"], True), "modules[0].frozen: unknown key"),
    ("hidden an integer", _set(["hidden"], 5), "hidden: must be a list of [node id, module index], got 5"),
    ("hidden entry short", _set(["hidden", 0], lambda v: v[:1]), "hidden[0]: must be [node id, module index]"),
    ("hidden entry long", _set(["hidden", 0], lambda v: v + [0]), "hidden[0]: must be [node id, module index]"),
    ("hidden id true", _set(["hidden", 0, 0], True), "hidden[0]: node id must be an integer within [17,"),
    ("hidden id float", _set(["hidden", 0, 0], 20.0), "hidden[0]: node id must be an integer within [17,"),
    ("hidden id an output", _set(["hidden", 0, 0], 14), "hidden[0]: node id must be an integer within [17,"),
    ("hidden id negative", _set(["hidden", 0, 0], -3), "hidden[0]: node id must be an integer within [17,"),
    ("hidden id huge", _set(["hidden", 0, 0], 2 ** 40), "hidden[0]: node id must be an integer within [17,"),
    ("hidden id NaN", _set(["hidden", 0, 0], nan), "hidden[0]: node id must be an integer within [17,"),
    ("hidden ids twice", lambda d: d["hidden"][1].__setitem__(0, d["hidden"][0][0]),
     re.compile(r"hidden\[1\]: node id \d+ appears twice$")),
    ("hidden module out of range", _set(["hidden", 0, 1], 2), "hidden[0]: module 2 is not an index into modules"),
    ("hidden module negative", _set(["hidden", 0, 1], -1), "hidden[0]: module -1 is not an index into modules"),
    ("hidden module true", _set(["hidden", 0, 1], True), "hidden[0]: module True is not an index into modules"),
    ("connections an integer", _set(["connections"], 7), "connections: must be a list"),
    ("connection short", _set(["connections", 2], lambda v: v[:3]), "connections[2]: must be [src, dst, weight, module]"),
    ("connection long", _set(["connections", 2], lambda v: v + [1]), "connections[2]: must be [src, dst, weight, module]"),
    ("connection an object", _set(["connections", 2], {"src": 0}), "connections[2]: must be [src, dst, weight, module]"),
    ("src true", _set(["connections", 2, 0], True), "connections[2]: src must be an integer node id, got True"),
    ("dst false", _set(["connections", 2, 1], False), "connections[2]: dst must be an integer node id, got False"),
    ("src float", _set(["connections", 2, 0], 1.0), "connections[2]: src must be an integer node id, got 1.0"),
    ("src dangling", _set(["connections", 2, 0], 9999), "connections[2]: src 9999 is not a node of this network"),
    ("dst dangling", _set(["connections", 2, 1], 9999), "connections[2]: dst 9999 is not a node of this network"),
    ("src negative", _set(["connections", 2, 0], -1), "connections[2]: src -1 is not a node of this network"),
    ("dst an input", _set(["connections", 2, 1], 0), "connections[2]: dst 0 is an input or bias node"),
    ("dst a bias node", _set(["connections", 2, 1], 12), "connections[2]: dst 12 is an input or bias node"),
    ("weight NaN", _set(["connections", 2, 2], nan), "connections[2]: weight must be a finite number, got NaN"),
    ("weight Infinity", _set(["connections", 2, 2], inf), "connections[2]: weight must be a finite number, got Infinity"),
    ("weight -Infinity", _set(["connections", 2, 2], -inf), "connections[2]: weight must be a finite number, got -Infinity"),
    ("weight huge", _set(["connections", 2, 2], 1e300), "connections[2]: weight 1e+300 is beyond the format's bound |weight| <= 1000"),
    ("weight just over", _set(["connections", 2, 2], -1000.5), "connections[2]: weight -1000.5 is beyond"),
    ("weight huge integer", _set(["connections", 2, 2], 10 ** 400), "connections[2]: weight 1000000"),
    ("weight a string", _set(["connections", 2, 2], "0.5"), "connections[2]: weight must be a number, got '0.5'"),
    ("weight true", _set(["connections", 2, 2], True), "connections[2]: weight must be a number, got True"),
    ("weight null", _set(["connections", 2, 2], None), "connections[2]: weight must be a number, got None"),
    ("module out of range", _set(["connections", 2, 3], 2), "connections[2]: module 2 is not an index into modules"),
    ("module negative", _set(["connections", 2, 3], -1), "connections[2]: module -1 is not an index"),
    ("module true", _set(["connections", 2, 3], True), "connections[2]: module True is not an index"),
    ("module float", _set(["connections", 2, 3], 0.0), "connections[2]: module 0.0 is not an index"),
    ("joints missing", _set(["joints"], DELETE), "joints: missing"),
    ("driven missing", _set(["joints", "driven"], DELETE), "joints.driven: missing"),
    ("driven empty", _set(["joints", "driven"], []), "joints.driven: must have at least 1 entry"),
    ("driven extra", _set(["joints", "driven"], lambda v: v + ["right_ankle_roll"]),
     "joints.hold_rad.right_ankle_roll: is a driven joint"),
    ("driven fewer", _set(["joints", "driven"], lambda v: v[1:]), "symmetry: has ['waist_yaw'] beyond joints.driven"),
    ("driven twice", _set(["joints", "driven"], lambda v: v + v[:1]), "joints.driven: 'waist_yaw' appears twice"),
    ("range missing", _set(["joints", "range_rad", "right_knee"], DELETE), "joints.range_rad.right_knee: missing"),
    ("range reversed", _set(["joints", "range_rad", "right_knee"], lambda v: v[::-1]),
     "joints.range_rad.right_knee: low must be below high"),
    ("range NaN", _set(["joints", "range_rad", "right_knee", 0], nan), "joints.range_rad.right_knee[0]: must be a finite number"),
    ("range 10 rad", _set(["joints", "range_rad", "right_knee", 1], 10.0), "joints.range_rad.right_knee[1]: must be within"),
    ("range a string", _set(["joints", "range_rad", "right_knee"], "0..2"), "joints.range_rad.right_knee: must be [low, high]"),
    ("hold a driven joint", _set(["joints", "hold_rad", "right_knee"], 0.0), "joints.hold_rad.right_knee: is a driven joint"),
    ("hold Infinity", _set(["joints", "hold_rad", "right_ankle_roll"], inf), "joints.hold_rad.right_ankle_roll: must be a finite"),
    ("output rule a number", _set(["joints", "output_rule"], 0.8), "joints.output_rule: must be one of"),
    ("joints extra key", _set(["joints", "gains"], {}), "joints.gains: unknown key"),
    ("task a string", _set(["task"], "walk"), "task: must be an object, got 'walk'"),
    ("task a list", _set(["task"], []), "task: must be an object, got []"),
    ("task NaN", _set(["task", "episode_s"], nan), "task.episode_s: must be a finite number, got NaN"),
    ("task Infinity", _set(["task", "episode_s"], inf), "task.episode_s: must be a finite number, got Infinity"),
    ("task control set a number", _set(["task", "control_set"], 5), "task.control_set: must be a non-empty string"),
    ("provenance null", _set(["provenance"], None), "provenance: must be an object, got None"),
    ("provenance nested Infinity", _set(["provenance", "fitness"], {"best": [1.0, -inf]}),
     "provenance.fitness.best[1]: must be a finite number, got -Infinity"),
    ("provenance odd key", _set(["provenance", "a b"], nan), "provenance['a b']: must be a finite number"),
]
# robot-dependent: the file is consistent in itself, but not with the robot it is run on
ROBOT_CASES = [
    ("control set of another robot", _set(["task", "control_set"], "fly"), "task.control_set: robot xl430_biped has no control set 'fly'"),
    ("not the task's control set", _set(["task", "control_set"], "all"), "joints.driven: lacks ['left_ankle_pitch', "
     "'left_ankle_roll', 'right_ankle_pitch', 'right_ankle_roll'] of robot xl430_biped's 'all' control set (task.control_set)"),
    ("leg outputs reordered with their inputs",
     (lambda d: [d["outputs"].__setitem__(slice(0, 2), d["outputs"][1::-1]),
                      d["inputs"].__setitem__(slice(0, 2), d["inputs"][1::-1]),
                      d["inputs"].__setitem__(slice(3, 5), d["inputs"][4:2:-1])]),
     "outputs[0]: is 'own_hip_pitch' where robot xl430_biped driving"),
    ("legs swapped", lambda d: d["symmetry"].__setitem__(
        "leg_joints", {"right": d["symmetry"]["leg_joints"]["left"], "left": d["symmetry"]["leg_joints"]["right"]}),
     "symmetry.leg_joints.right[0]: is 'left_hip_roll' where robot xl430_biped"),
    ("waist not mirrored", _set(["symmetry", "center_mirror_for_left", 0], 1.0),
     "symmetry.center_mirror_for_left: must be [-1.0] for robot xl430_biped"),
    ("range not the robot's", _set(["joints", "range_rad", "right_knee", 0], -0.5), "joints.range_rad.right_knee: [-0.5,"),
    ("hold of no such joint", _set(["joints", "hold_rad", "tail"], 0.0), "joints.hold_rad.tail: robot xl430_biped has no such joint"),
]


@pytest.mark.parametrize("name, mutate, expected", CASES, ids=[c[0] for c in CASES])
def test_a_broken_field_is_refused_by_name(valid, tmp_path, name, mutate, expected):
    data = copy.deepcopy(valid)
    mutate(data)
    message = refused(write(tmp_path, data))
    assert expected.match(message) if isinstance(expected, re.Pattern) else message.startswith(expected), message
    assert refused(write(tmp_path, data, "again.json"), robot=None) == message  # the robot adds nothing here


@pytest.mark.parametrize("name, mutate, expected", ROBOT_CASES, ids=[c[0] for c in ROBOT_CASES])
def test_a_file_that_does_not_fit_the_robot_is_refused_by_name(valid, tmp_path, name, mutate, expected):
    data = copy.deepcopy(valid)
    mutate(data)
    path = write(tmp_path, data)
    Controller.load(path)  # consistent in itself
    message = refused(path)
    assert message.startswith(expected), message


def test_a_controller_for_another_robot_is_refused(valid_path):
    assert refused(valid_path, load_robot("op3_legs")).startswith(
        "robot.joint_map_hash: made for robot 'xl430_biped'")


@pytest.mark.parametrize("key", ["robot", "inputs", "outputs", "bias", "symmetry", "sigmoid_steepness", "modules",
                                 "hidden", "connections", "joints", "task", "provenance"])
def test_every_required_field_missing_is_named(valid, tmp_path, key):
    data = copy.deepcopy(valid)
    del data[key]
    assert refused(write(tmp_path, data)) == f"{key}: missing"


def test_evolution_cannot_make_a_controller_the_format_refuses():
    for key, value in (("weight_limit", 5000.0), ("new_link_weight_range", 1e4), ("sigmoid_steepness", 200.0),
                       ("weight_sigma", math.inf)):
        with pytest.raises(ConfigError, match=f"neat.{key}: must be"):
            NeatConfig.from_mapping({key: value}, "run.yaml", "neat.")
    with pytest.raises(ConfigError, match="task.stagnation_s: must be finite"):
        TaskConfig.from_mapping({"stagnation_s": math.inf}, "run.yaml")


# -- bytes that are not a controller -------------------------------------------------------------
BYTE_CASES = {
    "undecodable.json": "not UTF-8 text (binary, or another encoding?): byte 0xfc at line 1 (offset 71)",
    "utf16.json": "not UTF-8 text (binary, or another encoding?): byte 0xff at line 1 (offset 0)",
    "gzipped.json": "not UTF-8 text (binary, or another encoding?): byte 0x8b at line 1 (offset 1)",
    "truncated.json": "not valid JSON (truncated?): Expecting ',' delimiter (line 8 column 28)",
    "empty.json": "not valid JSON (truncated?): Expecting value (line 1 column 1)",
    "not_an_object.json": "a controller file must hold a JSON object, got list",
    "deep.json": f"JSON nested 5001 levels deep (line 1); a controller nests at most {MAX_DEPTH}",
    "duplicate_key.json": "key 'tick_s' appears twice in one object (JSON keys must be unique)",
    "infinity_weight.json": "connections[0]: weight must be a finite number, got Infinity",
}


@pytest.mark.parametrize("name", sorted(BYTE_CASES))
def test_a_bad_file_is_one_line_naming_the_problem(name):
    assert refused(BAD_FILES / name) == BYTE_CASES[name]


def test_the_corpus_is_complete():
    assert sorted(p.name for p in BAD_FILES.iterdir()) == sorted(BYTE_CASES)


def test_deep_nesting_is_refused_before_decoding(tmp_path):
    path = tmp_path / "deep.json"
    path.write_text('{"task": ' + "[" * 100_000 + "]" * 100_000 + "}")
    assert refused(path) == f"JSON nested 100001 levels deep (line 1); a controller nests at most {MAX_DEPTH}"


def test_a_huge_file_is_refused_unread(tmp_path):
    path = tmp_path / "huge.json"
    with open(path, "wb") as f:
        f.truncate(50_000_000)  # sparse: 50 MB on paper, nothing to read
    start = time.perf_counter()
    assert refused(path).startswith(f"50000000 bytes is too large for a controller (at most {MAX_BYTES} bytes")
    assert time.perf_counter() - start < 0.5
    path.write_bytes(b" " * (MAX_BYTES + 1))
    assert refused(path).startswith(f"{MAX_BYTES + 1} bytes is too large")


@pytest.mark.skipif(not Path("/dev/zero").exists(), reason="needs /dev/zero")
def test_a_stream_without_a_size_is_refused_unread():
    assert refused(Path("/dev/zero")) == ("is a character device, not a regular file (a device such as /dev/zero "
                                          "never ends)")


def test_missing_file_and_directory(tmp_path):
    assert refused(tmp_path / "nope.json") == "cannot read: No such file or directory"
    assert refused(tmp_path) == "is a directory, not a file"


def test_numbers_beyond_json_are_named(valid_path, tmp_path):
    text = valid_path.read_text()
    for literal, shown in (("1e999", "inf"), ("-1e999", "-inf"), ("NaN", "NaN")):
        path = tmp_path / "n.json"
        path.write_text(text.replace('"tick_s": 0.034', f'"tick_s": {literal}'))
        assert refused(path) == f"tick_s: must be a finite number, got {shown}"
    path.write_text(text.replace('"tick_s": 0.034', '"tick_s": ' + "9" * 5000))
    assert refused(path).startswith("not valid JSON: Exceeds the limit (4300 digits)")


def test_a_byte_order_mark_is_accepted(valid_path, tmp_path):
    path = tmp_path / "bom.json"
    path.write_bytes(b"\xef\xbb\xbf" + valid_path.read_bytes())
    assert Controller.load(path, ROBOT) == Controller.load(valid_path, ROBOT)


def slow_depth(text: str) -> int:
    """Oracle of nesting_depth: a character-by-character scan."""
    depth = deepest = 0
    in_string = escaped = False
    for ch in text:
        if in_string:
            if escaped:
                escaped = False
            elif ch == "\\":
                escaped = True
            elif ch == '"':
                in_string = False
        elif ch == '"':
            in_string = True
        elif ch in "[{":
            depth += 1
            deepest = max(deepest, depth)
        elif ch in "]}":
            depth -= 1
    return deepest


JSON_SCALARS = st.one_of(
    st.none(), st.booleans(), st.integers(-2 ** 63, 2 ** 63),
    st.sampled_from([0, -1, 1, 2, 12, 17, 2 ** 31, -2 ** 31, 10 ** 30]),
    st.floats(allow_nan=True, allow_infinity=True),
    st.sampled_from([0.0, -0.0, 1e-300, 5e-324, 1e300, -1e300, 999.9, 1000.0, 1000.001, 0.5, -1.0]),
    st.text(alphabet='ab[]{}"\\\n\u00e9', max_size=8))
JSON_VALUES = st.recursive(JSON_SCALARS, lambda inner: st.lists(inner, max_size=4)
                           | st.dictionaries(st.text(alphabet='ab_[]"', max_size=5), inner, max_size=3), max_leaves=10)


@FUZZ
@given(value=JSON_VALUES, ascii_only=st.booleans())
def test_the_depth_scan_equals_a_plain_scan(value, ascii_only):
    text = json.dumps(value, ensure_ascii=ascii_only)
    assert nesting_depth(text.encode())[0] == slow_depth(text)


# -- the CLI: exit 2, one line, torque never on ---------------------------------------------------
@pytest.fixture
def bus_watch(monkeypatch):
    """Every MockBus `biped run` makes, and every call of drive."""
    import sim2real.hardware
    import sim2real.hardware.deploy

    watch = {"buses": [], "drives": 0}

    class WatchedBus(sim2real.hardware.MockBus):
        def __init__(self, robot, *args, **kwargs):
            super().__init__(robot, *args, **kwargs)
            self.torque_address = robot.joints[0].servo.profile.register("torque_enable").address
            watch["buses"].append(self)

        def torque_was_on(self) -> bool:
            return any(addr == self.torque_address and value for _, addr, value in self.writes)

    real_drive = sim2real.hardware.deploy.drive

    def counted_drive(*args, **kwargs):
        watch["drives"] += 1
        return real_drive(*args, **{**kwargs, "ramp_s": 0.02})

    monkeypatch.setattr(sim2real.hardware, "MockBus", WatchedBus)
    monkeypatch.setattr(sim2real.hardware.deploy, "drive", counted_drive)
    return watch


def biped_run(path: Path, capsys, *extra: str) -> tuple[int, str]:
    from evolve.cli import main

    capsys.readouterr()
    code = main(["run", str(path), "--bus", "mock", "--duration", "0.1", *extra])
    return code, capsys.readouterr().err


def test_biped_run_on_a_valid_controller_turns_torque_on_and_off(valid_path, capsys, bus_watch):
    code, err = biped_run(valid_path, capsys)
    assert code == 0, err
    assert bus_watch["drives"] == 1 and len(bus_watch["buses"]) == 1
    bus = bus_watch["buses"][0]
    assert bus.torque_was_on()  # the watch sees torque when there is some
    assert all(d.get_named("torque_enable") == 0 for d in bus.devices.values() if d.profile.is_servo)


CLI_CASES = ["tick zero", "weight Infinity", "weight huge", "outputs extra", "bias empty", "hidden an integer",
             "hidden id true", "module disabled", "task NaN"]


@pytest.mark.parametrize("name", CLI_CASES)
def test_biped_run_refuses_a_bad_field_before_any_servo_moves(valid, tmp_path, capsys, bus_watch, name):
    _, mutate, expected = next(c for c in CASES if c[0] == name)
    data = copy.deepcopy(valid)
    mutate(data)
    path = write(tmp_path, data)
    code, err = biped_run(path, capsys)
    assert code == 2
    assert err.count("\n") == 1 and err.startswith(f"biped: error: {path}: {expected}"), err
    assert bus_watch["drives"] == 0 and not any(bus.torque_was_on() for bus in bus_watch["buses"])


@pytest.mark.parametrize("name", ["undecodable.json", "deep.json", "truncated.json", "empty.json"])
def test_biped_run_refuses_a_bad_file_before_any_servo_moves(capsys, bus_watch, name):
    code, err = biped_run(BAD_FILES / name, capsys)
    assert code == 2 and err == f"biped: error: {BAD_FILES / name}: {BYTE_CASES[name]}\n"
    assert bus_watch["drives"] == 0 and not bus_watch["buses"]


def test_biped_run_refuses_a_huge_file_and_another_robot(valid_path, tmp_path, capsys, bus_watch):
    huge = tmp_path / "huge.json"
    with open(huge, "wb") as f:
        f.truncate(50_000_000)
    code, err = biped_run(huge, capsys)
    assert code == 2 and err.startswith(f"biped: error: {huge}: 50000000 bytes is too large") and err.count("\n") == 1
    code, err = biped_run(valid_path, capsys, "--robot", "op3_legs")
    assert code == 2 and err.startswith(f"biped: error: {valid_path}: robot.joint_map_hash: made for robot")
    assert bus_watch["drives"] == 0 and not bus_watch["buses"]


def test_every_command_that_reads_a_controller_refuses_it_first(valid, tmp_path, capsys):
    from evolve.cli import main

    data = copy.deepcopy(valid)
    data["outputs"].append("own_ankle_pitch")
    bad = write(tmp_path, data, "controller.json")
    trace = tmp_path / "trace.csv"
    names = ROBOT.joint_names
    columns = ["time_s", *[f"{n}_present_rad" for n in names], *[f"{n}_goal_rad" for n in names],
               "foot_left", "foot_right", "up_x", "up_y", "up_z"]
    trace.write_text(",".join(columns) + "\n" + ",".join(["0"] * (len(columns) - 1) + ["1"]) + "\n")
    commands = [["dry-run", str(bad), "--duration", "0.1"], ["run", str(bad), "--duration", "0.1"],
                ["eval", str(bad), "--seconds", "0.1"], ["export", str(tmp_path), "-o", str(tmp_path / "out.json")],
                ["render", str(bad), "-o", str(tmp_path / "walk.gif")], ["compare", str(trace), "--controller", str(bad)]]
    for argv in commands:
        capsys.readouterr()
        assert main(argv) == 2, argv
        err = capsys.readouterr().err
        assert err == f"biped: error: {bad}: outputs: has 5 names where the symmetry block (3 leg joints, " \
                      f"centre joints ['waist_yaw']) has 4: ['own_hip_roll', 'own_hip_pitch', 'own_knee', " \
                      f"'waist_yaw']\n", (argv, err)
    assert not (tmp_path / "out.json").exists() and not (tmp_path / "walk.gif").exists()


# -- whatever passes, runs --------------------------------------------------------------------------
@st.composite
def mutated(draw, base: dict):
    """The valid controller with up to three new weights (the format's extremes included),
    then up to two random edits: a field (at any depth) replaced by a random JSON value or
    an extreme number, deleted, or a list grown by one."""
    doc = copy.deepcopy(base)
    for _ in range(draw(st.integers(0, 3))):
        conn = doc["connections"][draw(st.integers(0, len(doc["connections"]) - 1))]
        conn[2] = draw(st.floats(-MAX_WEIGHT, MAX_WEIGHT) | st.sampled_from([MAX_WEIGHT, -MAX_WEIGHT, 0]))
    for _ in range(draw(st.integers(0, 2))):
        parent, key = None, None
        node = doc
        while isinstance(node, (dict, list)) and node and (key is None or draw(st.booleans())):
            parent, key = node, draw(st.sampled_from(sorted(node) if isinstance(node, dict) else range(len(node))))
            node = parent[key]
        if parent is None:
            continue
        kind = draw(st.sampled_from(["replace", "extreme", "delete", "grow"]))
        if kind == "replace":
            parent[key] = draw(JSON_VALUES)
        elif kind == "extreme":
            parent[key] = draw(st.sampled_from([0, -1, 1, True, False, None, 1e308, -1e308, 1e-308, nan, inf, -inf,
                                                2 ** 31, -(2 ** 31), 10 ** 40, 1000.0, -1000.0, 1001.0, "", []]))
        elif kind == "delete":
            del parent[key]
        elif isinstance(node, list):
            node.append(copy.deepcopy(node[draw(st.integers(0, len(node) - 1))]) if node and draw(st.booleans())
                        else draw(JSON_VALUES))
    return doc


# the format's bounds on the tick (a file alone), and the robot's (a file bound to its robot)
@pytest.mark.parametrize("tick_s, robot", [(t, None) for t in TICK_RANGE_S] + [(t, ROBOT) for t in tick_bounds(ROBOT)[:2]])
def test_the_extremes_the_format_allows_run_with_finite_goals(valid, tmp_path, tick_s, robot):
    data = copy.deepcopy(valid)
    data.update(tick_s=tick_s, sigmoid_steepness=MAX_STEEPNESS, bias=[[-1.0, 1.0], [1.0, -1.0]])
    for k, conn in enumerate(data["connections"]):
        conn[2] = MAX_WEIGHT if k % 3 else -MAX_WEIGHT
    policy = Policy(Controller.load(write(tmp_path, data), robot), ROBOT)
    goal = policy.reset()
    for k in range(50):
        angles = policy.high if k % 2 else policy.low  # the servos at their limits
        goal = policy.step(angles, np.array([k % 3 == 0, k % 2 == 0]), np.array([0.0, -1.0, 0.0]), goal)
        assert np.all(np.isfinite(goal)) and np.all(goal >= policy.low) and np.all(goal <= policy.high)


@pytest.fixture(scope="module")
def fuzz_dir(tmp_path_factory) -> Path:
    return tmp_path_factory.mktemp("fuzz")


@FUZZ
@given(data=st.data())
def test_whatever_the_check_lets_through_runs_and_gives_finite_goals(data, valid, fuzz_dir):
    doc = data.draw(mutated(valid))
    path = fuzz_dir / "c.json"
    path.write_text(json.dumps(doc))
    try:
        controller = Controller.load(path, ROBOT)
    except ConfigError as exc:
        assert "\n" not in str(exc) and str(exc).startswith(f"{path}: ")
        return
    jsonschema.validate(controller.to_dict(), SCHEMA)  # the schema is no stricter than the check
    policy = Policy(controller, ROBOT)
    rng = np.random.default_rng(0)
    goal = policy.reset()
    for _ in range(5):
        up = rng.normal(size=3)
        goal = policy.step(rng.uniform(policy.low, policy.high), rng.random(2) < 0.5, up / np.linalg.norm(up), goal)
        assert np.all(np.isfinite(goal)) and np.all(goal >= policy.low) and np.all(goal <= policy.high)
    # the evolution side (eval, view, render) builds the same network from it
    genome = genome_from_controller(controller)
    net = PopulationNetwork([genome, genome], controller.sigmoid_steepness, bias_values=bias_values(1))
    assert np.all(np.isfinite(net.activate(rng.uniform(-1, 1, (2, len(controller.inputs))))))


@FUZZ
@given(cut=st.integers(0, 4000), flips=st.lists(st.tuples(st.integers(0, 4000), st.integers(0, 255)), max_size=4),
       insert=st.sampled_from([b"", b"[", b"{", b'"', b"\\", b"NaN", b"-Infinity", b"1e999", b"\xff", b"]]]", b",,"]))
def test_damaged_bytes_give_a_config_error_or_a_controller(cut, flips, insert, valid_path, fuzz_dir):
    raw = bytearray(valid_path.read_bytes())
    for at, value in flips:
        raw[at % len(raw)] = value
    raw[cut % len(raw):cut % len(raw)] = insert
    path = fuzz_dir / "bytes.json"
    path.write_bytes(bytes(raw))
    try:
        Controller.load(path, ROBOT)
    except ConfigError as exc:
        assert "\n" not in str(exc)


def _with_inputs(valid: dict, names: list[str], **fields) -> dict:
    """``valid`` with more inputs at the end (node ids past the inputs move up) and ``fields``."""
    data = {**copy.deepcopy(valid), **fields}
    data["inputs"] = data["inputs"] + names
    n_in, extra = len(valid["inputs"]), len(names)
    data["hidden"] = [[node + extra, module] for node, module in data["hidden"]]
    data["connections"] = [[s + extra if s >= n_in else s, d + extra, w, m] for s, d, w, m in data["connections"]]
    return data


def _with_clock(valid: dict, period_s=0.6) -> dict:
    return _with_inputs(valid, ["phase_sin", "phase_cos"], phase_period_s=period_s)


@pytest.mark.parametrize("mutate, expected", [
    (lambda d: d.pop("phase_period_s"), r"inputs: has 13 names where .*a clock input needs a phase_period_s.* has 11"),
    (lambda d: d.update(phase_period_s=0.01), r"phase_period_s: must be within \[0.05, 10\], got 0.01"),
    (lambda d: d.update(phase_period_s=True), "phase_period_s: must be a number"),
    (lambda d: d.update(inputs=d["inputs"][:-2] + ["phase_cos", "phase_sin"]), r"inputs\[11\]: is .phase_cos."),
], ids=["clock-inputs-without-period", "period-too-short", "period-not-a-number", "clock-inputs-swapped"])
def test_a_broken_clock_is_refused_by_name(valid, mutate, expected):
    data = _with_clock(valid)
    mutate(data)
    with pytest.raises(ConfigError, match=expected):
        Controller.from_dict(data, "clock.json", ROBOT)


def test_a_period_without_the_clock_inputs_is_refused(valid):
    data = copy.deepcopy(valid)
    data["phase_period_s"] = 0.6
    with pytest.raises(ConfigError, match=r"inputs: has 11 names where .*the clock \(phase_period_s\).* has 13"):
        Controller.from_dict(data, "clock.json")


def _with_efference(valid: dict) -> dict:
    joints = valid["inputs"][:valid["inputs"].index("own_foot")]
    return _with_inputs(valid, [name + "_goal" for name in joints], efference_copy=True)


def _with_heading(valid: dict) -> dict:
    return _with_inputs(valid, ["heading"], heading_input=True, heading_scale_deg=45.0)


@pytest.mark.parametrize("extend, has", [
    (_with_clock, lambda c: c.phase_period_s == 0.6 and "clock" in c.layout(ROBOT).inputs),
    (_with_efference, lambda c: c.efference_copy and c.layout(ROBOT).efference),
    (_with_heading, lambda c: c.heading_input and c.input_channels["heading"]["heading_scale_deg"] == 45.0
     and c.layout(ROBOT).heading),
], ids=["clock", "efference-copy", "heading"])
def test_a_controller_with_more_inputs_round_trips_and_fits_its_robot(valid, tmp_path, extend, has):
    data = extend(valid)
    jsonschema.validate(data, SCHEMA)
    path = tmp_path / "more.json"
    Controller.from_dict(data).save(path)
    assert has(Controller.load(path, ROBOT))
    assert json.loads(path.read_text()) == data


@pytest.mark.parametrize("extend, mutate, expected", [
    (_with_efference, lambda d: d.pop("efference_copy"),
     r"inputs: has 18 names where .*needs efference_copy: true.* has 11"),
    (_with_efference, lambda d: d.update(efference_copy="yes"), r"efference_copy: must be true or false, got 'yes'"),
    (_with_efference, lambda d: d.update(inputs=d["inputs"][:-1]),
     r"inputs: has 17 names where .*then the efference \(efference_copy\)"),
    (_with_heading, lambda d: d.update(heading_input=False),
     r"heading_scale_deg: is the heading input's setting: give it only with heading_input: true"),
    (_with_heading, lambda d: (d.pop("heading_input"), d.pop("heading_scale_deg")),
     r"inputs: has 12 names where .*a heading input needs heading_input: true.* has 11"),
    (_with_heading, lambda d: d.update(heading_scale_deg=0), r"heading_scale_deg: must be within \(0, 180\], got 0"),
    (_with_heading, lambda d: d.update(heading_scale_deg=270.0),
     r"heading_scale_deg: must be within \(0, 180\], got 270"),
    (_with_heading, lambda d: d.update(heading_input=1), r"heading_input: must be true or false, got 1"),
    (_with_heading, lambda d: d.update(inputs=d["inputs"][:-1]),
     r"inputs: has 11 names where .*the heading \(heading_input\)"),
], ids=["goals-without-flag", "efference-flag-not-a-boolean", "a-goal-missing",
        "heading-scale-without-input", "heading-without-flag", "heading-scale-zero", "heading-scale-too-large",
        "heading-flag-not-a-boolean", "heading-missing"])
def test_a_broken_input_option_is_refused_by_name(valid, extend, mutate, expected):
    data = extend(valid)
    mutate(data)
    with pytest.raises(ConfigError, match=expected):
        Controller.from_dict(data, "inputs.json", ROBOT)


def test_a_shipped_controller_carries_what_made_it_and_not_the_trainers_run_folder(tmp_path):
    source = tmp_path / "walker.json"
    data = Controller.load(Path("configs/controllers/xl430_biped.json")).to_dict()
    data["provenance"] = {**data["provenance"], "run": "/home/someone/runs/seed1"}
    Controller.from_dict(data, str(source)).save(source)
    made = {"made_by": "biped train xl430_biped", "walk_rate": {"robots": 50, "walked": 49}}
    shipped = Controller.ship(source, tmp_path / "shipped.json", made)
    provenance = json.loads(Path(shipped).read_text())["provenance"]
    assert "run" not in provenance and provenance["made_by"] == made["made_by"]
    assert provenance["walk_rate"] == made["walk_rate"]
    again = Controller.load(shipped).to_dict()  # the network is the source's, bit for bit
    assert {k: v for k, v in again.items() if k != "provenance"} == \
        {k: v for k, v in Controller.load(source).to_dict().items() if k != "provenance"}

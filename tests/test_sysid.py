"""System identification: excitation programs, their runs through the bus layer, the richer
robot behind the simulated bus, and the fit (``biped excite``, ``biped sysid``)."""

import json
import math

import numpy as np
import pytest

from sim2real.controller.mapping import ServoMapping
from sim2real.errors import ConfigError, UsageError
from sim2real.hardware import MockBus
from sim2real.hardware.deploy import drive
from sim2real.hardware.dynamixel.registers import Reg
from sim2real.hardware.excitation import ExcitationSettings, build_program, joint_groups
from sim2real.hardware.trace import Trace, TraceWriter
from sim2real.robot import load_robot
from sim2real.simulation.reality.file import load_reality, parse_reality

ROBOT = load_robot()
SHORT = ExcitationSettings(chirp_s=4.0, f0_hz=0.5, f1_hz=8.0, step_deg=(3.0, 15.0), step_hold_s=0.3, hold_s=0.3,
                           ramp_s=0.5, tick_s=0.01)


# -- the program --------------------------------------------------------------------------------
@pytest.mark.parametrize("robot_name", ["xl430_biped", "op3_legs"])
@pytest.mark.parametrize("pose", ["suspended", "standing"])
def test_program_stays_inside_the_limits_and_starts_and_ends_at_home(robot_name, pose):
    robot = load_robot(robot_name)
    program = build_program(robot, pose)
    low = np.array([j.range_rad[0] for j in robot.joints])
    high = np.array([j.range_rad[1] for j in robot.joints])
    margin = math.radians(program.settings.margin_deg)
    assert np.all(program.goals >= low + margin - 1e-9) and np.all(program.goals <= high - margin + 1e-9)
    np.testing.assert_allclose(program.goals[0], program.hold)
    np.testing.assert_allclose(program.goals[-1], program.hold)
    np.testing.assert_allclose(program.step(None, None, None, None, tick=len(program.goals) + 5), program.hold)
    # every servo joint is excited, and no faster than the chirp's speed cap allows
    moved = np.ptp(program.goals, axis=0)
    assert np.all(moved > math.radians(1.0)), dict(zip(robot.joint_names, np.degrees(moved)))
    chirps = [s for s in program.segments if s.kind == "chirp"]
    for seg in chirps:
        speeds = np.abs(np.diff(program.goals[seg.start:seg.end], axis=0)) / program.tick_s
        cap = program.settings.speed_share * min(j.servo.profile.motor.no_load_speed_rad_s for j in robot.joints)
        assert speeds.max() <= 1.15 * cap  # a finite difference of the sine, a little above its peak


def test_pairs_move_parallel_in_the_world_and_other_joints_hold():
    program = build_program(ROBOT, joints=["hip_roll", "knee"], settings=SHORT)
    index = {n: k for k, n in enumerate(ROBOT.joint_names)}
    roll = program.goals[:, [index["right_hip_roll"], index["left_hip_roll"]]]
    knee = program.goals[:, [index["right_knee"], index["left_knee"]]]
    np.testing.assert_allclose(roll[:, 0], -roll[:, 1])  # anatomical angles mirrored: same way in the world
    np.testing.assert_allclose(knee[:, 0], knee[:, 1])
    still = [k for n, k in index.items() if "hip_roll" not in n and "knee" not in n]
    np.testing.assert_allclose(program.goals[:, still], np.tile(program.hold[still], (len(program.goals), 1)))
    assert {s.group for s in program.segments} == {"hip_roll", "knee"}


def test_program_refuses_what_it_cannot_do():
    with pytest.raises(UsageError, match="'elbow'"):
        joint_groups(ROBOT, ["elbow"])
    with pytest.raises(UsageError, match="at least four goals a period"):
        build_program(ROBOT, settings=ExcitationSettings(tick_s=0.034))
    with pytest.raises(UsageError, match="pose"):
        build_program(ROBOT, pose="lying")


def test_program_drives_the_mock_bus_safely_and_traces_itself(tmp_path):
    program = build_program(ROBOT, joints=["knee"], settings=SHORT)
    bus = MockBus(ROBOT)
    report = drive(bus, ROBOT, program, duration_s=program.duration_s, trace_path=tmp_path / "k.csv",
                   log=lambda line: None, ramp_s=0.05)
    assert report.stop_reason == "duration reached"
    assert sorted(report.torque_off.confirmed) == sorted(j.servo.id for j in ROBOT.joints)
    trace = Trace.read(tmp_path / "k.csv")
    assert trace.metadata["excitation"]["pose"] == "suspended"
    assert [s["group"] for s in trace.metadata["excitation"]["segments"]] == ["knee", "knee"]
    ticks = trace["tick"].astype(int)
    np.testing.assert_allclose(trace.goals(ROBOT.joint_names), program.goals[ticks], atol=2e-6)


# -- the reality vocabulary --------------------------------------------------------------------------
def test_reality_files_take_per_joint_values_latency_in_ms_and_effects():
    r = parse_reality({"kp_scale": 0.9, "latency_ms": 7.5, "joints": {"left_knee": {"kp_scale": 1.2}},
                       "stribeck_nm": 0.05}, "r.yaml")
    assert r.joint_range("left_knee", "kp_scale") == (1.2, 1.2) and r.joint_range("right_knee", "kp_scale") == (0.9, 0.9)
    assert r.effects == ["stribeck_nm"] and "latency_ms" in r.perturbed
    assert parse_reality(r.to_dict(), "again").to_dict() == r.to_dict()
    with pytest.raises(ConfigError, match="joints.left_knee.mass_scale"):
        parse_reality({"joints": {"left_knee": {"mass_scale": 1.1}}}, "r.yaml")
    with pytest.raises(ConfigError, match="stribeck_nm"):
        r.check_batchable()


def test_a_joint_unknown_to_the_robot_is_named(tmp_path):
    from evolve.locomotion.evaluator import LocomotionEvaluator
    from evolve.locomotion.task import TaskConfig

    reality = parse_reality({"joints": {"left_elbow": {"kp_scale": 1.1}}}, "r.yaml", "r")
    with pytest.raises(ConfigError, match="left_elbow"):
        evaluator = LocomotionEvaluator(ROBOT, TaskConfig(episode_s=0.1), 1, threads=1, reality=reality)
        evaluator.sample(np.array([[0, 0]]))
    with pytest.raises(ConfigError, match="supply_sag"):
        LocomotionEvaluator(ROBOT, TaskConfig(episode_s=0.1), 1, threads=1,
                            reality=parse_reality({"supply_sag": 0.1}, "r.yaml", "r"))


def test_servo_effects_raise_friction_at_rest_and_with_load():
    from sim2real.simulation.simbus.physics import PhysicsChain

    plain = PhysicsChain(ROBOT, clock=lambda: 0.0, suspended=True)
    rich = PhysicsChain(ROBOT, clock=lambda: 0.0, suspended=True,
                        reality=parse_reality({"stribeck_nm": 0.05, "load_friction": 0.1, "supply_sag": 0.2}, "r"))
    assert plain.effects is None
    dofs = rich.angles.servo_dof
    rich.data.actuator_force[:] = 1.0
    rich.effects.apply(rich.model, rich.data)
    np.testing.assert_allclose(rich.model.dof_frictionloss[dofs], plain.model.dof_frictionloss[dofs] + 0.05 + 0.1)
    assert np.all(rich.model.actuator_forcerange[:, 1] < plain.model.actuator_forcerange[:, 1])


# -- the fit -----------------------------------------------------------------------------------------
def simulated_trace(path, program, reality=None, seed=0):
    """The program run on the simulated bus's physics on a simulated clock (no pseudo-terminal,
    no real time): what `biped excite --bus sim` records, deterministically and fast."""
    from sim2real.simulation.simbus.physics import PhysicsChain

    now = [0.0]
    chain = PhysicsChain(ROBOT, clock=lambda: now[0], reality=load_reality(reality), seed=seed, suspended=True)
    mapping = ServoMapping(ROBOT)
    for dxl_id in chain.ids:
        chain.devices[dxl_id].set_named(Reg.TORQUE_ENABLE, 1)
    writer = TraceWriter(path, ROBOT.joint_names, {"robot": ROBOT.name, **program.trace_metadata(),
                                                   "tick_s": program.tick_s})
    for tick in range(len(program.goals)):
        now[0] = tick * program.tick_s
        chain.advance()
        present = mapping.angles(np.array([chain.devices[i].get_named(Reg.PRESENT_POSITION) for i in chain.ids]))
        goal = program.step(present, None, None, None, tick)
        for k, value in zip(chain.ids, mapping.ticks(goal)):
            chain.devices[k].set_named(Reg.GOAL_POSITION, int(value))
        writer.write(now[0], tick, goal, present, np.zeros(2), np.array([0, 0, 1.0]), 0.0, 0.0, False)
    writer.close()
    return path


@pytest.fixture(scope="module")
def hung_traces(tmp_path_factory):
    """Short excitations of two joint pairs on a robot off the model (no richer effects)."""
    folder = tmp_path_factory.mktemp("sysid")
    truth = {"kp_scale": 0.9, "torque_scale": 0.85, "damping_scale": 1.15, "friction_scale": 1.2,
             "armature_scale": 1.1, "backlash_deg": 0.3, "latency_ms": 8.0}
    (folder / "truth.yaml").write_text(json.dumps(truth))
    program = build_program(ROBOT, joints=["hip_pitch", "knee"], settings=SHORT)
    return truth, simulated_trace(folder / "hung.csv", program, folder / "truth.yaml")


def test_sysid_recovers_a_profile_and_writes_a_reality_file(hung_traces):
    pytest.importorskip("scipy")
    from sim2real.simulation.identify import identify

    truth, trace = hung_traces
    found = identify([trace], ROBOT, max_iters=40, log=lambda line: None)
    values = {name.split("/")[-1]: p["value"] for name, p in found.parameters.items()}
    for key in ("kp_scale", "torque_scale", "damping_scale", "friction_scale"):
        assert values[key] == pytest.approx(truth[key], rel=0.1), key
    assert abs(values["backlash_deg"] - truth["backlash_deg"]) <= 0.1
    assert abs(values["latency_ms"] - truth["latency_ms"]) <= 2.0  # a simulated clock: no bus delay
    for joint in ("right_knee", "left_hip_pitch"):
        assert found.rmse_deg_after[joint] <= min(1.0, 0.5 * found.rmse_deg_before[joint])
    reality = parse_reality(found.reality, "identified")  # a reality file, as written
    assert reality.range("kp_scale")[0] == pytest.approx(values["kp_scale"], abs=1e-3)


def test_sysid_refuses_traces_it_cannot_fit(tmp_path, hung_traces):
    from sim2real.simulation.identify import check_traces

    _, trace = hung_traces
    original = Trace.read(trace)
    meta = dict(original.metadata)

    def write(name, rows, metadata):
        path = tmp_path / name
        writer = TraceWriter(path, ROBOT.joint_names, metadata)
        goals, present = original.goals(ROBOT.joint_names), original.present(ROBOT.joint_names)
        for k in rows:
            writer.write(original.times[k], k, goals[k] if name != "still.csv" else goals[0], present[k],
                         np.zeros(2), np.array([0, 0, 1.0]), 0, 0, False)
        writer.close()
        return path

    with pytest.raises(ConfigError, match="op3_legs"):
        check_traces([write("other.csv", range(len(original)), {**meta, "robot": "op3_legs"})], ROBOT)
    with pytest.raises(ConfigError, match="too short"):
        check_traces([write("short.csv", range(50), meta)], ROBOT)
    with pytest.raises(ConfigError, match="no excitation"):
        check_traces([write("still.csv", range(len(original)), meta)], ROBOT)
    with pytest.raises(ConfigError, match="standing"):
        check_traces([write("standing.csv", range(len(original)),
                            {**meta, "excitation": {**meta["excitation"], "pose": "standing"}})], ROBOT)
    nan = tmp_path / "nan.csv"
    text = trace.read_text().splitlines()
    text[20] = text[20].replace(text[20].split(",")[5], "nan", 1)
    nan.write_text("\n".join(text) + "\n")
    (tmp_path / "nan.json").write_text(trace.with_suffix(".json").read_text())
    with pytest.raises(ConfigError, match="row 21"):
        check_traces([nan], ROBOT)
    cut = tmp_path / "cut.csv"  # a run killed mid-write: its last row half written
    cut.write_text(trace.read_text()[:-40])
    (tmp_path / "cut.json").write_text(trace.with_suffix(".json").read_text())
    warnings = []
    assert len(check_traces([cut], ROBOT, warn=warnings.append)[0]) == len(original) - 1
    assert len(warnings) == 1 and "cut short" in warnings[0]


def test_ranges_around_an_identified_robot_round_trip_and_ramp_from_it(tmp_path):
    from evolve.config import parse_randomize
    from sim2real.simulation.reality.file import centred

    (tmp_path / "mine.yaml").write_text("kp_scale: 0.8\nlatency_ms: 12.0\njoints: {left_knee: {damping_scale: 1.5}}\n")
    ranges, mine = load_reality("randomize"), load_reality(tmp_path / "mine.yaml")
    around = centred(ranges, mine)
    lo, hi = ranges.range("kp_scale")
    assert around.range("kp_scale") == pytest.approx((0.8 * lo, 0.8 * hi))  # scales multiply
    assert around.range("latency_ms") == (12.0, 12.0)  # the rest adds
    assert around.joint_range("left_knee", "damping_scale") == pytest.approx(tuple(1.5 * v for v in ranges.range("damping_scale")))
    again = parse_reality(around.to_dict(), "again")
    assert again.ranges == around.ranges and again.joint_ranges == around.joint_ranges
    start = around.scaled(0.0)  # evolution's ramp starts at the identified robot, not the nominal one
    assert start.range("kp_scale") == pytest.approx((0.8, 0.8)) and start.range("mass_scale") == (1.0, 1.0)
    assert start.joint_range("left_knee", "damping_scale") == pytest.approx((1.5, 1.5))
    config = parse_randomize({"reality": "randomize", "centre": str(tmp_path / "mine.yaml"), "episodes": 2}, "c.yaml")
    assert load_reality(config.profile).ranges == around.ranges
    with pytest.raises(ConfigError, match="fixed values"):
        parse_randomize({"reality": "randomize", "centre": "randomize"}, "c.yaml")


def test_compare_replays_an_excitation_on_the_hung_robot_of_a_reality_file(hung_traces, tmp_path):
    from sim2real.simulation.transfer.compare import compare

    truth, trace = hung_traces
    (tmp_path / "truth.yaml").write_text(json.dumps(truth))
    nominal = compare(trace)
    true = compare(trace, reality=tmp_path / "truth.yaml")
    assert nominal["suspended"] and true["reality"] == "truth"
    knee = ("right_knee", "left_hip_pitch")
    assert all(true["joints"][j]["rmse_deg"] < 0.5 * nominal["joints"][j]["rmse_deg"] for j in knee)


def test_biped_excite_on_the_simulated_bus_and_its_bad_inputs(tmp_path, capsys):
    from evolve.cli import main

    trace = tmp_path / "knee.csv"
    assert main(["excite", "--joints", "knee", "--chirp-s", "2.5", "--steps", "5", "--trace", str(trace),
                 "--no-realtime", "--json"]) == 0
    result = json.loads(capsys.readouterr().out.strip().splitlines()[-1])
    assert result["stop_reason"] == "duration reached" and not result["torque_off"]["unconfirmed"]
    recorded = Trace.read(trace)
    assert recorded.metadata["excitation"]["settings"]["chirp_s"] == 2.5
    moved = np.degrees(np.ptp(recorded.present(["right_knee", "left_knee", "right_hip_pitch"]), axis=0))
    assert moved[0] > 5 and moved[1] > 5 and moved[2] < 1  # the knees moved, the hips held
    # velocities and loads traced too, in the joint's frame: velocity follows the angle's slope
    velocity, load = recorded["right_knee_velocity_rad_s"], recorded["right_knee_load"]
    slope = np.gradient(recorded["right_knee_present_rad"], recorded.times)
    assert np.corrcoef(velocity, slope)[0, 1] > 0.8
    assert 0 < np.abs(load).max() <= 1.0
    assert next(c.unit for c in recorded.channels if c.name == "right_knee_velocity_rad_s") == "rad/s"
    for argv, problem in ((["--joints", "elbow"], "elbow"), (["--port", "/dev/null", "--reality", "default"], "--reality"),
                          (["--baud", "57600"], "--baud"), (["--tick-ms", "40"], "four goals")):
        assert main(["excite", *argv, "--trace", str(tmp_path / "x.csv")]) == 2
        assert problem in capsys.readouterr().err


def test_sysid_per_joint_refines_each_moving_pair_and_flags_the_joints_it_never_saw(hung_traces, tmp_path, capsys):
    pytest.importorskip("scipy")
    from evolve.cli import main

    _, trace = hung_traces
    out = tmp_path / "per_joint.yaml"
    assert main(["sysid", str(trace), "--per-joint", "--max-iters", "6", "-o", str(out), "--json"]) == 0
    result = json.loads(capsys.readouterr().out.strip().splitlines()[-1])
    moved = {"right_knee", "left_knee", "right_hip_pitch", "left_hip_pitch"}
    for name, p in result["parameters"].items():
        joint = name.split("/")[0]
        if joint in ROBOT.joint_names:
            assert p["identifiable"] == (joint in moved), name  # the hip rolls, ankles, waist: never excited
    for joint in moved:
        assert result["rmse_deg_after"][joint] < 0.5 * result["rmse_deg_before"][joint]
    reality = load_reality(out)  # what it wrote: per joint values, a latency for the bus
    assert set(reality.joint_ranges) == set(ROBOT.joint_names) and reality.range("latency_ms")[0] > 0
    knee = result["parameters"]["left_knee/kp_scale"]["value"]
    assert reality.joint_range("left_knee", "kp_scale")[0] == pytest.approx(knee, abs=1e-4)

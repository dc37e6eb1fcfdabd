"""``biped robot``: ``show``, ``stand``, ``mjcf`` and ``import`` - describe a robot, check
that it stands, export its MuJoCo model, or write a robot YAML from a model file.

:mod:`evolve.cli` assembles these with the other commands into one ``biped`` program
(``view`` and ``render`` of a robot: :mod:`sim2real.cli.view_commands`).  Heavy imports
(MuJoCo) happen inside the commands so that ``biped --help`` is instant and the deploy path
runs without them.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import textwrap
from pathlib import Path

from sim2real.cli.args import check_input_file, output_file
from sim2real.errors import ConfigError, UsageError
from sim2real.robot import DEFAULT_ROBOT, RobotSpec, available_robots, load_robot
from sim2real.robot.bus_plan import id_list

ROBOT_HELP = (
    f"robot name from configs/robots/ ({', '.join(available_robots())}; presets as "
    f"human:male_95) or a path to a robot YAML (default: {DEFAULT_ROBOT})"
)


def add_commands(sub: argparse._SubParsersAction) -> None:
    """``robot`` and its subcommands ``show``, ``stand``, ``mjcf``, ``import``."""
    robot = sub.add_parser("robot", help="describe a robot or export its MuJoCo model",
                           description="Describe a robot config or export its MuJoCo model.")
    rsub = robot.add_subparsers(dest="robot_command", required=True, metavar="{show,stand,mjcf,import}")
    show = rsub.add_parser("show", help="joints, servos, masses, control tick and torque margins",
                           description="Print the robot's joints, servos, masses, height, the control "
                           "tick with its derivation, and each joint's torque margin in a half crouch.")
    show.add_argument("robot", nargs="?", default=DEFAULT_ROBOT, help=ROBOT_HELP)
    show.add_argument("--json", action="store_true", help="print one JSON object instead of a table")
    show.set_defaults(func=cmd_robot_show)
    _add_stand(rsub)

    mjcf = rsub.add_parser("mjcf", help="write the robot as self-contained MJCF",
                           description="Write self-contained MJCF: one position actuator per servo, "
                           "named after its joint, and a keyframe 'home' with the standing pose.")
    mjcf.add_argument("robot", nargs="?", default=DEFAULT_ROBOT, help=ROBOT_HELP)
    mjcf.add_argument("-o", "--output", type=output_file(), help="output file (default: stdout)")
    mjcf.set_defaults(func=cmd_robot_mjcf)
    _add_import(rsub)


def robot_arg(name: str) -> RobotSpec:
    """The robot a positional ROBOT names, its file checked first (a FIFO would block the read),
    measured (every command that takes one simulates it)."""
    from sim2real.simulation.model.physique import measured

    if name.split(":", 1)[0] not in available_robots():  # a project robot's name is that robot, whatever the cwd holds
        check_input_file(name)
    return measured(load_robot(name))


# -- robot show -------------------------------------------------------------------------------
def describe(robot: RobotSpec) -> dict:
    """Everything ``biped robot show --json`` prints (SI units)."""
    from sim2real.robot.timing import control_timing
    from sim2real.simulation.model.builder import build_model
    from sim2real.simulation.standing.statics import CROUCH_KNEE_DEG, holding_torques

    from sim2real.controller.robot_checks import bus_problems
    from sim2real.robot.bus_plan import bus_time

    model = build_model(robot)
    timing = control_timing(robot)
    wire = bus_time(robot)
    torques = {t.joint: t for t in holding_torques(robot, model)}
    joints = []
    for j in robot.joints:
        entry = {
            "name": j.name, "side": j.side, "location": j.location, "axis": j.axis, "index": j.index,
            "range_rad": list(j.range_rad), "home_rad": j.home_rad,
            "servo_id": j.servo.id if j.servo else None,
            "servo_model": j.servo.profile.model if j.servo else None,
            "servo_protocol": j.servo.profile.protocol if j.servo else None,
            "servo_profile": j.servo.profile.path.name if j.servo else None,  # its file in firmware_profiles/
            "direction": j.servo.direction if j.servo else None,
            "zero_offset_rad": j.servo.zero_offset_rad if j.servo else None,
            "sign": j.sign,
            "holding_torque_nm": torques[j.name].torque_nm,
            "torque_limit_nm": torques[j.name].limit_nm,
            "torque_margin": torques[j.name].margin,
        }
        if j.servo is not None:
            entry["max_goal_step_rad"] = j.servo.profile.motor.no_load_speed_rad_s * timing.tick_s
        joints.append(entry)
    return {
        "name": robot.name,
        "description": robot.description,
        "source": robot.source,
        "actuation": "servo" if robot.is_servo_robot else "pd",
        "height_m": robot.height,
        "mass_kg": robot.mass,
        "leg_length_m": robot.leg_length,
        "tick_s": timing.tick_s,
        "bus_cycle_s": timing.bus_cycle_s,
        "tick_derivation": {
            "human_tick_s": timing.human_tick_s,
            "human_leg_length_m": timing.human_leg_length_m,
            "scaled_tick_s": timing.scaled_tick_s,
            "bus_bytes_per_cycle": timing.bus_bytes,
            "physics_dt_s": timing.physics_dt_s,
            "substeps": timing.substeps,
            "rule": timing.rule,
        },
        "bus": {"port": robot.bus.port, "baud": robot.bus.baud} if robot.bus else None,
        "bus_tick": None if wire is None else {
            "time_s": wire.total_s, "wire_s": wire.wire_s, "turnaround_s": wire.turnaround_s,
            "return_delay_s": wire.return_delay_s, "packets": wire.packets, "bytes": wire.bytes,
            "exchanges": [{"kind": e.kind, "protocol": e.protocol, "ids": list(e.ids),
                           "bytes": e.out_bytes() + e.in_bytes()} for e in wire.exchanges]},
        "bus_problems": bus_problems(robot, timing.tick_s),
        "model": None if robot.model is None else {
            "file": str(robot.model.path), "root": robot.model.root, "imu_body": robot.model.imu_body,
            "imu_pos_m": list(robot.model.imu_pos), "feet": {s: f.body for s, f in robot.model.feet.items()},
            "hands": dict(robot.model.hands), "inertias": robot.model.inertias, "forward": robot.model.forward},
        "sensor_board": (
            {"id": robot.sensor_board.id, "model": robot.sensor_board.profile.model}
            if robot.sensor_board else None
        ),
        "anthropometry": robot.anthropometry or None,
        "torque_margin_stance": f"single-leg stance, half crouch (knee {CROUCH_KNEE_DEG:g} deg)",
        "control_sets": {k: list(v) for k, v in robot.control_sets.items()},
        "joints": joints,
    }


def _print_description(d: dict) -> None:
    deriv = d["tick_derivation"]
    print(f"{d['name']}: {d['description']}")
    print(f"  from {d['source']}")
    if d["model"] is not None:
        m = d["model"]
        print(f"  model {m['file']}: root {m['root']}, feet {m['feet']['left']} and {m['feet']['right']}, "
              f"IMU on {m['imu_body']} at {m['imu_pos_m']} m" + (f", hands {', '.join(m['hands'].values())}"
                                                                 if m["hands"] else ""))
    print(f"  height {d['height_m']:.3f} m, mass {d['mass_kg']:.3f} kg, leg length {d['leg_length_m']:.3f} m")
    if d["bus"]:
        board = d["sensor_board"]
        print(f"  bus {d['bus']['port']} at {d['bus']['baud']} baud; sensor board "
              f"{board['model']} id {board['id']}" if board else "")
    print(f"control tick {d['tick_s'] * 1e3:.1f} ms:")
    print(f"  0.07 s x sqrt({d['leg_length_m']:.3f} m / {deriv['human_leg_length_m']:.3f} m human leg)"
          f" = {deriv['scaled_tick_s'] * 1e3:.1f} ms")
    print(f"  bus cycle {deriv['bus_bytes_per_cycle']} bytes = {d['bus_cycle_s'] * 1e3:.2f} ms"
          + (f" at {d['bus']['baud']} baud" if d["bus"] else ""))
    print(f"  rule: {deriv['rule']}")
    if d["bus_tick"] is not None:
        bt = d["bus_tick"]
        print(f"  bus time a tick {bt['time_s'] * 1e3:.2f} ms: {bt['packets']} packets, wire "
              f"{bt['wire_s'] * 1e3:.2f} ms + host turnaround {bt['turnaround_s'] * 1e3:.0f} ms")
        for e in bt["exchanges"]:
            print(f"    {e['kind'].replace('_', ' '):<10} protocol {e['protocol']:.1f}  {e['bytes']:>4} bytes  "
                  f"IDs {id_list(e['ids'])}")
    print(f"joints (torque margin: stall / holding torque, {d['torque_margin_stance']}):")
    width = max([18] + [len(j["name"]) for j in d["joints"]])
    print(f"  {'name':<{width}} {'id':>3} {'servo':<14} {'proto':>5} {'range [deg]':>16} {'home':>6} "
          f"{'hold [N m]':>10} {'margin':>7} {'step/tick':>9}")
    for j in d["joints"]:
        lo, hi = (math.degrees(a) for a in j["range_rad"])
        margin = "-" if j["torque_margin"] is None else f"{j['torque_margin']:.1f}x"
        step = f"{math.degrees(j['max_goal_step_rad']):.1f} deg" if "max_goal_step_rad" in j else "-"
        protocol = "-" if j["servo_protocol"] is None else f"{j['servo_protocol']:.1f}"
        print(f"  {j['name']:<{width}} {j['servo_id'] if j['servo_id'] is not None else '-':>3} "
              f"{j['servo_model'] or 'PD':<14} {protocol:>5} {f'[{lo:.1f}, {hi:.1f}]':>16} "
              f"{math.degrees(j['home_rad']):>6.1f} {j['holding_torque_nm']:>10.3f} {margin:>7} {step:>9}")
    profiles = {j["servo_model"]: (j["servo_profile"], j["servo_protocol"]) for j in d["joints"] if j["servo_model"]}
    for model, (file, protocol) in profiles.items():  # which profile each model name resolved to
        print(f"  servo {model}: firmware_profiles/{file}, protocol {protocol:.1f}")
    weak = [j["name"] for j in d["joints"] if j["torque_margin"] is not None and j["torque_margin"] < 1.5]
    if weak:
        print(f"warning: torque margin below 1.5x at {', '.join(weak)}")


def cmd_robot_show(args: argparse.Namespace) -> int:
    robot = robot_arg(args.robot)
    d = describe(robot)
    if args.json:
        print(json.dumps(d, indent=2))
    else:
        _print_description(d)
    if d["bus_problems"]:  # shown above, and refused: `biped run` would refuse it before opening the port
        raise ConfigError(robot.source, "bus", "; ".join(d["bus_problems"]))
    return 0


def _add_stand(rsub: argparse._SubParsersAction) -> None:
    stand = rsub.add_parser("stand", help="does it stand? 5 s from home, the servos holding home",
                            description="Simulate the robot 5 s from its home pose with every servo holding "
                            "home; print the torso's up-vector, the sag, the share of its weight on the feet, "
                            "the joints' torque margins, whether it fell or slid, and a verdict (stands, "
                            "stands with a warning, falls). Exit status 1 when it falls. "
                            "See docs/robot-stand.md.")
    stand.add_argument("robot", nargs="?", default=DEFAULT_ROBOT, help=ROBOT_HELP)
    stand.add_argument("--json", action="store_true", help="print one JSON object instead of text")
    stand.add_argument("--propose-home", action="store_true",
                       help="also propose a home that stands (knees bent, feet flat, the centre of mass over "
                       "the soles) and leg ranges centred on it, checked the same way (the exit status is "
                       "still the given home's)")
    stand.set_defaults(func=cmd_robot_stand)


def cmd_robot_stand(args: argparse.Namespace) -> int:
    from sim2real.simulation.standing.check import check_stand

    robot = robot_arg(args.robot)
    report = check_stand(robot)
    proposal = None
    if args.propose_home:
        from sim2real.simulation.standing.home import propose_home

        proposal = propose_home(robot)
    if args.json:
        print(json.dumps(report.to_json() | ({"proposed_home": proposal.to_json()} if proposal else {}), indent=2))
    else:
        print("\n".join(report.lines() + (proposal.report() + ["in the robot YAML:"] + proposal.yaml_lines()
                                          if proposal else [])))
    return 0 if report.stands else 1


def cmd_robot_mjcf(args: argparse.Namespace) -> int:
    from sim2real.simulation.model.builder import to_mjcf

    xml = to_mjcf(robot_arg(args.robot))
    if args.output is None:
        sys.stdout.write(xml)
    else:
        from sim2real.atomic_json import write_text_atomic

        write_text_atomic(args.output, xml)  # a full disk leaves no 0-byte file
        print(f"wrote {args.output}", file=sys.stderr)
    return 0


# -- robot import -------------------------------------------------------------------------------
IMPORT_EPILOG = """\
what it infers (at the model's zero pose; every guess is commented "guessed: check"):
  chains                   from the body tree: the legs (the two branches reaching the floor,
                           down to the feet), the arms (the mirrored pair of branches above),
                           the neck (the central chain going up) and the spine between them
  location                 from the place along the chain: hip (before the knee), knee (the
                           hinge across the leg splitting thigh and shank), ankle, toe;
                           shoulder, elbow, wrist; grippers and fingers are held
  facing                   from the feet (the sole reaches ahead of the ankle), the knees'
                           bend and limits and the toes; --forward overrides it
  sides and mirror pairs   side from the chain; a hinge's partner sits at its mirror image
                           across the sagittal plane with a mirrored axis; names (l_/r_...)
                           only break ties and are checked against it
  axis, index and sign     the principal axis nearest the joint's in the facing's frame (yaw,
                           roll, pitch), index 1, 2... for more joints of one role along a chain
                           (a spine), and anatomical angle = sign * model angle
  range, home              the model's range made anatomical and cut to the servo's reach
                           (+-90 deg if unlimited); a keyframe 'home' or 0
  stand                    the robot stands 5 s from that home (as biped robot stand); if it
                           falls or its knees are straight, a home with the knees bent that
                           stands is proposed and written, each leg range centred on it (the
                           networks use the central 80 %); the report gives both verdicts
                           (--no-stand: skip it)
  servo ids                1, 2, ... in model order: set them to your servos' IDs
  root, imu, feet, hands   the floating body (a URDF's base), the IMU at its origin, the end
                           of each leg, the end of each arm
joints on no chain (grippers, fingers), with an axis far from x, y and z, without a twin on
the other side, and slide and ball joints are left out, so the model builder holds them at
their home pose; a knee or elbow whose limits let it bend only the wrong way is named (and,
when the facing rests on cues or --forward, written turned to its flexion side).

examples:
  biped robot import op3.xml --servo XM430-W350 -o configs/robots/op3.yaml
  biped robot import robot.urdf --package-dir ~/ws/src -o robot.yaml
  biped robot import poppy.urdf --forward=-y --servo MX-28 --servo neck=AX-12A -o poppy.yaml
"""


def _add_import(rsub: argparse._SubParsersAction) -> None:
    from sim2real.simulation.model.importing.importer import DEFAULT_SERVO

    imp = rsub.add_parser(
        "import", help="write a starting robot YAML from an MJCF or URDF model",
        description=textwrap.fill(
            "Read a robot's MJCF (.xml) or URDF (.urdf) and write a robot YAML that maps its joints "
            "(side, location, axis, sign, range, servo id), its root, IMU, feet and hands, with what it "
            "guessed commented; print what it inferred and what it could not (unmapped joints, unpaired "
            "hinges, missing visual meshes, implausible inertias).", 90),
        epilog=IMPORT_EPILOG, formatter_class=argparse.RawDescriptionHelpFormatter)
    imp.add_argument("model", type=Path, metavar="MODEL",
                     help="the robot's MJCF or URDF file (told apart by its root element; expand a "
                     ".xacro first: xacro robot.urdf.xacro > robot.urdf, or pip install xacrodoc)")
    imp.add_argument("-o", "--output", type=output_file(".yaml", ".yml"), required=True,
                     help="the robot YAML to write (its name is the file's stem; paths in it are relative to it)")
    imp.add_argument("--servo", type=_servo_choice, action="append", default=[], metavar="[WHERE=]MODEL",
                     help=f"the Dynamixel model of the servos (default {DEFAULT_SERVO}; any model in "
                     "firmware_profiles/, e.g. XM430-W350, XL330-M288-T); repeat with WHERE=MODEL for "
                     "the servos of legs, arms, neck, waist or one joint (e.g. --servo neck=AX-12A)")
    imp.add_argument("--forward", choices=("+x", "-x", "+y", "-y"), default=None,
                     help="the way the robot faces in the model file (default: inferred from its feet, "
                     "knees and toes); write a minus with '=': --forward=-y")
    imp.add_argument("--package-dir", action="append", default=[], type=Path, metavar="DIR",
                     help="a folder holding the packages of a URDF's package://PKG/PATH meshes (tried as "
                     "DIR/PKG/PATH and DIR/PATH); repeatable")
    imp.add_argument("--recompute-inertias", action="store_true",
                     help="write 'inertias: from_geometry': each body's inertia from its collision "
                     "geometry, its mass kept (for a model whose inertias are wrong)")
    imp.add_argument("--no-stand", action="store_true",
                     help="skip the stand check (5 s from home, as biped robot stand) and the home it "
                     "proposes when the model's home falls or has straight knees: home and ranges stay the "
                     "model's")
    imp.set_defaults(func=cmd_robot_import)


def _servo_model(text: str) -> str:
    """A servo model name from ``firmware_profiles/`` (its canonical spelling)."""
    from sim2real.simulation.model.importing.importer import servo_model_name

    try:
        return servo_model_name(text)
    except KeyError as exc:
        raise argparse.ArgumentTypeError(exc.args[0]) from None


def _servo_choice(text: str) -> tuple[str | None, str]:
    """``MODEL`` or ``WHERE=MODEL``: (where or None, the model's canonical name)."""
    where, _, model = text.rpartition("=")
    return (where or None, _servo_model(model))


def cmd_robot_import(args: argparse.Namespace) -> int:
    from sim2real.simulation.model.importing.robot_yaml import write_robot_yaml
    from sim2real.simulation.model.importing.importer import import_robot

    from sim2real.simulation.model.importing.importer import DEFAULT_SERVO

    defaults = [model for where, model in args.servo if where is None]
    if len(defaults) > 1:
        raise UsageError(f"--servo: give one model for all servos, and WHERE=MODEL for the others (got "
                         f"{', '.join(defaults)})")
    result = import_robot(args.model, args.output, servo=defaults[0] if defaults else DEFAULT_SERVO,
                          servos={where: model for where, model in args.servo if where is not None},
                          package_dirs=args.package_dir, recompute_inertias=args.recompute_inertias,
                          forward=args.forward)
    if not args.no_stand:  # on the simulation side: sim2real.robot does not import it to write a YAML
        from sim2real.simulation.standing.imported import stand_imported

        result = stand_imported(result)
    print("\n".join(result.report()))
    write_robot_yaml(result)
    print(f"wrote {args.output}: check every line marked 'guessed: check' (servo ids, signs, feet, IMU) "
          f"before a controller drives the robot")
    return 0

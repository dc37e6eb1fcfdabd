"""The `biped` command line: the commands the acceptance checks call, run as a user would."""

import argparse
import json
import subprocess
import sys

import mujoco
import pytest

from evolve.cli import build_parser, main


def run_biped(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "evolve.cli", *args], capture_output=True, text=True,
                          timeout=300)


def test_robot_show_json_has_the_documented_keys(capsys):
    assert main(["robot", "show", "--json"]) == 0
    d = json.loads(capsys.readouterr().out)
    for key in ("name", "height_m", "mass_kg", "leg_length_m", "tick_s", "bus_cycle_s", "joints"):
        assert key in d
    assert d["name"] == "xl430_biped" and len(d["joints"]) == 11
    for joint in d["joints"]:
        for key in ("name", "servo_id", "servo_model", "range_rad"):
            assert key in joint
        assert joint["range_rad"][0] < joint["range_rad"][1]
    assert d["tick_s"] >= d["bus_cycle_s"]


def test_robot_show_table_explains_the_tick(capsys):
    assert main(["robot", "show", "op3_legs"]) == 0
    out = capsys.readouterr().out
    assert "0.07 s x sqrt(" in out and "bus cycle" in out and "margin" in out
    assert "right_hip_yaw" in out


def test_robot_mjcf_writes_a_loadable_file(tmp_path):
    path = tmp_path / "robot.xml"
    assert main(["robot", "mjcf", "human:female_95", "-o", str(path)]) == 0
    model = mujoco.MjModel.from_xml_path(str(path))
    assert model.key("home").id == 0 and model.nu == 15


def test_render_writes_a_picture_of_the_robot(tmp_path):
    path = tmp_path / "robot.png"
    result = run_biped("render", "-o", str(path), "--width", "320", "--height", "240")
    assert result.returncode == 0, result.stderr
    import imageio.v3 as iio

    image = iio.imread(path)
    assert image.shape == (240, 320, 3)
    assert image.std() > 5  # not a blank frame


def test_bad_robot_config_is_a_clear_error_not_a_traceback(tmp_path):
    bad = tmp_path / "bad.yaml"
    bad.write_text("name: x\ndescription: y\nbody: {}\njoints: []\ncontrol_sets: {}\nwings: 2\n")
    result = run_biped("robot", "show", str(bad))
    assert result.returncode == 2
    assert "bad.yaml: wings: unknown key 'wings'" in result.stderr
    assert "Traceback" not in result.stderr


@pytest.mark.parametrize("command", [[], ["robot"], ["robot", "show"], ["robot", "mjcf"], ["view"], ["render"],
                                     ["plot"], ["plot", "gait"], ["plot", "network"], ["plot", "reach"]])
def test_every_command_has_help(command):
    result = run_biped(*command, "--help")
    assert result.returncode == 0 and "usage: biped" in result.stdout


MARKUP = ("``", "`", "%%", "**")  # reST/Markdown or a doubled percent sign: printed as typed, not rendered


def every_parser(parser: argparse.ArgumentParser, path: tuple[str, ...] = ("biped",)):
    """(command words, parser) of ``parser`` and every subcommand under it, each once."""
    yield path, parser
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for name, child in action.choices.items():
                yield from every_parser(child, (*path, name))


def default_shown(default) -> list[str]:
    """The spellings under which a help text may show ``default``."""
    if isinstance(default, float):
        return [f"{default:g}", str(default)]
    if isinstance(default, (list, tuple)):
        return [" ".join(map(str, default)), ",".join(map(str, default)), str(default)]
    return [str(default)]


def help_problems(parser: argparse.ArgumentParser, path: tuple[str, ...] = ("biped",)) -> list[str]:
    """What the help of ``parser`` and its subcommands lacks: an argument without help (flags hidden on
    purpose with ``argparse.SUPPRESS`` aside), a flag whose default is not shown in its help, or markup
    in the printed help (description, epilog, every argument)."""
    problems = []
    for words, p in every_parser(parser, path):
        command = " ".join(words)
        text = p.format_help()
        for mark in MARKUP:
            for line in text.splitlines():
                if mark in line:
                    problems.append(f"{command}: its help prints {mark!r}: {line.strip()}")
                    break
        formatter = p._get_formatter()
        for action in p._actions:
            if isinstance(action, (argparse._HelpAction, argparse._SubParsersAction, argparse._VersionAction)):
                continue
            if action.help == argparse.SUPPRESS:
                continue
            name = "/".join(action.option_strings) or action.dest
            if not action.help:
                problems.append(f"{command} {name}: no help text")
                continue
            shown = formatter._expand_help(action)
            if (action.option_strings and isinstance(action, argparse._StoreAction)
                    and action.default not in (None, argparse.SUPPRESS)
                    and ("default" not in shown or not any(s in shown for s in default_shown(action.default)))):
                problems.append(f"{command} {name}: its default {action.default!r} is not in its help: {shown}")
    return problems


def test_every_flag_of_every_command_has_help_with_its_default_and_no_markup():
    parser = build_parser()
    problems = help_problems(parser)
    assert not problems, "\n".join(problems)
    plot = dict(every_parser(parser))[("biped", "plot")].format_help()
    assert all(word in plot for word in ("gait", "network", "reach"))  # every picture it draws, named


def test_the_help_check_finds_what_it_must():
    """The check itself: a flag without help, a default not shown, markup and a doubled percent sign in a
    description, in a subcommand two levels down."""
    parser = argparse.ArgumentParser(prog="biped")
    sub = parser.add_subparsers().add_parser("robot").add_subparsers().add_parser(
        "bad", description="fits with a 95 %% interval, as ``biped sysid`` prints")
    sub.add_argument("--quiet", action="store_true")
    sub.add_argument("--seed", type=int, default=3, help="a seed")
    sub.add_argument("--shown", type=float, default=0.5, help="shown (default %(default)s)")
    sub.add_argument("--hidden", default=1, help=argparse.SUPPRESS)
    problems = help_problems(parser)
    assert any("biped robot bad --quiet: no help text" in p for p in problems)
    assert any("biped robot bad --seed: its default 3 is not in its help" in p for p in problems)
    assert any("prints '%%'" in p for p in problems) and any("prints '``'" in p for p in problems)
    assert not any("--shown" in p or "--hidden" in p for p in problems)


def test_run_without_a_port_uses_the_simulated_bus(tmp_path):
    from evolve.locomotion.evaluator import neat_layout
    from evolve.locomotion.export import controller_from_genome
    from evolve.locomotion.task import TaskConfig
    from evolve.neat import Genome
    from sim2real.controller.symmetry import symmetric_layout
    from sim2real.robot import load_robot

    robot = load_robot()
    layout = symmetric_layout(robot, robot.control_sets["walk"])
    controller_from_genome(Genome(0, neat_layout(layout)), robot, layout, TaskConfig(), 1.0,
                           {"seed": 0}).save(tmp_path / "c.json")
    result = run_biped("run", str(tmp_path / "c.json"), "--duration", "0.5", "--json")
    assert result.returncode == 0, result.stdout + result.stderr
    assert "simulated bus" in result.stderr
    report = json.loads(result.stdout.strip().splitlines()[-1])
    assert report["stop_reason"] == "duration reached" and not report["fell"]

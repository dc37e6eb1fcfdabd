"""The control tick: seed 000's 0.07 s scaled by dynamic similarity, bounded by the bus."""

import dataclasses
import math

import pytest

from sim2real.robot import load_robot
from sim2real.robot.spec import BusSettings
from sim2real.robot.timing import (
    HUMAN_TICK_S,
    bus_cycle_bytes,
    bus_cycle_s,
    control_timing,
)


def test_default_robot_tick_is_scaled_by_sqrt_of_leg_length():
    robot = load_robot()
    timing = control_timing(robot)
    expected = HUMAN_TICK_S * math.sqrt(robot.leg_length / timing.human_leg_length_m)
    assert timing.scaled_tick_s == pytest.approx(expected)
    # rounded to a whole number of physics steps
    assert abs(timing.tick_s - expected) <= timing.physics_dt_s / 2 + 1e-12
    assert timing.tick_s == pytest.approx(timing.substeps * timing.physics_dt_s)
    assert 0.025 < timing.tick_s < 0.045  # a 0.4 m robot ticks about twice as fast as a human


def test_human_keeps_the_papers_tick():
    assert control_timing(load_robot("human:male_95")).tick_s == pytest.approx(0.07)


def test_bus_bytes_match_the_wire_format():
    # DESIGN.md section 6: 12-servo sync write of goals 74 bytes, sync read of 4 bytes
    # 26 + 12 x 15; plus one READ of the sensor board (14 out, 11 + 16 back: foot switches,
    # up-vector, heading and angular rates, addresses 100-115 of its profile).
    robot = load_robot("op3_legs")
    assert bus_cycle_bytes(robot) == 74 + 26 + 12 * 15 + 14 + 11 + 16


def test_tick_never_below_the_bus_cycle_at_a_slow_baud():
    robot = dataclasses.replace(load_robot(), bus=BusSettings(port="/dev/null", baud=57600))
    timing = control_timing(robot)
    assert timing.bus_cycle_s == pytest.approx(bus_cycle_bytes(robot) * 10 / 57600)
    assert timing.bus_cycle_s > timing.scaled_tick_s  # 292 bytes take ~51 ms at 57600 baud
    assert timing.tick_s >= timing.bus_cycle_s
    assert "bus cycle" in timing.rule


def test_bus_cycle_at_1_mbps_is_about_3_ms():
    assert bus_cycle_s(load_robot()) == pytest.approx(2.9e-3, rel=0.05)


def test_a_robot_config_sets_its_physics_step_and_the_model_takes_it(tmp_path):
    import yaml

    from sim2real.robot.paths import robots_dir
    from sim2real.simulation.model.builder import build_model

    doc = yaml.safe_load((robots_dir() / "human.yaml").read_text())
    doc["physics_dt_s"] = 0.005
    path = tmp_path / "human.yaml"
    path.write_text(yaml.safe_dump(doc))
    robot = load_robot(f"{path}:male_50")
    timing = control_timing(robot)
    assert timing.physics_dt_s == 0.005 and timing.substeps == 14 and timing.tick_s == pytest.approx(0.07)
    assert build_model(robot).opt.timestep == 0.005
    doc["physics_dt_s"] = 0.5
    path.write_text(yaml.safe_dump(doc))
    from sim2real.errors import ConfigError

    with pytest.raises(ConfigError, match="physics_dt_s"):
        load_robot(str(path))

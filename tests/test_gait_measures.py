"""Gait measures (issue 51): synthetic gaits with answers known by hand, their edge cases, the
robot's hips found by role, the shipped walkers measured, and the measures where they are
reported (`biped eval`, `biped plot gait`)."""

from __future__ import annotations

import dataclasses
import json
import math

import mujoco
import numpy as np
import pytest

from sim2real.controller.activation import exp_fingerprint
from sim2real.controller.file import Controller
from sim2real.gait_measures import (
    MAX_FLIGHT_SHARE,
    MIN_STEPS,
    MIN_SYMMETRY,
    SKIP_S,
    GaitMeasures,
    GaitMeter,
    describe,
    hip_pitch_joints,
    is_a_walk,
    measure_gait,
    walk_faults,
)
from sim2real.robot import load_robot
from sim2real.robot.paths import data_root

CONTROLLERS = data_root() / "configs" / "controllers"
TICK_S = 0.05  # the synthetic gaits' tick [s]: 20 ticks a 1 s stride
STRIDE = 20  # ticks


def walk(seconds: float = 10.0, swing_deg: float = 40.0) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A symmetric alternating walk: 1 s strides, each hip a sine of ``swing_deg`` peak to
    peak half a stride apart; the left foot down for ticks 0-11 of a stride, the right for
    10-21 (so both down 4 ticks in 20, never both up), each touching down once a stride."""
    ticks = np.arange(round(seconds / TICK_S))
    phase = ticks % STRIDE
    left = math.radians(swing_deg / 2) * np.sin(2 * np.pi * phase / STRIDE)
    feet = np.stack([phase < 12, (phase - 10) % STRIDE < 12], axis=1)
    return ticks * TICK_S, np.stack([left, -left], axis=1), feet


def hop(seconds: float = 10.0) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A hop driven by one leg: the right hip swings 50 deg, the left 5 deg; a stride is 4
    ticks in flight (both feet up), then both land together, the right lifts after 4 ticks."""
    ticks = np.arange(round(seconds / TICK_S))
    phase = ticks % STRIDE
    wave = np.sin(2 * np.pi * phase / STRIDE)
    hips = np.radians(np.stack([2.5 * wave, 25.0 * wave], axis=1))
    feet = np.stack([phase >= 4, (phase >= 4) & (phase < 8)], axis=1)
    return ticks * TICK_S, hips, feet


class TestKnownGaits:
    def test_a_symmetric_alternating_walk_is_a_walk_with_its_cadence(self):
        m = measure_gait(*walk())
        assert m.ticks == 160 and m.measured_s == pytest.approx(8.0)  # 10 s, the first 2 s skipped
        assert m.hip_swing_deg == pytest.approx((40.0, 40.0)) and m.symmetry == pytest.approx(1.0)
        assert m.flight_share == 0.0 and m.double_support_share == pytest.approx(0.2)
        assert m.touchdowns == (8, 8) and m.steps == 16  # one a foot a stride: t = 2, 3, ... 9 and 2.5 ... 9.5
        assert m.cadence_steps_min == pytest.approx(120.0)
        assert is_a_walk(m) and walk_faults(m) == []

    def test_a_one_legged_hop_has_low_symmetry_and_its_flight_share(self):
        m = measure_gait(*hop())
        assert m.hip_swing_deg == pytest.approx((5.0, 50.0)) and m.symmetry == pytest.approx(0.1)
        assert m.flight_share == pytest.approx(4 / 20) and m.double_support_share == pytest.approx(4 / 20)
        assert m.steps == 8 and m.touchdowns == (8, 8)  # both feet land on one tick: one step
        assert not is_a_walk(m)
        assert walk_faults(m) == [f"hip swing symmetry 0.10 < {MIN_SYMMETRY:g}",
                                  f"both feet up in 20% of the ticks > {MAX_FLIGHT_SHARE:.0%}"]

    def test_a_leg_that_keeps_landing_while_the_other_stays_down_makes_one_step(self):
        times, hips, feet = walk()
        feet[:, 0] = True  # the left foot never lifts: the right's landings are one leg hopping
        m = measure_gait(times, hips, feet)
        assert m.touchdowns == (0, 8) and m.steps == 1
        assert m.symmetry == pytest.approx(1.0) and m.flight_share == 0.0  # the hips alone would pass
        assert walk_faults(m) == [f"1 alternating steps < {MIN_STEPS}"]

    def test_a_chattering_switch_counts_its_touchdowns_but_not_as_steps(self):
        times, hips, feet = walk()
        feet[np.arange(len(times)) % STRIDE == 1, 0] = False  # the left switch opens for a tick after landing
        m = measure_gait(times, hips, feet)
        assert m.touchdowns == (16, 8) and m.steps == 16 and is_a_walk(m)

    def test_a_stand_with_a_symmetric_sway_takes_no_steps_and_is_no_walk(self):
        times, _, _ = walk()
        sway = np.radians(0.1) * np.sin(times)
        m = measure_gait(times, np.stack([sway, sway], axis=1), np.ones((len(times), 2), dtype=bool))
        assert m.steps == 0 and m.touchdowns == (0, 0) and m.cadence_steps_min == 0.0
        assert m.double_support_share == 1.0 and m.flight_share == 0.0 and m.symmetry == pytest.approx(1.0)
        assert walk_faults(m) == [f"0 alternating steps < {MIN_STEPS}"]

    def test_hips_that_do_not_move_have_no_symmetry(self):
        times, _, feet = walk()
        m = measure_gait(times, np.zeros((len(times), 2)), feet)
        assert math.isnan(m.symmetry) and m.steps == 16
        assert walk_faults(m) == ["neither hip swings"]
        assert m.to_dict()["symmetry"] is None


class TestEdgeCases:
    def test_a_fall_mid_episode_is_measured_up_to_the_fall(self):
        times, hips, feet = (a[:100] for a in walk())  # the recording ends at 5 s, as a replay's at a fall
        m = measure_gait(times, hips, feet)
        assert m.ticks == 60 and m.measured_s == pytest.approx(3.0)
        assert m.steps == 6 and m.cadence_steps_min == pytest.approx(120.0)  # t = 2, 2.5, ... 4.5

    def test_an_episode_no_longer_than_the_start_up_has_empty_measures(self):
        m = measure_gait(*(a[:30] for a in walk()))  # 1.5 s
        assert m.empty and m.ticks == 0 and m.measured_s == 0.0 and m.steps == 0
        assert all(math.isnan(v) for v in (m.symmetry, m.flight_share, m.cadence_steps_min, *m.hip_swing_deg))
        assert walk_faults(m) == ["no ticks after the first 2 s"] and not is_a_walk(m)
        assert describe(m) == "not measured: no ticks after the first 2 s"
        json.dumps(m.to_dict(), allow_nan=False)  # NaN reported as null

    def test_the_start_up_skipped_is_a_parameter(self):
        assert SKIP_S == 2.0
        times, hips, feet = walk()
        everything = measure_gait(times, hips, feet, skip_s=0.0)
        assert everything.ticks == 200
        assert everything.touchdowns == (9, 10) and everything.steps == 19  # feet down at the first tick: no landing
        m = measure_gait(times, hips, feet, skip_s=5.0)
        assert m.ticks == 100 and m.skipped_s == 5.0 and m.steps == 10
        assert measure_gait(times, hips, feet, skip_s=10.0).empty

    def test_a_traces_uneven_clock_measures_with_its_median_tick(self):
        times, hips, feet = walk()
        jitter = np.where(np.arange(len(times)) % 3 == 1, 0.004, 0.0)  # every third row read 4 ms late
        m = measure_gait(times + jitter, hips, feet)
        assert m.ticks == 160 and m.measured_s == pytest.approx(8.0)

    @pytest.mark.parametrize("change, message", [
        (lambda t, h, f: (t[::-1], h, f), "times_s: finite and increasing"),
        (lambda t, h, f: (t, h[:, :1], f), "hips_rad: (200, 2)"),
        (lambda t, h, f: (t, np.where(h > 0.1, np.nan, h), f), "hips_rad: (200, 2) finite"),
        (lambda t, h, f: (t, h, f[:-1]), "feet: (200, 2)"),
        (lambda t, h, f: (t[:1], h[:1], f[:1]), "times_s: a row (n,) of at least 2 ticks"),
    ])
    def test_bad_arrays_are_refused_naming_the_argument(self, change, message):
        with pytest.raises(ValueError, match=message.replace("(", r"\(").replace(")", r"\)")):
            measure_gait(*change(*walk()))

    def test_the_meter_of_many_episodes_measures_each_as_alone(self):
        episodes = [walk(), hop(), tuple(a[:100] for a in walk(swing_deg=20.0))]  # the last falls at 5 s
        meter = GaitMeter(3, TICK_S)
        for t in range(200):
            alive = np.array([e for e, (times, _, _) in enumerate(episodes) if t < len(times)])
            meter.add(alive, t * TICK_S, np.stack([episodes[e][1][t] for e in alive]),
                      np.stack([episodes[e][2][t] for e in alive]))
        assert meter.measures() == [measure_gait(*e, tick_s=TICK_S) for e in episodes]

    def test_the_measures_read_back_from_json_are_the_same(self):
        for m in (measure_gait(*walk()), measure_gait(*hop()), measure_gait(*(a[:30] for a in walk()))):
            back = GaitMeasures.from_dict(json.loads(json.dumps(m.to_dict())))
            assert back.to_dict() == m.to_dict() and is_a_walk(back) == is_a_walk(m)


class TestHips:
    def test_hips_are_found_by_their_role_not_their_name(self):
        robot = load_robot("xl430_biped")
        assert hip_pitch_joints(robot) == ("left_hip_pitch", "right_hip_pitch")
        renamed = dataclasses.replace(robot, joints=tuple(dataclasses.replace(j, name=f"j{k}")
                                                          for k, j in enumerate(robot.joints)))
        left, right = hip_pitch_joints(renamed)
        assert (renamed.joint(left).side, renamed.joint(right).side) == ("left", "right")
        assert {renamed.joint(left).location, renamed.joint(left).axis} == {"hip", "pitch"}
        assert hip_pitch_joints(load_robot("op3")) == ("l_hip_pitch", "r_hip_pitch")  # ROBOTIS's names

    def test_a_robot_without_a_left_hip_pitch_cannot_be_measured(self):
        robot = load_robot("xl430_biped")
        lame = dataclasses.replace(robot, joints=tuple(j for j in robot.joints if j.name != "left_hip_pitch"))
        with pytest.raises(ValueError, match="robot xl430_biped has no left hip pitch joint"):
            hip_pitch_joints(lame)


def _same_numerics(path) -> None:
    """Skip a knife-edge human gait where it was not evolved (as tests/test_human_walkers.py)."""
    provenance = Controller.load(path).provenance
    if provenance.get("mujoco") != mujoco.__version__:
        pytest.skip(f"{path.name} was evolved on MuJoCo {provenance.get('mujoco')}, this is {mujoco.__version__}")
    if provenance.get("exp_fingerprint") != exp_fingerprint():
        pytest.skip(f"{path.name} was evolved where np.exp rounds differently from this machine")


class TestShippedWalkers:
    """Issue 51's table, measured over 10 s on the nominal robot with the first 2 s skipped."""

    def test_the_servo_bipeds_walker_walks_a_walk_and_eval_measures_the_replays_episode(self):
        from evolve.replay import evaluate_controller, gait
        from sim2real.gait_measures import measure_recorded

        path = CONTROLLERS / "xl430_biped.json"
        m = measure_recorded(gait(path, seconds=10.0))
        assert m.hip_swing_deg == pytest.approx((37.9, 37.4), abs=0.1)  # issue 51: 37.9 / 37.4
        assert m.symmetry == pytest.approx(0.99, abs=0.01) and m.flight_share == 0.0
        assert m.double_support_share == pytest.approx(0.53, abs=0.01)  # 0.523 here
        assert m.steps >= 20 and is_a_walk(m)
        report = evaluate_controller(path, seconds=10.0, gait_measures=True)["gait"]
        assert report["walks"] == 1 and len(report["per_episode"]) == 1
        by_eval, by_replay = report["per_episode"][0], m.to_dict()  # eval's tracker: the same ticks
        for key in ("measured_s", "cadence_steps_min"):  # the replay's tick is read off its times
            assert by_eval.pop(key) == pytest.approx(by_replay.pop(key), rel=1e-12)
        assert by_eval == by_replay

    def test_the_human_male_50_walker_hops(self):
        from evolve.replay import gait
        from sim2real.gait_measures import measure_recorded

        path = CONTROLLERS / "human_male_50.json"
        _same_numerics(path)
        m = measure_recorded(gait(path, seconds=10.0))
        assert m.hip_swing_deg[0] == pytest.approx(5.9, abs=0.2)  # issue 51: 5.9 / 80.4
        assert m.hip_swing_deg[1] > 70.0 and m.symmetry < 0.1  # 78.2 deg, 0.075 here
        assert m.flight_share == pytest.approx(0.12, abs=0.01)
        assert not is_a_walk(m)


class TestReported:
    def test_eval_reports_each_episodes_gait_in_json_and_in_lines(self, capsys):
        from evolve.cli import main

        path = str(CONTROLLERS / "xl430_biped.json")
        assert main(["eval", path, "--seconds", "4", "--episodes", "2", "--randomize", "--json"]) == 0
        report = json.loads(capsys.readouterr().out)
        assert len(report["gait"]["per_episode"]) == 2 and "distance_m" in report
        assert {"hip_swing_deg", "symmetry", "flight_share", "double_support_share", "steps", "cadence_steps_min",
                "walk"} <= set(report["gait"]["per_episode"][1])
        assert report["gait"]["walks"] == sum(e["walk"] for e in report["gait"]["per_episode"])
        assert main(["eval", path, "--seconds", "1"]) == 0  # shorter than the start-up: measured as nothing
        out = capsys.readouterr().out
        assert "upright_s: " in out and "per_episode: " in out  # the old lines stay
        assert "gait: 0 of 1 episodes walk a walk (first 2 s skipped)\n" \
               "  episode 0: not measured: no ticks after the first 2 s" in out

    def test_plot_gait_prints_the_measures_and_draws_them_under_the_title(self, tmp_path, capsys, monkeypatch):
        pytest.importorskip("matplotlib")
        import matplotlib.axes

        from evolve.cli import main

        titles = []
        original = matplotlib.axes.Axes.set_title
        monkeypatch.setattr(matplotlib.axes.Axes, "set_title",
                            lambda self, label, *a, **k: (titles.append(label), original(self, label, *a, **k))[1])
        assert main(["plot", "gait", str(CONTROLLERS / "xl430_biped.json"), "--seconds", "3",
                     "-o", str(tmp_path / "g.png")]) == 0
        out = capsys.readouterr().out
        assert "gait: hip swing" in out and "steps (" in out
        assert any("\nafter 2 s: hip swing" in t and "steps/min" in t for t in titles)

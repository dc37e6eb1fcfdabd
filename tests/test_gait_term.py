"""Selection's gait term (``selection_gait_coeff``): a two-legged walk is paid, a hop is not,
by the same gait measures ``biped eval`` reports (the slow oracle), and without the
coefficient nothing is computed or paid."""

import dataclasses
import math

import pytest

from evolve.locomotion.evaluator import LocomotionEvaluator
from evolve.locomotion.task import TaskConfig
from evolve.replay import controller_setup, evaluate_controller
from sim2real.errors import ConfigError

SECONDS = 6.0


def _evaluate(path: str, coeff: float):
    data, spec, ev, genome = controller_setup(path, None, SECONDS)
    task = dataclasses.replace(ev.task, selection_gait_coeff=coeff)
    ev = LocomotionEvaluator(spec, task, 1, threads=1)
    return ev.evaluate([genome], data.sigmoid_steepness), ev


@pytest.mark.parametrize("path, walks", [("configs/controllers/xl430_biped.json", True),
                                         ("configs/controllers/human_male_50.json", False)])
def test_the_gait_term_pays_a_walk_and_not_a_hop_as_the_gait_measures_say(path, walks):
    paid, ev = _evaluate(path, 2.0)
    unpaid, _ = _evaluate(path, 0.0)
    assert "gait" not in unpaid.terms  # left out, not computed, without its coefficient
    term = paid.terms["gait"][0]
    assert paid.selection[0] - unpaid.selection[0] == pytest.approx(2.0 * term)
    assert paid.fitness[0] == unpaid.fitness[0]  # eq. 3 is not changed
    gait = evaluate_controller(path, seconds=SECONDS, gait_measures=True)["gait"]["per_episode"][0]
    upright = min(paid.upright_s[0] / ev.episode_s, 1.0)  # whole ticks
    expected = upright * gait["symmetry"] * math.exp(-(gait["flight_share"] / ev.task.selection_gait_flight_sigma) ** 2)
    assert term == pytest.approx(expected, rel=1e-9, abs=1e-12)
    assert (term > 0.9) if walks else (term < 0.1)


def test_the_gait_term_settings_are_checked():
    with pytest.raises(ConfigError, match="selection_gait_flight_sigma: must be > 0"):
        TaskConfig.from_mapping({"selection_gait_flight_sigma": 0.0})
    with pytest.raises(ConfigError, match="selection_gait_coeff: must not be negative"):
        TaskConfig.from_mapping({"selection_gait_coeff": -1.0})


def test_the_gait_term_is_a_stats_column_only_with_its_coefficient():
    from evolve.config import config_path, load_evolve_config
    from evolve.run_stats import term_columns

    plain = load_evolve_config(config_path("walk"))
    paid = load_evolve_config(config_path("walk"), {"task.selection_gait_coeff": 2.0})
    assert "gait" not in term_columns(plain) and term_columns(paid)[-1] == "gait"


def _judged(path: str, **task):
    """The controller's episode without the harness, its task's stopping rules changed as ``task`` says."""
    data, spec, ev, genome = controller_setup(path, None, SECONDS)
    ev = LocomotionEvaluator(spec, dataclasses.replace(ev.task, **task), 1, threads=1)
    return ev.evaluate([genome], data.sigmoid_steepness, harness=0.0), ev


def test_the_flight_rule_ends_a_hop_as_a_fall_when_its_flight_passes_the_share():
    """The shipped human_male_50 has both feet up in about 12 % of its ticks: with the rule at
    2 % its episode ends as a fall at the tick its airborne ticks pass 2 % of the episode's,
    as the recorded foot contacts (the slow oracle, ``biped plot gait``'s) count them."""
    from evolve.replay import gait

    path = "configs/controllers/human_male_50.json"
    stopped, ev = _judged(path, flight_stop_share=0.02)
    free, _ = _judged(path, flight_stop_share=0.0)
    recorded = gait(path, seconds=SECONDS)
    airborne = (~recorded.feet.any(axis=1)).cumsum()
    last = int((airborne > 0.02 * ev.n_ticks).argmax())  # the tick that ends it
    assert airborne[-1] > 0.02 * ev.n_ticks and not free.fell[0]
    assert stopped.fell[0] and stopped.upright_s[0] == pytest.approx(recorded.times_s[last])  # the tick before
    assert stopped.terms["time"][0] == pytest.approx(recorded.times_s[last])  # the tick before's terms are kept
    assert stopped.fitness[0] < free.fitness[0]


def test_the_flight_rule_leaves_a_walk_alone_and_replays_without_stopping_rules_drop_it():
    walk, _ = _judged("configs/controllers/xl430_biped.json", flight_stop_share=0.02)
    plain, _ = _judged("configs/controllers/xl430_biped.json", flight_stop_share=0.0)
    assert not walk.fell[0] and walk.selection[0] == plain.selection[0]
    data, spec, ev, genome = controller_setup("configs/controllers/human_male_50.json", None, SECONDS,
                                              stagnation_stop=False)
    assert ev.task.flight_stop_share == 0.0 and ev.task.stagnation_s == 1e9


def test_the_stagnation_pace_ends_an_episode_that_gains_less_than_it_in_stagnation_s():
    """The shipped biped walks about 0.7 leg lengths a second: a pace of 0.1 leg lengths per
    3 s leaves it alone, 3 leg lengths per 3 s (faster than it walks) ends it, not as a fall,
    within the first stagnation_s after a gain it cannot repeat."""
    path = "configs/controllers/xl430_biped.json"
    plain, ev = _judged(path, stagnation_progress_leg=0.0)
    slow, _ = _judged(path, stagnation_progress_leg=0.1)
    fast, _ = _judged(path, stagnation_progress_leg=3.0)
    assert plain.upright_s[0] >= SECONDS - ev.tick_s and not plain.fell[0]
    assert slow.fitness[0] == plain.fitness[0] and slow.upright_s[0] == plain.upright_s[0]
    assert not fast.fell[0] and ev.task.stagnation_s < fast.upright_s[0] <= ev.task.stagnation_s + ev.tick_s
    assert fast.fitness[0] < plain.fitness[0]
    with pytest.raises(ConfigError, match="task.stagnation_progress_leg: must not be negative"):
        TaskConfig.from_mapping({"stagnation_progress_leg": -0.1})


@pytest.mark.parametrize("share", [-0.1, 1.0])
def test_the_flight_rule_takes_a_share(share):
    with pytest.raises(ConfigError, match="task.flight_stop_share: (must not be negative|is a share of the ticks)"):
        TaskConfig.from_mapping({"flight_stop_share": share})


@pytest.mark.parametrize("path", ["configs/controllers/xl430_biped.json", "configs/controllers/human_male_50.json"])
def test_the_smooth_term_is_the_mean_kernel_of_the_goals_second_difference(path):
    """Against the goals recorded tick by tick (the slow oracle): the mean over the episode's
    ticks of exp(-(RMS of the second difference / sigma)^2), from the start's goals on."""
    import numpy as np

    data, spec, ev, genome = controller_setup(path, None, SECONDS)
    plain = ev.evaluate([genome], data.sigmoid_steepness, harness=0.0)
    task = dataclasses.replace(ev.task, selection_smooth_coeff=3.0, selection_smooth_sigma_deg=4.0)
    ev = LocomotionEvaluator(spec, task, 1, threads=1)
    goals = []
    paid = ev.evaluate([genome], data.sigmoid_steepness, harness=0.0,
                       on_tick=lambda e, alive: goals.append(e.ctrl[0, e.driven].copy()))
    assert "smooth" not in plain.terms and paid.fitness[0] == plain.fitness[0]
    start = ev.hold[ev.driven]
    g = np.array([start, start] + goals)
    rms = np.sqrt(np.mean((g[2:] - 2 * g[1:-1] + g[:-2]) ** 2, axis=1))
    up = len(goals) if not paid.fell[0] else len(goals) - 1  # a fall's tick is not paid
    expected = np.exp(-(rms[:up] / np.radians(4.0)) ** 2).sum() / ev.n_ticks
    assert paid.terms["smooth"][0] == pytest.approx(expected, rel=1e-9)
    assert paid.selection[0] - plain.selection[0] == pytest.approx(3.0 * expected)
    assert 0.0 < expected < 1.0


def test_the_smooth_term_is_a_stats_column_only_with_its_coefficient_and_its_width_is_checked():
    from evolve.config import config_path, load_evolve_config
    from evolve.run_stats import term_columns

    assert "smooth" not in term_columns(load_evolve_config(config_path("walk")))
    paid = load_evolve_config(config_path("walk"), {"task.selection_smooth_coeff": 2.0})
    assert term_columns(paid)[-1] == "smooth"
    with pytest.raises(ConfigError, match="selection_smooth_sigma_deg: must be > 0"):
        TaskConfig.from_mapping({"selection_smooth_sigma_deg": 0.0})

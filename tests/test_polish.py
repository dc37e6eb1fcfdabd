"""The weight polish (biped polish): the topology kept, the weights moved by CMA-ES, every
candidate of an update on the same robots, a seed fixing the whole polish."""

import json
from pathlib import Path

import numpy as np
import pytest

from evolve.cli import main
from evolve.locomotion.export import genome_from_controller
from evolve.polish import weights_of, with_weights
from sim2real.controller.file import Controller

WALKER = "configs/controllers/xl430_biped_no_gyro.json"


def test_weights_round_trip_through_a_genome_and_stay_within_the_format():
    genome = genome_from_controller(Controller.load(WALKER))
    enabled, weights = weights_of(genome)
    moved = with_weights(genome, enabled, weights + 100.0)
    assert [moved.conns[k].weight for k in enabled] == [20.0] * len(enabled)  # clipped to the bound
    again = with_weights(genome, enabled, weights)
    assert weights_of(again)[1].tolist() == weights.tolist()
    assert {k: (g.src, g.dst, g.enabled) for k, g in again.conns.items()} == \
        {k: (g.src, g.dst, g.enabled) for k, g in genome.conns.items()}  # the topology frozen


def test_biped_polish_writes_a_loadable_walker_and_a_seed_fixes_it(tmp_path, capsys):
    args = ["polish", WALKER, "--updates", "2", "--popsize", "4", "--robots", "2", "--every", "1",
            "--validation", "3", "--test", "3", "--seed", "5", "--json"]
    results = []
    for name in ("a", "b"):
        assert main([*args, "--out", str(tmp_path / name)]) == 0
        results.append(json.loads(capsys.readouterr().out.strip().splitlines()[-1]))
    a, b = results
    def judged(history):  # the seconds aside
        return [{k: v for k, v in entry.items() if k != "elapsed_s"} for entry in history]
    assert judged(a["history"]) == judged(b["history"]) and a["test"] == b["test"]  # the seed fixes every draw and step
    assert len(a["history"]) == 3 and a["weights"] > 50
    polished = Controller.load(tmp_path / "a" / "polished.json")
    original = Controller.load(WALKER)
    assert [c[:2] for c in polished.connections] == [c[:2] for c in original.connections]
    assert polished.provenance["polish"]["updates"] == 2 and "test_walk_rate" in polished.provenance["polish"]
    if a["kept_update"]:
        assert not np.allclose([c[2] for c in polished.connections], [c[2] for c in original.connections])


def test_a_straight_polish_scores_longer_episodes_with_the_straight_term_and_counts_no_turned_walk(tmp_path):
    from evolve.polish import Judge

    plain = Judge(WALKER, ["randomize"], 2)
    straight = Judge(WALKER, ["randomize"], 2, episode_s=4.0, selection={"selection_straight_coeff": 8.0},
                     heading_deg=1e-6)
    assert straight.evaluator.episode_s == pytest.approx(4.0, abs=0.05) and straight.evaluator.task.selection_straight_coeff == 8.0
    keys = np.array([[1, 0, 0, 0]])
    score, _ = plain.run([plain.start], keys)
    s8, walked = straight.run([straight.start], keys)
    assert not walked.any()  # every walk turns a little: none is within 1e-6 deg
    assert s8[0, 0] != score[0, 0]
    on_model = Judge(WALKER, ["randomize"], 1, nominal=True)
    too_fast = Judge(WALKER, ["randomize"], 1, min_speed_m_s=5.0, nominal=True)  # no small robot walks at 5 m/s
    none = np.empty((0, 4), dtype=np.int64)  # the nominal robot alone
    assert on_model.run([on_model.start], none)[1].all() and not too_fast.run([too_fast.start], none)[1].any()
    paid = Judge(WALKER, ["randomize"], 1, selection={"selection_walk_bonus": 50.0}, nominal=True)
    bonus = 50.0 - on_model.evaluator.task.selection_walk_bonus  # the model walks: the walk is paid so much more
    assert paid.run([paid.start], none)[0][0, 0] == pytest.approx(on_model.run([on_model.start], none)[0][0, 0] + bonus)
    faster = Judge(WALKER, ["randomize"], 2, episode_s=4.0,
                   selection={"selection_straight_coeff": 8.0, "selection_speed_leg_s": 1.2})
    assert faster.run([faster.start], keys)[0][0, 0] != s8[0, 0]  # the straight term's kernel moved
    with_model = Judge(WALKER, ["randomize"], 2, nominal=True)
    both, _ = with_model.run([with_model.start], keys)
    assert both.shape == (1, 2) and both[0, 0] == score[0, 0]  # the drawn robot as before, then the model
    assert main(["polish", WALKER, "--out", str(tmp_path / "p"), "--updates", "1", "--popsize", "4", "--robots", "1",
                 "--validation", "1", "--test", "1", "--episode-s", "2", "--straight", "8", "--heading-deg", "45",
                 "--with-nominal", "--speed-leg-s", "0.8", "--min-speed", "0.15", "--walk-bonus", "20", "--lr-adapt", "--json"]) == 0
    provenance = Controller.load(tmp_path / "p" / "polished.json").provenance["polish"]
    assert (provenance["straight"], provenance["speed_leg_s"], provenance["min_speed_m_s"],
            provenance["walk_bonus"], provenance["lr_adapt"]) == (8.0, 0.8, 0.15, 20.0, True)


def test_robots_take_turns_at_several_ranges_each_drawn_as_its_ranges_alone_would():
    from evolve.polish import Judge

    keys = np.array([[3, 0, 0, 0], [3, 0, 0, 1], [3, 0, 0, 2]])
    mixed, wide, narrow = (Judge(WALKER, names, 3) for names in
                           (["randomize", "narrow"], ["randomize"], ["narrow"]))
    score, _ = mixed.run([mixed.start], keys)
    alone = {name: judge.run([judge.start], keys)[0][0] for name, judge in (("wide", wide), ("narrow", narrow))}
    assert score[0].tolist() == [alone["wide"][0], alone["narrow"][1], alone["wide"][2]]
    assert alone["wide"][1] != alone["narrow"][1]


def test_on_best_sees_every_kept_walker_and_can_stop_the_search(tmp_path):
    from evolve.polish import polish

    seen = []

    def on_best(kept, entry):
        seen.append((entry["update"], Controller.load(kept).provenance["polish"]["kept_update"]))
        return len(seen) == 2

    # these settings keep the weights of updates 2, 3 and 6, each better on validation than the last
    r = polish(Path(WALKER), tmp_path, updates=9, popsize=4, robots=1, validation=2, test=1, every=1, episode_s=2.0,
               sigma=0.3, seed=3, on_best=on_best, log=lambda line: None)
    assert seen == [(2, 2), (3, 3)] and r["kept_update"] == 3
    assert [e["update"] for e in r["history"]] == list(range(4)), "the search stopped where on_best said so"
    assert r["search_minutes"] <= r["minutes"]

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
    score = plain.run([plain.start], keys).score
    s8, walked, walked_any, _ = straight.run([straight.start], keys)
    assert not walked.any()  # every walk turns a little: none is within 1e-6 deg
    assert walked_any.all(), "a walk of any heading is still a walk"
    assert s8[0, 0] != score[0, 0]
    on_model = Judge(WALKER, ["randomize"], 1, nominal=True)
    too_fast = Judge(WALKER, ["randomize"], 1, min_speed_m_s=5.0, nominal=True)  # no small robot walks at 5 m/s
    none = np.empty((0, 4), dtype=np.int64)  # the nominal robot alone
    assert on_model.run([on_model.start], none)[1].all() and not too_fast.run([too_fast.start], none)[1].any()
    assert too_fast.run([too_fast.start], none)[2].all()  # ... but it walks
    paid = Judge(WALKER, ["randomize"], 1, selection={"selection_walk_bonus": 50.0}, nominal=True)
    bonus = 50.0 - on_model.evaluator.task.selection_walk_bonus  # the model walks: the walk is paid so much more
    assert paid.run([paid.start], none)[0][0, 0] == pytest.approx(on_model.run([on_model.start], none)[0][0, 0] + bonus)
    faster = Judge(WALKER, ["randomize"], 2, episode_s=4.0,
                   selection={"selection_straight_coeff": 8.0, "selection_speed_leg_s": 1.2})
    assert faster.run([faster.start], keys)[0][0, 0] != s8[0, 0]  # the straight term's kernel moved
    with_model = Judge(WALKER, ["randomize"], 2, nominal=True)
    both = with_model.run([with_model.start], keys).score
    assert both.shape == (1, 2) and both[0, 0] == score[0, 0]  # the drawn robot as before, then the model
    assert main(["polish", WALKER, "--out", str(tmp_path / "p"), "--updates", "1", "--popsize", "4", "--robots", "1",
                 "--validation", "1", "--test", "1", "--episode-s", "2", "--straight", "8", "--heading-deg", "45",
                 "--with-nominal", "--speed-leg-s", "0.8", "--min-speed", "0.15", "--walk-bonus", "20", "--lr-adapt",
                 "--worst", "0.5", "--json"]) == 0
    provenance = Controller.load(tmp_path / "p" / "polished.json").provenance["polish"]
    assert (provenance["straight"], provenance["speed_leg_s"], provenance["min_speed_m_s"],
            provenance["walk_bonus"], provenance["lr_adapt"], provenance["worst"]) == (8.0, 0.8, 0.15, 20.0, True, 0.5)


def test_a_cvar_ranking_scores_each_candidate_by_its_worst_robots():
    from evolve.polish import ranked_by

    score = np.array([[9.0, 1.0, 5.0, 7.0], [4.0, 4.0, 4.0, 4.0]])
    assert ranked_by(score, 1.0).tolist() == [5.5, 4.0]  # the mean: the first candidate ranks higher
    assert ranked_by(score, 0.5).tolist() == [3.0, 4.0]  # its two worst robots: the steady one ranks higher
    assert ranked_by(score, 0.01).tolist() == [1.0, 4.0]  # at least one robot
    assert ranked_by(score, 0.75).tolist() == [13.0 / 3, 4.0]


def test_robots_take_turns_at_several_ranges_each_drawn_as_its_ranges_alone_would():
    from evolve.polish import Judge

    keys = np.array([[3, 0, 0, 0], [3, 0, 0, 1], [3, 0, 0, 2]])
    mixed, wide, narrow = (Judge(WALKER, names, 3) for names in
                           (["randomize", "narrow"], ["randomize"], ["narrow"]))
    score = mixed.run([mixed.start], keys).score
    alone = {name: judge.run([judge.start], keys)[0][0] for name, judge in (("wide", wide), ("narrow", narrow))}
    assert score[0].tolist() == [alone["wide"][0], alone["narrow"][1], alone["wide"][2]]
    assert alone["wide"][1] != alone["narrow"][1]


def test_on_best_sees_every_kept_walker_and_can_stop_the_search(tmp_path):
    from evolve.polish import polish

    settings = dict(updates=6, popsize=4, robots=1, validation=2, test=1, every=1, episode_s=2.0, sigma=0.3,
                    seed=3, log=lambda line: None)
    seen = []

    def on_best(kept, entry):
        seen.append((entry["update"], Controller.load(kept).provenance["polish"]["kept_update"]))
        return False

    r = polish(Path(WALKER), tmp_path / "all", on_best=on_best, **settings)
    best, improved = (-1.0, -np.inf), []  # the updates whose validation beat every earlier one
    for entry in r["history"]:
        if (entry["walk_rate"], entry["score"]) > best:
            best = (entry["walk_rate"], entry["score"])
            improved.append(entry["update"])
    assert improved[1:], "these settings keep some update's weights"
    assert seen == [(u, u) for u in improved[1:]] and r["kept_update"] == improved[-1]

    stops = polish(Path(WALKER), tmp_path / "stop", on_best=lambda kept, entry: True, **settings)
    assert [e["update"] for e in stops["history"]] == list(range(improved[1] + 1)), "stopped where on_best said so"
    assert stops["kept_update"] == improved[1] and stops["search_minutes"] <= stops["minutes"]


def test_a_cut_polish_resumes_as_the_uncut_one_goes_on_and_nothing_else_resumes_it(tmp_path):
    """A polish cut after any update continues from ``checkpoint.json`` exactly as the uncut
    polish went on (its CMA-ES replayed from the scores it was told); a folder holding a
    checkpoint is not overwritten, and another walker or setting does not resume it."""
    from evolve.polish import polish
    from sim2real.errors import ConfigError

    settings = dict(updates=4, popsize=4, robots=1, validation=2, test=2, every=1, episode_s=2.0, sigma=0.3,
                    seed=3, log=lambda line: None)
    whole = polish(Path(WALKER), tmp_path / "whole", **settings)

    def cut_at(update):
        def log(line):
            if line.startswith(f"update {update}/"):
                raise KeyboardInterrupt  # after the update's validation, before its checkpoint
        return log

    cut = tmp_path / "cut"
    with pytest.raises(KeyboardInterrupt):
        polish(Path(WALKER), cut, **{**settings, "log": cut_at(3)})
    assert len(json.loads((cut / "checkpoint.json").read_text())["scores"]) == 2
    with pytest.raises(FileExistsError, match="holds a polish"):
        polish(Path(WALKER), cut, **settings)
    with pytest.raises(ConfigError, match="identity.sigma"):
        polish(Path(WALKER), cut, **{**settings, "sigma": 0.2}, resume=True)
    resumed = polish(Path(WALKER), cut, **settings, resume=True)

    def judged(result):  # the seconds aside
        return {**{k: v for k, v in result.items() if k not in ("minutes", "search_minutes", "polished")},
                "history": [{k: v for k, v in e.items() if k != "elapsed_s"} for e in result["history"]]}
    assert judged(resumed) == judged(whole)
    assert Controller.load(cut / "polished.json").connections == Controller.load(tmp_path / "whole" /
                                                                                 "polished.json").connections
    longer = polish(Path(WALKER), cut, **{**settings, "updates": 5}, resume=True)  # a finished polish goes on
    assert [e["update"] for e in longer["history"]] == list(range(6))
    assert longer["history"][:5] == resumed["history"]


def test_biped_polish_refuses_a_folder_holding_a_polish_unless_resumed(tmp_path, capsys):
    (tmp_path / "checkpoint.json").write_text("{}")
    assert main(["polish", WALKER, "--out", str(tmp_path)]) == 2
    assert "holds a polish" in capsys.readouterr().err
    assert main(["polish", WALKER, "--out", str(tmp_path), "--resume"]) == 2
    assert "checkpoint.json: version: not a version-1 polish checkpoint" in capsys.readouterr().err


def test_ctrl_c_leaves_a_checkpoint_that_resume_continues(tmp_path):
    """A real ``biped polish`` process interrupted (SIGINT) mid-search exits 130 naming the way
    on; ``--resume`` continues it to a finished polish."""
    import os
    import signal
    import subprocess
    import sys
    import time

    out = tmp_path / "p"
    args = [sys.executable, "-m", "evolve.cli", "polish", WALKER, "--out", str(out), "--popsize", "4", "--robots",
            "1", "--validation", "1", "--test", "1", "--every", "1", "--episode-s", "1", "--seed", "2"]
    # (a shell's background job inherits SIGINT ignored; a user's Ctrl-C reaches a polish that is not)
    process = subprocess.Popen([*args, "--updates", "100000"], stderr=subprocess.PIPE, text=True,
                               env={**os.environ, "PYTHONPATH": os.getcwd()},
                               preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    started = time.monotonic()  # a loaded machine takes minutes to start MuJoCo
    while not (out / "checkpoint.json").exists() and process.poll() is None and time.monotonic() - started < 900:
        time.sleep(0.1)
    assert (out / "checkpoint.json").exists(), f"no checkpoint in {time.monotonic() - started:.0f} s"
    process.send_signal(signal.SIGINT)
    _, err = process.communicate(timeout=900)
    assert process.returncode == 130 and "--resume" in err
    done = len(json.loads((out / "checkpoint.json").read_text())["scores"])
    finished = subprocess.run([*args, "--updates", str(done + 1), "--resume", "--json"], capture_output=True,
                              text=True, timeout=900, env={**os.environ, "PYTHONPATH": os.getcwd()})
    assert finished.returncode == 0, finished.stderr
    assert [e["update"] for e in json.loads(finished.stdout)["history"]] == list(range(done + 2))


def test_a_polish_without_a_final_test_stops_on_its_plateau_or_when_told(tmp_path):
    """biped train's polish stages: no final test (``test=0``, the training measures its walker
    itself), a speed gate, a plateau and a time stop; the result says there was no test."""
    from evolve.polish import polish

    settings = dict(popsize=2, robots=1, validation=1, test=0, every=1, episode_s=1.0, seed=2, min_speed_m_s=0.1,
                    log=lambda line: None)
    r = polish(Path(WALKER), tmp_path / "told", updates=50, should_stop=lambda: True, **settings)
    assert [e["update"] for e in r["history"]] == [0, 1] and r["lifted"] is None
    assert r["test"]["polished"]["walk_rate"] is None and (tmp_path / "told" / "polished.json").exists()
    flat = polish(Path(WALKER), tmp_path / "flat", updates=50, patience=2, **settings)
    assert len(flat["history"]) - 1 - flat["kept_update"] == 2, "stopped two validations after its last keep"
    asked = []  # a rule asked at each validation: no plateau for three, then one of two
    rule = polish(Path(WALKER), tmp_path / "rule", updates=50, patience=lambda: asked.append(1) or
                  (None if len(asked) <= 3 else 2), **settings)
    assert len(rule["history"]) - 1 >= 4 and len(rule["history"]) - 1 - rule["kept_update"] == 2
    assert len(asked) == len(rule["history"]) - 1

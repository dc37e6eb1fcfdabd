"""`benchmarks.human_walk` counts a run as walking only when its walker's gait is a walk (issue
51), and keeps seed 000's count as ``covers_2m``: the counting with the evolution and the
replays replaced by stand-ins (as tests/test_robust_walk_summary.py tests train's stages)."""

from __future__ import annotations

import json

import numpy as np
import pytest

from benchmarks import human_walk
from sim2real.atomic_json import write_json_atomic
from sim2real.gait_measures import measure_gait

TICKS = np.arange(200)  # 10 s of 0.05 s ticks
PHASE = TICKS % 20
WAVE = np.sin(2 * np.pi * PHASE / 20)
# the stand-in gaits' measures: an alternating walk and a one-legged hop with flight phases
WALK = measure_gait(TICKS * 0.05, np.stack([WAVE, -WAVE], axis=1) * 0.3,
                    np.stack([PHASE < 12, (PHASE - 10) % 20 < 12], axis=1)).to_dict()
HOP = measure_gait(TICKS * 0.05, np.stack([0.03 * WAVE, 0.4 * WAVE], axis=1),
                   np.stack([PHASE >= 4, (PHASE >= 4) & (PHASE < 8)], axis=1)).to_dict()
FLIGHT_ONLY = {**WALK, "flight_share": 0.05}  # legs alike, but both feet up 5 % of the time
SHORT = measure_gait(TICKS[:30] * 0.05, np.zeros((30, 2)), np.ones((30, 2), dtype=bool)).to_dict()


def test_the_stand_in_gaits_are_what_they_say():
    assert WALK["walk"] and not HOP["walk"] and not SHORT["walk"]


@pytest.mark.parametrize("covers, gait, walked", [
    (True, WALK, True), (True, HOP, False), (True, FLIGHT_ONLY, False), (True, SHORT, False), (False, WALK, False)])
def test_a_run_walked_when_it_covers_2_m_with_a_walks_gait(covers, gait, walked):
    assert human_walk.walks_a_walk(covers, gait) is walked


def test_the_tally_counts_walks_and_keeps_seed_000s_count_beside():
    runs = [{"walked": True, "covers_2m": True}, {"walked": False, "covers_2m": True},
            {"walked": False, "covers_2m": True}, {"walked": False, "covers_2m": False}]
    assert human_walk.tally(runs) == {"walked": 1, "rate": 0.25, "covers_2m": 3, "covers_2m_rate": 0.75}
    assert human_walk.tally([]) == {"walked": 0, "rate": None, "covers_2m": 0, "covers_2m_rate": None}


def _finished_run(folder, first_walker: dict | None) -> None:
    (folder / "run").mkdir(parents=True)
    (folder / "run" / "stats.csv").write_text("generation,best\n0,1\n1,2\n2,3\n")
    write_json_atomic(folder / "state.json", {"first_walker": first_walker, "best_walker": first_walker})


@pytest.mark.parametrize("first, gait, walked, covers", [
    ({"generation": 1, "minutes": 2.0, "distance_m": 2.4}, HOP, False, True),
    ({"generation": 1, "minutes": 2.0, "distance_m": 2.4}, WALK, True, True),
    (None, WALK, False, False)])
def test_a_finished_run_reports_its_walkers_gait_and_both_verdicts(tmp_path, monkeypatch, first, gait, walked, covers):
    measured = []
    monkeypatch.setattr(human_walk, "gait_of", lambda controller, body=None: (measured.append(controller), gait)[1])
    monkeypatch.setattr(human_walk, "sustained_walk", lambda controller, body=None: {"sustained_m": 9.0,
                                                                                    "sustained_s": 60.0})
    _finished_run(tmp_path, first)
    result = human_walk.finish("male_50", 1, tmp_path, quiet=True)
    assert (result["walked"], result["covers_2m"], result["gait"]) == (walked, covers, gait)
    assert measured == [tmp_path / ("walker.json" if first else "run/controller.json")]  # the walker's gait
    assert json.loads((tmp_path / "result.json").read_text()) == result
    assert result["generations_run"] == 3


def test_finished_runs_read_back_are_counted_both_ways(tmp_path, monkeypatch, capsys):
    """Two runs that covered 2 m before the gait measures existed (one a hop, one a walk), one
    that did not, and one finished with them; ``--hours 0`` starts no evolution."""
    out = tmp_path / "runs"
    old = {"male_50-seed1": True, "male_50-seed2": True, "female_5-seed1": False}
    for name, walked in old.items():
        (out / name).mkdir(parents=True)
        write_json_atomic(out / name / "result.json", {"preset": name.split("-")[0], "walked": walked,
                                                       "sustained_m": 5.0})
    (out / "female_5-seed2").mkdir()
    new = {"preset": "female_5", "walked": False, "covers_2m": True, "gait": HOP, "sustained_m": 5.0}
    write_json_atomic(out / "female_5-seed2" / "result.json", new)
    before = {p: p.read_bytes() for p in out.rglob("result.json")}
    gaits = {"male_50-seed1": HOP, "male_50-seed2": WALK, "female_5-seed1": WALK}
    measured = []

    def gait_of(controller, body=None):
        measured.append(controller.relative_to(out).as_posix())
        return gaits[controller.relative_to(out).parts[0]]
    monkeypatch.setattr(human_walk, "gait_of", gait_of)
    human_walk.main(["--presets", "male_50", "female_5", "--seeds", "1", "2", "3", "--out", str(out),
                     "--hours", "0", "--json"])
    result = json.loads(capsys.readouterr().out.splitlines()[-1])
    assert (result["walked"], result["covers_2m"]) == (1, 3)
    assert result["rate"] == pytest.approx(1 / 4) and result["covers_2m_rate"] == pytest.approx(3 / 4)
    assert sorted(result["unfinished"]) == ["female_5-seed3", "male_50-seed3"]
    runs = {(r["preset"], r["walked"], r["covers_2m"]) for r in result["runs"]}
    assert runs == {("male_50", False, True), ("male_50", True, True), ("female_5", False, False),
                    ("female_5", False, True)}
    # the old runs' walkers measured now (the one without a walker: its best controller); the new one is not
    assert sorted(measured) == ["female_5-seed1/run/controller.json", "male_50-seed1/walker.json",
                                "male_50-seed2/walker.json"]
    assert {p: p.read_bytes() for p in out.rglob("result.json")} == before  # finished runs are only read


def test_a_variant_body_from_a_file_is_resumed_and_judged_on_itself(tmp_path):
    """An ablation's body is a robot file named like the project's human_stepping but with other
    ankle ranges: its run resumes (the file given again) and its controllers are replayed on it,
    not on the project's body (whose joint map they would not match)."""
    import yaml

    from evolve.replay import evaluate_controller
    from sim2real.errors import ConfigError

    body = "benchmarks/records/human-gait/configs/human_stepping_ankle0.yaml"
    config = tmp_path / "tiny.yaml"
    config.write_text(yaml.safe_dump({"extends": "walk_human", "neat": {"population_size": 10, "target_species": 2},
                                      "task": {"episode_s": 1.0, "harness_generations": 1}}))
    out = tmp_path / "runs"
    folder = human_walk.run_folder(out, "female_5", 1, body)
    folder.mkdir(parents=True)
    assert not human_walk.evolve_preset("female_5", 1, folder, config_name=str(config), robot=body, generations=3,
                                        after_walker=0, threads=1, deadline=0.0, quiet=True)  # cut after one
    human_walk.main(["--config", str(config), "--robot", body, "--presets", "female_5", "--seeds", "1",
                     "--generations", "3", "--out", str(out), "--quiet", "--json"])
    result = json.loads((folder / "result.json").read_text())
    assert result["generations_run"] == 3 and result["gait"]["ticks"] >= 0
    with pytest.raises(ConfigError):  # the project's body is not the one it was evolved on
        evaluate_controller(folder / "run" / "controller.json", seconds=1.0)


def test_a_walks_gait_beats_a_farther_hop_and_a_run_stops_after_its_first_walk(tmp_path, monkeypatch):
    """Every champion judged covers 2 m (a stand-in); their gaits, in turn: a hop, a walk, a hop...
    The run keeps the walk though the later hops go farther, and stops ``after_walker``
    generations after that walk, not after its first walker (the hop)."""
    import yaml

    config = tmp_path / "tiny.yaml"
    config.write_text(yaml.safe_dump({"extends": "walk_human", "neat": {"population_size": 10, "target_species": 2},
                                      "task": {"episode_s": 1.0, "harness_generations": 1}}))
    gaits = iter([HOP, WALK, HOP, HOP, HOP, HOP])
    judged_files = []
    monkeypatch.setattr(human_walk, "walked_by_seed_000", lambda upright, distance, episode_s: True)
    monkeypatch.setattr(human_walk, "gait_of", lambda controller, body=None: (judged_files.append(controller), next(gaits))[1])
    folder = tmp_path / "run"
    folder.mkdir()
    assert human_walk.evolve_preset("female_5", 1, folder, config_name=str(config), robot="human_stepping",
                                    generations=50, after_walker=2, threads=1, deadline=float("inf"), quiet=True)
    state = json.loads((folder / "state.json").read_text())
    # the harness is off from generation 1: a hop there, the walk at 2, then 3 and 4
    assert [state[k]["generation"] for k in ("first_walker", "first_walk", "best_walker")] == [1, 2, 2]
    assert state["best_walker"]["a_walk"] and not state["first_walker"]["a_walk"]
    assert len(judged_files) == 4 and not (folder / "candidate.json").exists()
    assert human_walk.better_walker({"distance_m": 2.1, "a_walk": True}, {"distance_m": 5.0, "a_walk": False})
    assert not human_walk.better_walker({"distance_m": 5.0}, {"distance_m": 2.1, "a_walk": True})
    assert human_walk.better_walker({"distance_m": 5.0, "a_walk": False}, {"distance_m": 2.1})

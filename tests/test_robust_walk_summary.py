"""The training's stage logic (which walker each stage starts from and keeps, what it tests, how
a cut stage resumes) with the searches and measures replaced by stand-ins, and the benchmark's
summary of trainings."""

from __future__ import annotations

import shutil
from pathlib import Path
from types import SimpleNamespace

import pytest

from evolve import train as tr
from evolve import train_speed as ts
from evolve import walk_measures as wm
from evolve.train_record import latest_walker

WALKER = Path("configs/controllers/xl430_biped.json")


def _test(walked: int, default: int = 3) -> dict:
    return {"randomized": {"walked": walked}, "default": {"walked": default}, "draws": 10, "default_episodes": 3}


@pytest.fixture
def budget() -> tr.Budget:
    return tr.Budget(minutes=60.0)


def fake_polish(kept_updates: list[int], calls: list):
    """A stand-in for evolve.polish.polish: validation keeps the walker at ``kept_updates``."""
    def polish(source, out, *, updates, popsize, seed, on_best, resume, patience, threads, test, should_stop, log,
               **options):
        calls.append({"source": Path(source), "out": Path(out), "resume": resume, "seed": seed, "patience": patience,
                      **options})
        history = [{"update": 0}]
        for update in kept_updates:
            shutil.copyfile(source, Path(out) / "kept.json")
            history.append({"update": update})
            if on_best(Path(out) / "kept.json", {"update": update, "elapsed_s": 1.0}):
                break
        shutil.copyfile(source, Path(out) / "polished.json")
        return {"polished": str(Path(out) / "polished.json"), "kept_update": kept_updates[-1] if kept_updates else 0,
                "history": history, "physics_steps": 1, "minutes": 0.1}
    return polish


def test_a_polish_stage_tests_each_kept_walker_once_and_keeps_the_last_robust(tmp_path, monkeypatch, budget):
    import evolve.polish

    calls, tested = [], []
    verdicts = {5: _test(6), 10: _test(9), 15: _test(7)}
    monkeypatch.setattr(evolve.polish, "polish", fake_polish([5, 10, 15], calls))

    def robustness(path, threads=1, robot=None):
        tested.append(len(tested))
        return verdicts[[5, 10, 15][len(tested) - 1]]
    monkeypatch.setattr(wm, "robustness", robustness)
    record = tr.polish_stage(WALKER, tmp_path / "p", tr.TrainSettings(seed=4), budget, 0.65, lambda s: None,
                             dict(tr.POLISH))
    assert len(tested) == 3
    assert [t["robust"] for t in record["tests"]] == [False, True, False]
    assert record["walker"] == str(tmp_path / "p" / "walker.json")  # update 10's: the last robust one
    assert sorted(p.name for p in (tmp_path / "p").glob("robust_update*.json")) == ["robust_update10.json"]
    assert calls[0]["seed"] == 4 and calls[0]["robots"] == tr.POLISH["robots"] and not calls[0]["resume"]
    # cut after its tests: the resumed stage meets the same updates and tests none again
    (tmp_path / "p" / "checkpoint.json").write_text("{}")
    monkeypatch.setattr(wm, "robustness", lambda *a, **k: pytest.fail("a walker tested twice"))
    again = tr.polish_stage(WALKER, tmp_path / "p", tr.TrainSettings(seed=4), budget, 0.65, lambda s: None,
                            dict(tr.POLISH))
    assert calls[-1]["resume"] and again["tests"] == record["tests"] and again["walker"] == record["walker"]


@pytest.mark.parametrize("neat_robust", [True, False])
def test_the_walk_rate_polish_stops_on_a_plateau_only_with_a_robust_walker(tmp_path, monkeypatch, budget, neat_robust):
    """Without a robust walker nothing after the polish would use its minutes: no plateau stops it."""
    import evolve.polish

    calls = []
    monkeypatch.setattr(evolve.polish, "polish", fake_polish([], calls))
    state = {"stages": {"neat": {"walker": str(WALKER), "robust": neat_robust}}}
    tr._polish("xl430_biped", tmp_path, tr.TrainSettings(), state, budget, lambda s: None)
    patience = calls[0]["patience"]  # asked at each validation
    assert patience() == (tr.PATIENCE if neat_robust else None)
    (tmp_path / "polish" / "walker.json").write_text("{}")  # a robust walker kept mid-stage
    assert patience() == tr.PATIENCE, "a robust walker brings the plateau back"


def test_a_polish_stage_past_its_share_of_the_budget_does_not_start(tmp_path, monkeypatch):
    import evolve.polish

    monkeypatch.setattr(evolve.polish, "polish", lambda *a, **k: pytest.fail("polished past its budget"))
    spent = tr.Budget(minutes=10.0, spent_s=7 * 60.0)
    record = tr.polish_stage(WALKER, tmp_path / "p", tr.TrainSettings(), spent, 0.65, lambda s: None, dict(tr.POLISH))
    assert record["skipped"] and record["walker"] is None


class FakeNeatRun:
    """A stand-in for evolve.run.Run in the NEAT stage: each generation costs ``seconds`` of the
    budget; the seeds in ``walks_at`` have a candidate walk on validation robots from that
    generation on.  Off the harness (generation 25) its champion never changes."""

    def __init__(self, config, folder, budget, walks_at, seconds, cut_after_stop=False):
        self.config, self.folder, self.budget, self.walks_at, self.seconds = config, Path(folder), budget, walks_at, seconds
        self.cut_after_stop = cut_after_stop  # Ctrl-C while the run writes its last checkpoint
        self.generation_offset, self.best, self.evolved = 0, None, False
        self.population = type("P", (), {"generation": 0})()
        self.folder.mkdir(parents=True, exist_ok=True)

    def evolve(self, stop):
        self.evolved = True
        while True:
            self.population.generation += 1
            self.budget.spent_s += self.seconds
            g = self.population.generation
            self.best = SimpleNamespace(generation=min(g, 25), harness=g < 25, genome=SimpleNamespace(key=7))
            walks = self.walks_at.get(self.config.seed)
            row = {"validation_walked": 3 if walks is not None and g >= walks else (0 if g % 5 == 0 else "")}
            if stop(self, row):
                if self.cut_after_stop:
                    raise KeyboardInterrupt
                return self.best

    def controller(self, best):
        return SimpleNamespace(save=lambda path: Path(path).write_text("{}"))

    def close(self):
        pass


def _fake_neat(monkeypatch, budget, walks_at: dict, seconds: float, cut_after_stop: bool = False) -> list:
    """Run.create replaced by :class:`FakeNeatRun`; the budget's clock stands still (only the
    fake generations spend it).  Returns (seed, folder name, run) of each run made."""
    import evolve.run

    monkeypatch.setattr(tr, "time", SimpleNamespace(monotonic=lambda: 0.0))

    created = []

    def create(config, folder, log):
        run = FakeNeatRun(config, folder, budget, walks_at, seconds, cut_after_stop)
        created.append((config.seed, Path(folder).name, run))
        return run

    monkeypatch.setattr(evolve.run, "Run", SimpleNamespace(create=create))
    monkeypatch.setattr(wm, "robustness", lambda *a, **k: _test(0, 0))
    return created


def test_neat_starts_again_from_a_new_seed_when_nothing_walks_off_the_harness(tmp_path, monkeypatch):
    """Seed 1 never walks: 25 generations after the harness (generation 50) NEAT starts again
    from seed 1001, which walks at generation 30 and runs to NEAT's share of the budget."""
    budget = tr.Budget(minutes=10.0, started=0.0)  # NEAT's share: 270 s; a generation costs 1 s
    created = _fake_neat(monkeypatch, budget, {1001: 30}, seconds=1.0)
    record = tr._neat("xl430_biped", tmp_path, tr.TrainSettings(minutes=10.0), {}, budget, lambda s: None)
    assert [c[:2] for c in created] == [(1, "neat"), (1001, "neat-2")]
    assert record["seed"] == 1001 and [r["seed"] for r in record["restarts"]] == [1]
    assert record["restarts"][0]["generations"] == 25 + tr.NEAT_RESTART_AFTER
    assert record["walker"] == str(tmp_path / "neat-2" / "champion.json") and not record["robust"]
    assert record["restarts"][0]["minutes"] == pytest.approx(50 / 60)
    budget = tr.Budget(minutes=10.0, started=0.0)  # the stage again in its folder, as a resume runs it
    created = _fake_neat(monkeypatch, budget, {1001: 30}, seconds=1.0)
    again = tr._neat("xl430_biped", tmp_path, tr.TrainSettings(minutes=10.0), {}, budget, lambda s: None)
    assert [c[:2] for c in created] == [(1001, "neat-2")] and again["restarts"] == record["restarts"]


def test_no_restart_that_could_not_catch_up_nor_for_a_seed_that_walks(tmp_path, monkeypatch):
    """With less of NEAT's share left than the attempt took, NEAT goes on; a seed with a walk
    (generation 40) is never restarted."""
    budget = tr.Budget(minutes=3.0, started=0.0)  # NEAT's share: 81 s; at generation 50, 31 s left < 50 s taken
    created = _fake_neat(monkeypatch, budget, {}, seconds=1.0)
    record = tr._neat("xl430_biped", tmp_path / "a", tr.TrainSettings(minutes=3.0), {}, budget, lambda s: None)
    assert [c[:2] for c in created] == [(1, "neat")] and record["restarts"] == [] and record["generations"] == 81
    budget = tr.Budget(minutes=10.0, started=0.0)
    created = _fake_neat(monkeypatch, budget, {1: 40}, seconds=1.0)
    record = tr._neat("xl430_biped", tmp_path / "b", tr.TrainSettings(minutes=10.0), {}, budget, lambda s: None)
    assert [c[:2] for c in created] == [(1, "neat")] and record["restarts"] == [] and record["generations"] == 270


def test_neats_decision_to_restart_is_kept_through_a_cut(tmp_path, monkeypatch):
    """Cut while NEAT writes its last checkpoint after deciding to restart: the resume takes the
    decision and evolves no generation more from the seed it left."""
    budget = tr.Budget(minutes=10.0, started=0.0)
    _fake_neat(monkeypatch, budget, {1001: 30}, seconds=1.0, cut_after_stop=True)
    with pytest.raises(KeyboardInterrupt):
        tr._neat("xl430_biped", tmp_path, tr.TrainSettings(minutes=10.0), {}, budget, lambda s: None)
    created = _fake_neat(monkeypatch, budget, {1001: 30}, seconds=1.0)
    record = tr._neat("xl430_biped", tmp_path, tr.TrainSettings(minutes=10.0), {}, budget, lambda s: None)
    assert [c[:2] for c in created] == [(1, "neat"), (1001, "neat-2")]
    assert not created[0][2].evolved, "the cut attempt evolved again"
    assert [r["seed"] for r in record["restarts"]] == [1] and record["seed"] == 1001


def test_a_cut_polish_stage_resumes_past_its_share_and_a_begun_speed_restart_is_finished(tmp_path, monkeypatch):
    """A polish cut after its share ran out is finished from its checkpoint (its kept walker
    stands), and so is the speed polish's restart, if it had begun."""
    import evolve.polish

    calls = []
    monkeypatch.setattr(evolve.polish, "polish", fake_polish([5], calls))
    monkeypatch.setattr(wm, "robustness", lambda path, **k: _test(9))
    monkeypatch.setattr(wm, "sustained", lambda *a, **k: {"speed_m_s": 0.11})
    spent = tr.Budget(minutes=10.0, spent_s=9.9 * 60.0)
    for name in ("speed", "speed_restart1"):
        (tmp_path / name).mkdir()
        (tmp_path / name / "checkpoint.json").write_text("{}")
    state = _state(tmp_path, neat_robust=True, polish_walker=True)
    record = tr._speed("xl430_biped", tmp_path, tr.TrainSettings(), state, spent, lambda s: None)
    assert [(c["out"].name, c["resume"]) for c in calls] == [("speed", True), ("speed_restart1", True)]
    assert record["walker"] == str(tmp_path / "speed_restart1" / "walker.json")
    assert not any(r.get("skipped") for r in record["runs"])


def test_sigterm_and_sighup_end_a_training_as_ctrl_c_does():
    """The training's ``finally`` records the cut stage only if the signal becomes an exception."""
    import os
    import signal

    before = signal.getsignal(signal.SIGTERM)
    with pytest.raises(KeyboardInterrupt):
        with tr._termination_as_interrupt():
            os.kill(os.getpid(), signal.SIGTERM)  # os.kill runs the handler before it returns
            pytest.fail("SIGTERM did not interrupt")
    assert signal.getsignal(signal.SIGTERM) is before


def _state(tmp_path: Path, neat_robust: bool, polish_walker: bool) -> dict:
    neat = tmp_path / "neat.json"
    shutil.copyfile(WALKER, neat)
    polish = None
    if polish_walker:
        polish = tmp_path / "polish.json"
        shutil.copyfile(WALKER, polish)
    return {"stages": {"neat": {"walker": str(neat), "robust": neat_robust},
                       "polish": {"walker": polish and str(polish), "kept": None}}}


def test_the_speed_polish_starts_from_the_newest_robust_walker_no_slower_than_it_walks(tmp_path, monkeypatch,
                                                                                       budget):
    import evolve.polish

    calls = []
    monkeypatch.setattr(evolve.polish, "polish", fake_polish([5], calls))
    monkeypatch.setattr(wm, "robustness", lambda path, **k: _test(9))
    speeds = iter([0.11, 0.13])
    monkeypatch.setattr(wm, "sustained", lambda *a, **k: {"speed_m_s": next(speeds)})
    monkeypatch.setattr(ts, "faster_clock", lambda *a, **k: {"walker": None, "tests": []})  # no faster clock
    state = _state(tmp_path, neat_robust=True, polish_walker=True)
    record = tr._speed("xl430_biped", tmp_path, tr.TrainSettings(), state, budget, lambda s: None)
    assert calls[0]["source"] == tmp_path / "polish.json", "the polish's walker, not NEAT's"
    assert calls[0]["min_speed_m_s"] == 0.11 and calls[0]["worst"] == tr.SPEED["worst"]
    assert calls[0]["reality"] == ["randomize", "default"], "every other robot the transfer check's"
    assert calls[1]["source"] == tmp_path / "speed" / "walker.json", "the restart starts from what it kept"
    assert calls[1]["out"] == tmp_path / "speed_restart1"
    assert record["walker"] == str(tmp_path / "speed_restart1" / "walker.json")
    # a walker a little faster than the goal: the gate stays at the goal's speed
    speeds = iter([0.16, 0.155])
    calls.clear()
    shutil.rmtree(tmp_path / "speed"), shutil.rmtree(tmp_path / "speed_restart1")
    tr._speed("xl430_biped", tmp_path, tr.TrainSettings(), state, budget, lambda s: None)
    assert calls[0]["min_speed_m_s"] == tr.SPEED_GOAL_M_S
    # one faster than the goal by the margin on both walks: no speed polish, no minutes spent
    speeds = iter([0.3, tr.SPEED_GOAL_M_S * tr.SPEED_MARGIN])
    calls.clear()
    record = tr._speed("xl430_biped", tmp_path, tr.TrainSettings(), state, budget, lambda s: None)
    assert calls == [] and record["walker"] is None and record["skipped"] == "fast enough"
    # slow, but fast enough at a faster gait clock: that walker, and no polish
    speeds = iter([0.11, 0.13])
    fast = tmp_path / "cadence.json"
    shutil.copyfile(WALKER, fast)
    monkeypatch.setattr(ts, "faster_clock", lambda *a, **k: {"walker": str(fast), "speeds_m_s": [0.2, 0.17]})
    record = tr._speed("xl430_biped", tmp_path, tr.TrainSettings(), state, budget, lambda s: None)
    assert calls == [] and record["walker"] == str(fast)
    assert latest_walker({"stages": {**state["stages"], "speed": record}}) == str(fast)


def test_no_speed_polish_without_a_robust_walker(tmp_path, monkeypatch, budget):
    import evolve.polish

    monkeypatch.setattr(evolve.polish, "polish", lambda *a, **k: pytest.fail("sped up a walker that is not robust"))
    state = _state(tmp_path, neat_robust=False, polish_walker=False)
    assert tr._speed("xl430_biped", tmp_path, tr.TrainSettings(), state, budget, lambda s: None)["skipped"]


def test_the_shipped_walker_is_the_newest_robust_one_else_the_polish_kept_weights(tmp_path):
    state = _state(tmp_path, neat_robust=True, polish_walker=False)
    assert latest_walker(state) == state["stages"]["neat"]["walker"]
    state = _state(tmp_path, neat_robust=True, polish_walker=True)
    state["stages"]["speed"] = {"walker": "speed/walker.json"}
    assert latest_walker(state) == "speed/walker.json"
    assert latest_walker(state, skip_speed=True) == state["stages"]["polish"]["walker"]
    none = _state(tmp_path, neat_robust=False, polish_walker=False)
    none["stages"]["polish"]["kept"] = "polish/polished.json"
    assert latest_walker(none) == "polish/polished.json"


def _measured(falls: int, rate: float = 0.96) -> dict:
    walk = {"upright_s": 60.0 if not falls else 15.0, "distance_m": 9.0, "falls": falls, "speed_m_s": 0.17,
            "heading_deg_per_min": 4.0, "per_episode": []}
    return {"rate": {"share": rate, "walked": int(rate * 50), "robots": 50},
            "transfer": {"ratio": 0.9, "passed": True, "sim_walked": True, "runs": []},
            "sustained": {"nominal": walk, "default": {**walk, "falls": 0, "upright_s": 60.0}},
            "steering": {"reached": True}}


def test_a_speed_polish_that_falls_on_the_model_is_undone_and_the_walker_before_it_ships(tmp_path, monkeypatch,
                                                                                          budget):
    state = _state(tmp_path, neat_robust=True, polish_walker=True)
    shutil.copyfile(WALKER, tmp_path / "sped.json")
    state["stages"]["speed"] = {"walker": str(tmp_path / "sped.json")}
    state.update(command="biped train xl430_biped", settings={"seed": 1})
    measured = {str(tmp_path / "sped.json"): _measured(falls=1), str(tmp_path / "polish.json"): _measured(falls=0)}
    monkeypatch.setattr(wm, "measure_walker", lambda walker, log, **k: measured[str(walker)])
    record = tr._measure("xl430_biped", tmp_path, tr.TrainSettings(), state, budget, lambda s: None)
    assert record["walker"] == str(tmp_path / "polish.json") and state["stages"]["speed"]["undone"]
    assert all(record["bar"].values())
    from sim2real.controller.file import Controller

    provenance = Controller.load(tmp_path / "controller.json").provenance
    assert provenance["made_by"] == "biped train xl430_biped" and provenance["bar"] == record["bar"]


def test_a_walker_that_misses_the_bar_gives_way_to_the_newest_robust_one_before_it_that_meets_it(
        tmp_path, monkeypatch, budget):
    """The polish kept robust walkers at updates 5, 10 and 15; 15's misses the bar on transfer, 10's
    too, 5's meets it: 5's ships, and the provenance lists the three measured, newest first."""
    import json

    folder = tmp_path / "polish"
    folder.mkdir()
    data = json.loads(WALKER.read_text())
    for update in (5, 10, 15):  # each its own file, as each kept update's weights are
        data["provenance"]["update"] = update
        (folder / f"robust_update{update}.json").write_text(json.dumps(data))
    shutil.copyfile(folder / "robust_update15.json", folder / "walker.json")
    state = _state(tmp_path, neat_robust=False, polish_walker=False)
    state["stages"]["polish"] = {"walker": str(folder / "walker.json"), "kept": None,
                                 "tests": [{"update": u, "robust": True} for u in (5, 10, 15)]}
    state["stages"]["speed"] = {"walker": None, "runs": [], "skipped": "fast enough"}
    state.update(command="biped train xl430_biped", settings={"seed": 1})
    missed = _measured(falls=0)
    missed["transfer"] = {**missed["transfer"], "ratio": 0.74, "passed": False}
    verdicts = {"walker.json": missed, "robust_update10.json": missed, "robust_update5.json": _measured(falls=0)}
    measured = []
    monkeypatch.setattr(wm, "measure_walker", lambda walker, log, **k: (measured.append(Path(walker).name),
                                                                        verdicts[Path(walker).name])[1])
    record = tr._measure("xl430_biped", tmp_path, tr.TrainSettings(), state, budget, lambda s: None)
    # update 15's file is the walker itself: not measured twice
    assert measured == ["walker.json", "robust_update10.json", "robust_update5.json"]
    assert record["walker"] == str(folder / "robust_update5.json") and all(record["bar"].values())
    assert record["missed"] == {str(folder / n): ["transfer"] for n in ("walker.json", "robust_update10.json")}
    from sim2real.controller.file import Controller

    provenance = Controller.load(tmp_path / "controller.json").provenance
    assert list(provenance["walkers_measured"]) == [str(folder / n) for n in measured] and provenance["update"] == 5
    # with no budget left after the first measures, the walker ships as it is, its misses named
    measured.clear()
    spent = tr.Budget(minutes=60.0, spent_s=3600.0)
    record = tr._measure("xl430_biped", tmp_path, tr.TrainSettings(), state, spent, lambda s: None)
    assert measured == ["walker.json"] and record["bar"]["transfer"] is False


def test_the_bar_names_each_part_a_walker_misses():
    from evolve.walk_measures import meets_bar

    assert all(meets_bar(_measured(0)).values())
    assert meets_bar(_measured(0, rate=0.88)) == {"walk_rate": False, "straight": True, "speed": True,
                                                  "transfer": True}
    slow = _measured(0)
    slow["sustained"]["default"]["speed_m_s"] = 0.12
    assert not meets_bar(slow)["speed"]
    assert not meets_bar(_measured(1))["straight"]  # a fall in the 60 s walk


def test_the_benchmark_summary_gives_medians_of_end_to_end_minutes():
    from benchmarks.robust_walk import summary

    runs = [{"wall_minutes": w, "cpu_minutes": 2 * w, "met_bar": w < 60, "walk_rate": 0.9, "transfer": 0.85,
             "speed_m_s": {"nominal": 0.2, "default": 0.16}, "heading_deg_per_min": 5.0, "turn_reached": True}
            for w in (40.0, 55.0, 70.0)]
    s = summary(runs)
    assert s["wall_minutes_median"] == 55.0 and s["cpu_minutes_median"] == 110.0 and s["met_bar"] == 2
    assert s["speed_m_s_median"] == 0.16 and s["turn_reached"] == 3


def test_a_slow_walker_tries_a_faster_gait_clock_and_keeps_the_fastest_robust_one(tmp_path, monkeypatch):
    """Each faster clock is tested; the fastest (by the lower of its two 60 s speeds) that stays
    robust is kept, its period in the file the runtime reads; a resume measures nothing again."""
    from sim2real.controller.file import Controller

    period = Controller.load(WALKER).phase_period_s
    measured = []

    def speeds(walker, settings, robot):  # faster with the clock, down to x0.8; x0.7 falls apart
        factor = round(Controller.load(walker).phase_period_s / period, 3)
        measured.append(factor)
        return {0.9: [0.12, 0.10], 0.8: [0.14, 0.12], 0.7: [0.16, 0.13]}[factor]

    monkeypatch.setattr(ts, "speeds", speeds)
    monkeypatch.setattr(wm, "robustness", lambda path, **k: _test(
        9 if Controller.load(path).phase_period_s > 0.75 * period else 5))
    record = ts.faster_clock(WALKER, tmp_path / "cadence", tr.TrainSettings(), "xl430_biped", [0.10, 0.08],
                             lambda s: None)
    assert measured == [0.9, 0.8, 0.7] and [t["robust"] for t in record["tests"]] == [True, True, False]
    kept = Controller.load(record["walker"])
    assert kept.phase_period_s == pytest.approx(0.8 * period) and kept.task["phase_period_s"] == kept.phase_period_s
    assert kept.connections == Controller.load(WALKER).connections and record["speeds_m_s"] == [0.14, 0.12]
    again = ts.faster_clock(WALKER, tmp_path / "cadence", tr.TrainSettings(), "xl430_biped", [0.10, 0.08],
                            lambda s: None)
    assert measured == [0.9, 0.8, 0.7] and again["walker"] == record["walker"]
    # none faster than the walker itself: none kept
    none = ts.faster_clock(WALKER, tmp_path / "other", tr.TrainSettings(), "xl430_biped", [0.2, 0.2], lambda s: None)
    assert none["walker"] is None


def test_the_mildest_gait_clock_fast_enough_is_kept_and_no_faster_one_is_tried(tmp_path, monkeypatch):
    """OP3's seed 5: every clock robust on the bar's 10 robots, x0.9 already past the goal's
    margin; x0.7 walked on fewer of 50.  x0.9 is kept, x0.8 and x0.7 never measured."""
    from sim2real.controller.file import Controller

    period = Controller.load(WALKER).phase_period_s
    measured = []

    def speeds(walker, settings, robot):
        factor = round(Controller.load(walker).phase_period_s / period, 3)
        measured.append(factor)
        return {0.9: [0.229, 0.177], 0.8: [0.254, 0.211], 0.7: [0.281, 0.245]}[factor]

    monkeypatch.setattr(ts, "speeds", speeds)
    monkeypatch.setattr(wm, "robustness", lambda path, **k: _test(10))
    record = ts.faster_clock(WALKER, tmp_path / "cadence", tr.TrainSettings(), "xl430_biped", [0.179, 0.155],
                             lambda s: None)
    assert measured == [0.9] and Controller.load(record["walker"]).phase_period_s == pytest.approx(0.9 * period)
    assert ts.fast_enough(record["tests"][0]) and not ts.fast_enough({**record["tests"][0], "robust": False})
    assert not ts.fast_enough({"robust": True, "speeds_m_s": [0.3, ts.SPEED_GOAL_M_S]})  # the goal, no margin


def test_the_measure_stages_fallbacks_are_the_robust_walkers_newest_first(tmp_path):
    """The speed restart's robust walkers, the speed polish's, the faster gait clock they started
    from, the walk-rate polish's, NEAT's robust champion; a file that is gone is left out."""
    from evolve.train_record import earlier_walkers

    def stage(name: str, robust_updates: list[int], gone: tuple[int, ...] = ()) -> dict:
        (tmp_path / name).mkdir()
        for u in robust_updates:
            if u not in gone:
                (tmp_path / name / f"robust_update{u}.json").write_text("{}")
        return {"walker": str(tmp_path / name / "walker.json"),
                "tests": [{"update": u, "robust": True} for u in robust_updates] + [{"update": 99, "robust": False}]}

    cadence, neat = tmp_path / "period_x0.8.json", tmp_path / "neat.json"
    cadence.write_text("{}"), neat.write_text("{}")
    state = {"stages": {"neat": {"walker": str(neat), "robust": True}, "polish": stage("polish", [5, 10], gone=(5,)),
                        "speed": {"runs": [stage("speed", [5]), stage("speed_restart1", [5, 15])],
                                  "cadence": {"walker": str(cadence)}}}}
    assert [str(p.relative_to(tmp_path)) for p in earlier_walkers(state)] == [
        "speed_restart1/robust_update15.json", "speed_restart1/robust_update5.json", "speed/robust_update5.json",
        "period_x0.8.json", "polish/robust_update10.json", "neat.json"]

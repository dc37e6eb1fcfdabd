"""The robust-walk benchmark's summary: what its medians count."""

from benchmarks.robust_walk import summary


def _run(seed: int, robust: bool, ratio: float = 0.0, sim_walked: bool = True, passed: bool = False) -> dict:
    run = {"seed": seed, "robust": robust}
    if robust:
        run.update(minutes=float(seed), generations=100 * seed, rate={"share": 0.5 + seed / 100, "robots": 50},
                   transfer={"ratio": ratio, "sim_walked": sim_walked, "passed": passed},
                   sustained={"default": {"upright_s": 60.0, "distance_m": 5.0, "heading_deg_per_min": 10.0 * seed},
                              "nominal": {"speed_m_s": 0.1, "heading_deg_per_min": 25.0}})
    return run


def test_a_fall_on_the_model_keeps_nothing_of_its_walk():
    runs = [_run(1, True, 0.81, passed=True), _run(2, False), _run(3, True, 7.5, sim_walked=False),
            _run(4, True, 0.51)]
    s = summary(runs)
    assert (s["seeds"], s["robust_seeds"], s["transfer_passed"]) == (4, 3, 1)
    assert s["transfer_ratio_median"] == 0.51  # median of 0.81, 0 (the fall) and 0.51; the 7.5 would make it 0.81
    assert s["median_minutes"] == 3.0
    assert s["walk_rate_50_median"] == 0.53 and s["speed_m_s_median"] == 0.1
    assert s["heading_deg_per_min_median"] == 30.0  # the worse robot's: 25, 30 and 40 deg/min


def test_no_robust_walker_has_no_medians():
    s = summary([_run(1, False), _run(2, False)])
    assert s["robust_seeds"] == 0 and s["transfer_ratio_median"] is None and s["transfer_passed"] == 0



def test_the_polish_phase_tests_every_kept_walker_and_times_the_first_robust_one(tmp_path, monkeypatch):
    """The recipe's polish (``--polish``): NEAT's last champion polished, each walker the
    validation keeps tested; the seed's minutes are NEAT's budget plus the search up to the
    first robust one, the tests' own seconds aside.  The polish, the tests and the measures are
    stand-ins here (each is tested on its own): what is checked is the bookkeeping."""
    import shutil
    import time

    import evolve.polish
    from benchmarks import robust_walk

    def polish(source, out, *, on_best, **settings):  # keeps walkers at updates 5, 10 and 15
        history = []
        for update, elapsed_s in ((5, 60.0), (10, 120.0), (15, 180.0)):
            shutil.copyfile(source, out / "kept.json")
            history.append({"update": update, "elapsed_s": elapsed_s})
            on_best(out / "kept.json", history[-1])
        return {"history": history, "settings": settings}

    def robustness(walker, draws):  # the second kept walker and the third pass
        time.sleep(0.01)
        robust = len(tested) >= 1
        tested.append(walker)
        return {"randomized": {"walked": 10 if robust else 3}, "default": {"walked": 3}, "draws": draws,
                "default_episodes": 3}

    tested = []
    monkeypatch.setattr(evolve.polish, "polish", polish)
    monkeypatch.setattr(robust_walk, "robustness", robustness)
    monkeypatch.setattr(robust_walk, "after_test", lambda walker, log: {"rate": {"share": 0.9, "robots": 50}})
    shutil.copyfile("configs/controllers/xl430_biped.json", tmp_path / "champion.json")
    neat = {"seed": 2, "robust": False, "minutes": None, "generations": None, "champion_generation": 59,
            "evolution_minutes": 45.0, "generations_run": 61, "run_dir": str(tmp_path), "tests": []}
    r = robust_walk.polish_once(neat, tmp_path, updates=20, draws=10, need=8, quiet=True, speed_leg_s=0.8,
                                validation=100, walk_bonus=20.0)
    assert [(t["update"], t["robust"]) for t in r["polish"]["tests"]] == [(5, False), (10, True), (15, True)]
    assert r["robust"] and 46.99 < r["minutes"] < 47.0  # 45 + 2 minutes, less the first test's seconds
    assert r["generations"] == 61  # all NEAT's
    assert r["walker_test"]["update"] == 15 and (tmp_path / "polish" / "robust_walker.json").exists()
    assert r["rate"] == {"share": 0.9, "robots": 50} and r["neat"] is neat
    assert r["polish"]["settings"]["speed_leg_s"] == 0.8 and r["polish"]["settings"]["seed"] == 2
    assert (r["polish"]["settings"]["robots"], r["polish"]["settings"]["sigma"]) == (
        robust_walk.POLISH_ROBOTS, robust_walk.POLISH_SIGMA)
    assert (r["polish"]["settings"]["validation"], r["polish"]["settings"]["walk_bonus"]) == (100, 20.0)

    tested.clear()
    shutil.copyfile("configs/controllers/xl430_biped.json", tmp_path / "robust_walker.json")
    first = robust_walk.polish_once({**neat, "robust": True, "minutes": 30.0, "tests": [{"generation": 40}],
                                     "rate": "neat's", "transfer": {}, "sustained": {}, "steering": None},
                                    tmp_path, updates=20, draws=10, need=8, quiet=True, robots=32, sigma=0.05)
    assert (first["polish"]["settings"]["robots"], first["polish"]["settings"]["sigma"]) == (32, 0.05)
    assert first["minutes"] == 30.0, "NEAT's robust walker came first: its minutes count"
    assert first["walker"] == str(tmp_path / "polish" / "robust_walker.json") and first["rate"]["share"] == 0.9

    # no kept walker passes: NEAT's walker stays the seed's
    monkeypatch.setattr(robust_walk, "robustness", lambda walker, draws: {
        "randomized": {"walked": 3}, "default": {"walked": 3}, "draws": draws, "default_episodes": 3})
    stays = robust_walk.polish_once({**neat, "robust": True, "minutes": 30.0, "tests": [{"generation": 40}],
                                     "rate": "neat's", "transfer": {}, "sustained": {}, "steering": None},
                                    tmp_path, updates=20, draws=10, need=8, quiet=True)
    assert stays["walker"] == str(tmp_path / "robust_walker.json") and stays["rate"] == "neat's"
    assert stays["walker_test"] == {"generation": 40}


def test_a_cut_polish_stage_resumes_with_its_tests_and_tests_no_walker_twice(tmp_path, monkeypatch):
    """A polish stage cut mid-way (here after its update-10 test, before the polish's checkpoint
    of update 10) resumes: the polish from its checkpoint, the stage's tests from tests.json;
    the update done again keeps its test, and no walker is tested twice.  Stand-ins as above."""
    import shutil

    import evolve.polish
    from benchmarks import robust_walk

    def polish(source, out, *, on_best, resume, **settings):
        assert resume == (out / "checkpoint.json").exists()
        done = 5 if resume else 0  # the checkpoint: update 5
        (out / "checkpoint.json").write_text("{}")
        history = []
        for update in (5, 10, 15):
            if update <= done:
                continue
            shutil.copyfile(source, out / "kept.json")
            history.append({"update": update, "elapsed_s": 60.0 * update / 5})
            on_best(out / "kept.json", history[-1])
            if update == 10 and not resume:
                raise KeyboardInterrupt
        return {"history": history}

    tested = []

    def robustness(walker, draws):
        tested.append(walker)
        return {"randomized": {"walked": 10 if len(tested) >= 2 else 3}, "default": {"walked": 3}, "draws": draws,
                "default_episodes": 3}

    monkeypatch.setattr(evolve.polish, "polish", polish)
    monkeypatch.setattr(robust_walk, "robustness", robustness)
    source = tmp_path / "walker.json"
    shutil.copyfile("configs/controllers/xl430_biped.json", source)
    out = tmp_path / "polish"
    try:
        robust_walk.polish_stage(source, out, 2, 20, 10, 8, lambda line: None)
    except KeyboardInterrupt:
        pass
    assert len(tested) == 2 and (out / "robust_walker.json").exists()
    record, walker_test = robust_walk.polish_stage(source, out, 2, 20, 10, 8, lambda line: None)
    assert len(tested) == 3, "updates 5, 10 and 15 each tested once"
    assert [(t["update"], t["robust"]) for t in record["tests"]] == [(5, False), (10, True), (15, True)]
    assert walker_test["update"] == 15 and record["first_robust_s"] is not None
    assert robust_walk.read_json(out / "tests.json")["tests"] == record["tests"]


def test_the_speed_polish_starts_from_the_final_walker_no_slower_than_it_walks(tmp_path, monkeypatch):
    """The recipe's speed polish (``--speed-polish``): a robust seed's final walker (the
    polish's, else NEAT's) polished again, counting no walk slower than the lower of its 60 s
    walks' speeds; a robust walker it keeps becomes the seed's; a seed that is not robust is
    left as it is.  Stand-ins as above: the bookkeeping is checked.  (Not the minutes to
    robustness it reports: that figure's meaning - the first robust walker's, or the final
    one's - is the recipe's to state, not this test's to lock in.)"""
    import shutil

    import evolve.polish
    from benchmarks import robust_walk

    def polish(source, out, *, on_best, **settings):
        calls.append((source, settings))
        shutil.copyfile(source, out / "kept.json")
        entry = {"update": 5, "elapsed_s": 30.0}
        on_best(out / "kept.json", entry)
        return {"history": [entry], "settings": settings}

    calls = []
    robust_now = {"randomized": {"walked": 9}, "default": {"walked": 3}, "draws": 10, "default_episodes": 3}
    monkeypatch.setattr(evolve.polish, "polish", polish)
    monkeypatch.setattr(robust_walk, "robustness", lambda walker, draws: robust_now)
    monkeypatch.setattr(robust_walk, "after_test", lambda walker, log: {"rate": {"share": 0.96, "robots": 50}})
    (tmp_path / "polish").mkdir()
    shutil.copyfile("configs/controllers/xl430_biped.json", tmp_path / "polish" / "robust_walker.json")
    before = {"seed": 1, "robust": True, "minutes": 50.8, "walker": "elsewhere/robust_walker.json",
              "walker_test": {"update": 35}, "rate": {"share": 0.9}, "transfer": {"ratio": 0.9},
              "sustained": {"nominal": {"speed_m_s": 0.12}, "default": {"speed_m_s": 0.11}}, "steering": None}
    r = robust_walk.speed_polish_once(before, tmp_path, updates=20, draws=10, need=8, quiet=True)
    (source, settings), = calls
    assert source == tmp_path / "polish" / "robust_walker.json", "the polish's walker, not a stale path"
    assert settings["min_speed_m_s"] == 0.11 and settings["speed_leg_s"] == robust_walk.SPEED_POLISH_LEG_S
    assert (settings["robots"], settings["sigma"], settings["validation"], settings["worst"]) == (
        robust_walk.SPEED_POLISH_ROBOTS, robust_walk.SPEED_POLISH_SIGMA, robust_walk.SPEED_POLISH_VALIDATION,
        robust_walk.SPEED_POLISH_WORST)
    assert "nominal" not in settings
    assert r["walker"] == str(tmp_path / "speed_polish" / "robust_walker.json") and r["rate"]["share"] == 0.96
    assert r["speed_polish"]["before"]["rate"] == {"share": 0.9}

    # no walker from the polish: NEAT's robust walker is the one polished for speed
    (tmp_path / "polish" / "robust_walker.json").rename(tmp_path / "robust_walker.json")
    robust_walk.speed_polish_once(before, tmp_path, updates=20, draws=10, need=8, quiet=True)
    assert calls[-1][0] == tmp_path / "robust_walker.json"
    (tmp_path / "robust_walker.json").rename(tmp_path / "polish" / "robust_walker.json")

    # no robust walker kept: the polish's stays the seed's
    robust_now = {**robust_now, "randomized": {"walked": 7}}
    stays = robust_walk.speed_polish_once(before, tmp_path, updates=20, draws=10, need=8, quiet=True,
                                          min_speed_m_s=0.15, nominal=True, robots=16, sigma=0.1, validation=30,
                                          walk_bonus=20.0, worst=0.25)
    assert calls[-1][1]["min_speed_m_s"] == 0.15 and calls[-1][1]["nominal"] is True
    assert [calls[-1][1][k] for k in ("robots", "sigma", "validation", "walk_bonus", "worst")] == [16, 0.1, 30, 20.0, 0.25]
    assert stays["walker"] == before["walker"] and stays["rate"] == {"share": 0.9}
    assert not (tmp_path / "speed_polish" / "robust_walker.json").exists()
    assert robust_walk.speed_polish_once({"seed": 5, "robust": False}, tmp_path, 20, 10, 8, True)["speed_polish"] is None

    # a walker faster than the goal: the gate asks the goal's speed, not its own
    fast = {**before, "sustained": {"nominal": {"speed_m_s": 0.36}, "default": {"speed_m_s": 0.35}}}
    robust_walk.speed_polish_once(fast, tmp_path, updates=20, draws=10, need=8, quiet=True)
    assert calls[-1][1]["min_speed_m_s"] == robust_walk.SPEED_GOAL_M_S


def test_a_restart_polishes_the_walker_the_speed_polish_kept_and_comes_only_after_one(tmp_path, monkeypatch):
    """``--speed-polish-restarts``: restart k starts from the walker restart k-1 (or the first
    speed polish) kept, in its own folder, its record appended; none follows a speed polish
    that kept no robust walker, or one undone, or the last restart asked for."""
    import shutil

    import evolve.polish
    from benchmarks import robust_walk

    calls = []

    def polish(source, out, *, on_best, **settings):
        calls.append((source, out))
        shutil.copyfile(source, out / "kept.json")
        entry = {"update": 40, "elapsed_s": 30.0}
        on_best(out / "kept.json", entry)
        return {"controller": str(source), "history": [entry]}

    monkeypatch.setattr(evolve.polish, "polish", polish)
    monkeypatch.setattr(robust_walk, "robustness", lambda walker, draws: {
        "randomized": {"walked": 9}, "default": {"walked": 3}, "draws": 10, "default_episodes": 3})
    monkeypatch.setattr(robust_walk, "after_test", lambda walker, log: {"rate": {"share": 0.96, "robots": 50}})
    (tmp_path / "speed_polish").mkdir()
    shutil.copyfile("configs/controllers/xl430_biped.json", tmp_path / "speed_polish" / "robust_walker.json")
    first = {"first_robust_s": 100.0, "controller": "polish/robust_walker.json"}
    sped = {"seed": 3, "robust": True, "minutes": 55.6, "walker": str(tmp_path / "speed_polish" / "robust_walker.json"),
            "walker_test": {"update": 20}, "rate": {"share": 0.84}, "transfer": {"ratio": 1.0},
            "sustained": {"nominal": {"speed_m_s": 0.24}, "default": {"speed_m_s": 0.24}}, "steering": None,
            "speed_polish": first}
    assert robust_walk.next_speed_polish(sped, restarts=1) == 1
    assert robust_walk.next_speed_polish(sped, restarts=0) is None
    r = robust_walk.speed_polish_once(sped, tmp_path, updates=40, draws=10, need=8, quiet=True, restart=1)
    assert calls == [(tmp_path / "speed_polish" / "robust_walker.json", tmp_path / "speed_polish_restart1")]
    assert r["speed_polish"] is first and len(r["speed_polish_restarts"]) == 1
    assert r["speed_polish_restarts"][0]["before"]["rate"] == {"share": 0.84}
    assert r["walker"] == str(tmp_path / "speed_polish_restart1" / "robust_walker.json") and r["rate"]["share"] == 0.96
    assert robust_walk.last_speed_polish(r) is r["speed_polish_restarts"][0]
    assert robust_walk.next_speed_polish(r, restarts=1) is None, "the one restart asked for is done"
    assert robust_walk.next_speed_polish(r, restarts=2) == 2

    assert robust_walk.next_speed_polish({"seed": 3, "robust": True}, restarts=1) == 0, "the first comes first"
    assert robust_walk.next_speed_polish({**sped, "speed_polish": {**first, "first_robust_s": None}}, 1) is None
    assert robust_walk.next_speed_polish({**sped, "speed_polish": {**first, "rejected": "falls"}}, 1) is None
    assert robust_walk.next_speed_polish({"seed": 5, "robust": False, "speed_polish": None}, 1) is None


def test_a_budget_in_generations_ends_the_neat_phase_whatever_the_minutes(tmp_path, monkeypatch):
    """``--generations G``: a robot that costs twice the steps gets the same generations, not
    half; the evolution stops after G generations in all though minutes remain."""
    import yaml

    from benchmarks import robust_walk

    config = {"robot": "xl430_biped", "seed": 1, "generations": 50, "threads": 1, "checkpoint_every": 100,
              "task": {"episode_s": 0.5, "harness_generations": 0},
              "neat": {"population_size": 6, "target_species": 2, "compat_threshold": 0.5}}
    (tmp_path / "tiny.yaml").write_text(yaml.safe_dump(config))
    monkeypatch.setattr(robust_walk, "robustness", lambda walker, draws: {
        "randomized": {"walked": 0}, "default": {"walked": 0}, "draws": draws, "default_episodes": 3})
    r = robust_walk.robust_once(str(tmp_path / "tiny.yaml"), 1, tmp_path / "seed1", minutes=60.0, draws=10,
                                need=8, quiet=True, generations=3)
    assert r["generations_run"] == 3 and not r["robust"] and r["evolution_minutes"] < 60.0
    assert len(r["tests"]) >= 1, "the champions were tested on the way"


def test_a_speed_polish_that_loses_the_walk_on_the_model_is_undone():
    from benchmarks.robust_walk import keep_the_model_walk

    def walk(falls, upright_s=60.0):
        return {"nominal": {"falls": falls, "upright_s": upright_s}, "default": {"falls": 0, "upright_s": 60.0}}

    before = {"walker_test": {"update": 20}, "rate": {"walked": 35}, "transfer": {"ratio": 1.01},
              "sustained": walk(0), "steering": {"reached": True}}
    stage = {"controller": "seed1/polish/robust_walker.json", "before": before}
    sped = {"seed": 1, "robust": True, "walker": "seed1/speed_polish/robust_walker.json", "walker_test": {"update": 15},
            "rate": {"walked": 36}, "transfer": {"ratio": 0.9}, "sustained": walk(1, 8.1),
            "steering": {"reached": False}, "speed_polish": stage}
    undone = keep_the_model_walk(sped)
    assert undone["walker"] == "seed1/polish/robust_walker.json" and undone["rate"] == {"walked": 35}
    assert undone["sustained"] == before["sustained"] and undone["steering"] == {"reached": True}
    assert "8.1 s" in undone["speed_polish"]["rejected"] and undone["speed_polish"]["after"]["rate"] == {"walked": 36}
    assert keep_the_model_walk(undone) is undone, "applied twice, it changes nothing"
    # the walker before fell on the model too, or the new one does not: the speed polish stands
    fell_before = {**sped, "speed_polish": {**stage, "before": {**before, "sustained": walk(1, 3.2)}}}
    assert keep_the_model_walk(fell_before) is fell_before
    steady = {**sped, "sustained": walk(0)}
    assert keep_the_model_walk(steady) is steady
    # no walker kept by the speed polish, or no speed polish: nothing to undo
    unchanged = {**sped, "walker": stage["controller"]}
    assert keep_the_model_walk(unchanged) is unchanged
    assert keep_the_model_walk({"seed": 5, "robust": False, "speed_polish": None})["speed_polish"] is None


def test_the_benchmark_runs_the_restarts_a_seed_lacks_and_no_more(tmp_path, monkeypatch):
    """A seed folder whose speed polish kept a walker gets its restart from ``--out``, once; a
    rerun finds it done; ``--speed-polish-restarts 0`` asks for none."""
    from benchmarks import robust_walk
    from sim2real.atomic_json import read_json, write_json_atomic

    calls = []

    def speed_polish_once(result, folder, *args, restart=0, **settings):
        calls.append(restart)
        record = {"controller": "before.json", "first_robust_s": 5.0}
        return {**result, **robust_walk.with_last_speed_polish(result, record, restart)}

    monkeypatch.setattr(robust_walk, "speed_polish_once", speed_polish_once)
    walk = {"falls": 0, "upright_s": 60.0, "distance_m": 9.0, "speed_m_s": 0.15, "heading_deg_per_min": 3.0}
    seed = {"seed": 1, "robust": True, "minutes": 50.0, "generations": 60, "polish": {}, "rate": {"share": 0.96},
            "transfer": {"ratio": 0.9, "passed": True, "sim_walked": True}, "steering": {"reached": True},
            "sustained": {"nominal": walk, "default": walk},
            "speed_polish": {"controller": "polish/robust_walker.json", "first_robust_s": 9.0}}
    write_json_atomic(tmp_path / "seed1" / "result.json", seed)
    argv = ["--seeds", "1", "--out", str(tmp_path), "--polish", "40", "--speed-polish", "40", "--json"]
    robust_walk.main(argv)
    assert calls == [1] and len(read_json(tmp_path / "seed1" / "result.json")["speed_polish_restarts"]) == 1
    robust_walk.main(argv)
    assert calls == [1], "done before"
    write_json_atomic(tmp_path / "seed1" / "result.json", seed)
    robust_walk.main([*argv, "--speed-polish-restarts", "0"])
    assert calls == [1]


def test_a_restart_that_loses_the_walk_on_the_model_is_undone_alone():
    from benchmarks.robust_walk import keep_the_model_walk

    def walk(falls, upright_s=60.0):
        return {"nominal": {"falls": falls, "upright_s": upright_s}, "default": {"falls": 0, "upright_s": 60.0}}

    first = {"controller": "seed1/polish/robust_walker.json", "first_robust_s": 9.0}
    before = {"walker_test": {"update": 40}, "rate": {"walked": 47}, "transfer": {"ratio": 0.95},
              "sustained": walk(0), "steering": {"reached": True}}
    restart = {"controller": "seed1/speed_polish/robust_walker.json", "before": before}
    sped = {"seed": 1, "robust": True, "walker": "seed1/speed_polish_restart1/robust_walker.json",
            "walker_test": {"update": 5}, "rate": {"walked": 49}, "transfer": {"ratio": 0.9},
            "sustained": walk(1, 12.0), "steering": {"reached": True}, "speed_polish": first,
            "speed_polish_restarts": [restart]}
    undone = keep_the_model_walk(sped)
    assert undone["walker"] == "seed1/speed_polish/robust_walker.json" and undone["rate"] == {"walked": 47}
    assert undone["speed_polish"] is first, "the first speed polish stands"
    assert "12.0 s" in undone["speed_polish_restarts"][0]["rejected"]
    assert keep_the_model_walk(undone) is undone


def test_the_walker_shipped_walks_on_the_model_then_on_the_most_robots():
    from benchmarks.robust_walk import ship_rank

    def seed(falls, share, ratio):
        return {"sustained": {"nominal": {"falls": falls}}, "rate": {"share": share},
                "transfer": {"ratio": ratio, "sim_walked": True}}

    fast_but_falls, steady, most_robots = seed(1, 0.94, 1.10), seed(0, 0.88, 0.93), seed(0, 1.0, 0.91)
    assert max([fast_but_falls, steady, most_robots], key=ship_rank) is most_robots
    assert max([fast_but_falls, steady], key=ship_rank) is steady

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

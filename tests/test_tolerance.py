"""benchmarks.tolerance: each perturbation alone, and the largest size a walker stays up at."""

import json

import pytest
from conftest import ROOT

from benchmarks import tolerance
from sim2real.simulation.reality.file import load_reality

WALKER = ROOT / "configs" / "controllers" / "xl430_biped_no_gyro.json"


@pytest.mark.parametrize("kind", tolerance.KINDS)
def test_each_kind_is_a_valid_reality_of_that_perturbation_alone(kind):
    reality = load_reality(tolerance.perturbation(kind, 0.01))
    assert reality.perturbed == [kind]
    lo, hi = reality.range(kind)
    if kind == "joint_noise_deg":
        assert lo == hi == pytest.approx(0.01 * tolerance.NOISE_DEG_AT_1)
    else:
        assert (lo, hi) == pytest.approx((0.99, 1.01))


def test_an_episode_ended_early_without_a_fall_is_not_upright():
    # the stagnation stop ends an episode without a fall: it did not stay up the whole episode
    episode = lambda upright_s, fell: {"upright_s": upright_s, "fell": fell}  # noqa: E731
    walk = {"seconds": 10.01, "per_episode": [episode(10.01, False), episode(4.2, False), episode(3.0, True),
                                               episode(10.01, False)]}
    assert tolerance.upright_share(walk) == 0.5


def test_tolerates_is_the_largest_size_kept_upright(capsys):
    # the randomization-hardened walker stays up at 1e-3; at 0.9 (masses and gains off by up
    # to 90 %) it cannot stay up in every episode of every kind
    tolerance.main([str(WALKER), "--sizes", "1e-3", "0.9", "--episodes", "2", "--seconds", "2", "--json"])
    result = json.loads(capsys.readouterr().out.strip().splitlines()[-1])
    (walker,) = result["controllers"]
    assert walker["nominal_upright"]
    assert set(walker["tolerates"]) == set(tolerance.KINDS)
    for kind, rows in walker["by_kind"].items():
        assert [r["size"] for r in rows] == [1e-3, 0.9]
        held = walker["tolerates"][kind]
        assert held == (0.0 if rows[0]["upright"] < 1 else 1e-3 if rows[1]["upright"] < 1 else 0.9)
    assert min(walker["tolerates"].values()) < 0.9


@pytest.mark.parametrize("args, problem", [
    (["--sizes", "0.1", "0.01"], "ascending"),
    (["--sizes", "1.5"], "in (0, 1)"),
    (["--episodes", "0"], "at least 1"),
])
def test_bad_arguments_are_refused(args, problem, capsys):
    with pytest.raises(SystemExit) as exit_:
        tolerance.main([str(WALKER), *args])
    assert exit_.value.code != 0
    assert problem in capsys.readouterr().err


def test_a_missing_controller_is_named(capsys):
    with pytest.raises(SystemExit):
        tolerance.main(["no/such/walker.json"])
    assert "no/such/walker.json: no such controller file" in capsys.readouterr().err

"""Reality profiles and domain randomization: files, draws, and their use per simulation."""

import numpy as np
import pytest

from evolve.locomotion.evaluator import LocomotionEvaluator, neat_layout
from evolve.locomotion.task import TaskConfig
from evolve.neat import Genome, NeatConfig, Population
from sim2real.controller.symmetry import symmetric_layout
from sim2real.errors import ConfigError
from sim2real.robot import load_robot
from sim2real.simulation.model.parts import CLOSED_PLAY_RAD
from sim2real.simulation.reality.file import NOMINAL, PERTURBATIONS, load_reality, parse_reality
from sim2real.simulation.reality.randomize import needs_backlash_joints, sample

ROBOT = load_robot()
TASK = TaskConfig(episode_s=1.0)


def test_shipped_files_load_and_default_is_a_fixed_profile():
    default, ranges = load_reality("default"), load_reality("randomize")
    assert all(lo == hi for lo, hi in default.ranges.values())
    assert any(lo < hi for lo, hi in ranges.ranges.values())
    assert set(ranges.ranges) == set(PERTURBATIONS) - {"latency_ms"}  # randomized as latency_ticks
    assert load_reality("nominal").is_nominal and not default.is_nominal


def test_narrow_is_randomize_milder_and_centres_on_a_fit():
    """narrow.yaml: randomize.yaml's keys, each range within randomize.yaml's, around a fit."""
    narrow, wide = load_reality("narrow"), load_reality("randomize")
    assert set(narrow.ranges) == set(wide.ranges)
    for key, (lo, hi) in narrow.ranges.items():
        w_lo, w_hi = wide.range(key)
        assert w_lo <= lo <= hi <= w_hi, key
    assert any(narrow.range(k) != wide.range(k) for k in narrow.ranges)
    fitted = load_reality({**narrow.to_dict(), "centre": {"kp_scale": 0.8, "latency_ms": 10.0}})
    assert fitted.range("kp_scale") == pytest.approx((0.72, 0.88))
    assert fitted.range("latency_ms") == (10.0, 10.0) and fitted.range("latency_ticks") == narrow.range("latency_ticks")


@pytest.mark.parametrize("doc, key, problem", [
    ({"mass_scal": 1.0}, "mass_scal", "unknown key"),
    ({"kp_scale": [1.2, 0.8]}, "kp_scale", "low must be below high"),
    ({"kp_scale": 0}, "kp_scale", "scale must be > 0"),
    ({"backlash_deg": -1}, "backlash_deg", "must not be negative"),
    ({"foot_flip": 2}, "foot_flip", "probability"),
    ({"latency_ticks": "one"}, "latency_ticks", "number"),
])
def test_bad_reality_files_name_key_and_problem(doc, key, problem):
    with pytest.raises(ConfigError) as err:
        parse_reality(doc, "r.yaml")
    assert err.value.key == key and problem in str(err.value) and "r.yaml" in str(err.value)


def test_unknown_profile_lists_the_known_ones():
    with pytest.raises(FileNotFoundError, match="default"):
        load_reality("no-such-profile")


@pytest.fixture(scope="module")
def evaluator():
    return LocomotionEvaluator(ROBOT, TASK, 6, threads=1, reality=load_reality("randomize"))


def test_draws_depend_on_the_key_only(evaluator):
    keys = np.array([[1, 0, 3, i] for i in range(4)])
    together = evaluator.sample(keys)
    alone = evaluator.sample(keys[2:3])
    assert np.array_equal(together.kp_scale[2], alone.kp_scale[0])
    assert np.array_equal(together.joint_noise_rad[2], alone.joint_noise_rad[0])
    assert not np.array_equal(together.kp_scale[0], together.kp_scale[1])
    lo, hi = load_reality("randomize").range("kp_scale")
    assert (together.kp_scale >= lo).all() and (together.kp_scale <= hi).all()
    # a ramp's weaker randomization: the same streams, every range pulled toward nominal
    half = evaluator.sample(keys, intensity=0.5)
    assert np.allclose(half.kp_scale - 1.0, (together.kp_scale - 1.0) / 2)
    assert np.allclose(half.backlash_rad, together.backlash_rad / 2)
    assert np.array_equal(evaluator.sample(keys, intensity=1.0).kp_scale, together.kp_scale)
    drift = np.degrees(together.heading_drift_rad_s)  # either way, per episode
    assert drift.shape == (4,) and (np.abs(drift) <= 0.2).all() and len(set(np.sign(drift))) == 2


def test_only_realities_that_draw_backlash_get_backlash_joints():
    for doc, geared in ((None, False), ({"kp_scale": 0.9}, False), ({"backlash_deg": 0.0}, False),
                        ({"backlash_deg": [0.0, 0.6]}, True), ("default", True)):
        reality = load_reality(doc)
        assert needs_backlash_joints(reality) == geared
        ev = LocomotionEvaluator(ROBOT, TASK, 1, threads=1, reality=reality)
        assert ev.angles.has_play == geared
    plain = LocomotionEvaluator(ROBOT, TASK, 1, threads=1)
    drawn = sample(load_reality("default"), np.zeros((1, 1)), plain.model, 0, plain.tick_s)
    with pytest.raises(ValueError, match="without backlash joints"):
        plain.evaluate([Genome(0, plain.neat_layout)], 1.0, perturbation=drawn)


def test_scaled_reality_goes_from_nominal_to_itself():
    full = load_reality("randomize")
    assert full.scaled(0.0).is_nominal and full.scaled(1.0) is full
    assert full.scaled(0.5).range("kp_scale") == pytest.approx((0.9, 1.1))
    assert full.scaled(0.5).range("backlash_deg") == pytest.approx((0.0, 0.3))


def test_each_simulation_gets_its_own_model_and_nominal_comes_back(evaluator):
    layout = neat_layout(symmetric_layout(ROBOT, ROBOT.control_sets["walk"]))
    genomes = Population(NeatConfig(population_size=3, target_species=1), layout, seed=1).genomes
    p = evaluator.sample(np.array([[7, i] for i in range(3)]))
    evaluator.evaluate(genomes, 1.0, perturbation=p)
    nominal = evaluator.model
    floor = nominal.geom("floor").id
    for i in range(3):
        m = evaluator.batch.get_model(i)
        assert m.body_mass[1:] == pytest.approx(nominal.body_mass[1:] * p.mass_scale[i, 1:])
        assert m.actuator_gainprm[:, 0] == pytest.approx(nominal.actuator_gainprm[:, 0] * p.kp_scale[i])
        assert m.geom_friction[floor, 0] == pytest.approx(nominal.geom_friction[floor, 0] * p.floor_friction_scale[i])
        assert m.actuator_delay == pytest.approx(np.full(nominal.nu, p.latency_s[i]))
        kv = -m.actuator_biasprm[:, 2]  # the D term: kp Td inside the torque limit
        assert kv == pytest.approx(m.actuator_gainprm[:, 0] * p.derivative_s[i]) and p.derivative_s[i] > 0
        dofs = evaluator.angles.servo_dof
        assert m.dof_armature[dofs] == pytest.approx(nominal.dof_armature[dofs] * p.armature_scale[i])
        play = m.jnt_range[evaluator.angles.play_joint]  # each joint's gear play, as drawn
        assert play[:, 1] - play[:, 0] == pytest.approx(np.maximum(p.backlash_rad[i], CLOSED_PLAY_RAD))
    assert evaluator.batch.get_model(0).body_mass[1] != evaluator.batch.get_model(1).body_mass[1]
    evaluator.evaluate(genomes, 1.0)  # back to the nominal robot
    for i in range(3):
        m = evaluator.batch.get_model(i)
        assert m.body_mass == pytest.approx(nominal.body_mass)
        assert m.actuator_delay == pytest.approx(0.0)
        assert m.jnt_range == pytest.approx(nominal.jnt_range)  # the gears closed again
        assert m.actuator_biasprm == pytest.approx(nominal.actuator_biasprm)
        assert m.dof_armature == pytest.approx(nominal.dof_armature)


def test_randomized_results_do_not_depend_on_batching(evaluator):
    layout = neat_layout(symmetric_layout(ROBOT, ROBOT.control_sets["walk"]))
    genomes = Population(NeatConfig(population_size=4, target_species=1), layout, seed=2).genomes
    keys = np.array([[3, 0, 0, i, 0] for i in range(4)])
    together = evaluator.evaluate(genomes, 1.0, perturbation=evaluator.sample(keys))
    single = LocomotionEvaluator(ROBOT, TASK, 1, threads=1, reality=load_reality("randomize"))
    for i in (0, 3):
        alone = single.evaluate([genomes[i]], 1.0, perturbation=single.sample(keys[i:i + 1]))
        assert alone.fitness[0] == together.fitness[i] and alone.distance_m[0] == together.distance_m[i]
    nominal = LocomotionEvaluator(ROBOT, TASK, 4, threads=1).evaluate(genomes, 1.0)
    assert not np.array_equal(nominal.fitness, together.fitness)


def test_a_nominal_reality_changes_nothing():
    layout = neat_layout(symmetric_layout(ROBOT, ROBOT.control_sets["walk"]))
    genomes = Population(NeatConfig(population_size=3, target_species=1), layout, seed=4).genomes
    plain = LocomotionEvaluator(ROBOT, TASK, 3, threads=1)
    a = plain.evaluate(genomes, 1.0)
    b = plain.evaluate(genomes, 1.0, perturbation=plain.sample(np.zeros((3, 1))))
    assert np.array_equal(a.fitness, b.fitness) and NOMINAL.is_nominal


def test_evolve_config_randomize_block_is_validated():
    from evolve.config import parse_evolve_config

    config = parse_evolve_config({"randomize": {"reality": "randomize", "episodes": 3, "score": "worst"}}, "e.yaml")
    assert config.randomize.episodes == 3 and config.to_dict()["randomize"]["score"] == "worst"
    assert "randomize" not in parse_evolve_config({}, "e.yaml").to_dict()
    ramped = parse_evolve_config({"randomize": {"reality": "randomize", "ramp_generations": 40}}, "e.yaml")
    assert [ramped.randomize.intensity(g) for g in (0, 10, 40, 90)] == [0.0, 0.25, 1.0, 1.0]
    assert parse_evolve_config(ramped.to_dict(), "e.yaml") == ramped
    assert config.randomize.intensity(0) == 1.0  # no ramp: full strength from the start
    capped = parse_evolve_config({"randomize": {"reality": "randomize", "ramp_generations": 40, "strength": 0.5}},
                                 "e.yaml")
    assert [capped.randomize.intensity(g) for g in (0, 10, 20, 40, 90)] == [0.0, 0.25, 0.5, 0.5, 0.5]
    assert parse_evolve_config(capped.to_dict(), "e.yaml") == capped
    for block, key in (({"reality": "nope"}, "randomize.reality"), ({"episodes": 0}, "randomize.episodes"),
                       ({"strength": 0}, "randomize.strength"), ({"strength": 1.5}, "randomize.strength"),
                       ({"score": "median"}, "randomize.score"), ({"reality": {"kp_scale": -1}}, "kp_scale"),
                       ({"ramp_generations": -5}, "randomize.ramp_generations")):
        with pytest.raises(ConfigError) as err:
            parse_evolve_config({"randomize": block}, "e.yaml")
        assert err.value.key == key


def test_eval_reports_the_spread_over_randomized_episodes(tmp_path, capsys):
    import json

    from evolve.cli import main
    from evolve.locomotion.export import controller_from_genome
    from evolve.neat import Genome

    layout = symmetric_layout(ROBOT, ROBOT.control_sets["walk"])
    path = tmp_path / "stand.json"
    controller_from_genome(Genome(0, neat_layout(layout)), ROBOT, layout, TaskConfig(episode_s=1.0), 1.0,
                           {"seed": 0}).save(path)
    assert main(["eval", str(path), "--randomize", "--episodes", "3", "--json"]) == 0
    report = json.loads(capsys.readouterr().out)
    assert report["episodes"] == 3 and report["reality"] == "randomize"
    assert report["min_distance_m"] <= report["distance_m"] <= report["max_distance_m"]
    assert report["min_distance_m"] < report["max_distance_m"]  # three different robots
    assert set(report) >= {"falls", "walked_share", "upright_s"}
    assert main(["eval", str(path), "--randomize", "--reality", "default"]) == 2
    assert "not both" in capsys.readouterr().err

    # --ablate: the whole profile, then each of its perturbations alone on the same seeds
    profile = {"kp_scale": 0.5, "joint_noise_deg": 0.2}
    (tmp_path / "soft.yaml").write_text(json.dumps(profile))
    assert main(["eval", str(path), "--reality", str(tmp_path / "soft.yaml"), "--ablate", "--episodes", "1",
                 "--json"]) == 0
    ablation = json.loads(capsys.readouterr().out)
    assert list(ablation["only"]) == ["kp_scale", "joint_noise_deg"]
    assert ablation["only"]["kp_scale"]["value"] == 0.5
    # the network has no connections, so only the softer servos move the robot differently
    assert ablation["only"]["kp_scale"]["distance_m"] == ablation["all"]["distance_m"] != ablation["nominal"]["distance_m"]
    assert ablation["only"]["joint_noise_deg"]["distance_m"] == ablation["nominal"]["distance_m"]
    assert main(["eval", str(path), "--ablate"]) == 2
    assert "reality to take apart" in capsys.readouterr().err

    # --by-perturbation: the episodes sorted by what each drew
    assert main(["eval", str(path), "--randomize", "--episodes", "6", "--by-perturbation", "--json"]) == 0
    table = json.loads(capsys.readouterr().out)["by_perturbation"]
    assert {"kp_scale", "torque_scale", "latency_ms"} <= set(table)
    assert all(len(row["walked_by_third"]) == 3 and row["third_edges"][0] <= row["third_edges"][1]
               for row in table.values())
    assert main(["eval", str(path), "--by-perturbation"]) == 2
    assert "--randomize" in capsys.readouterr().err


def test_only_keeps_one_perturbation():
    default = load_reality("default")
    soft = default.only("kp_scale")
    assert soft.perturbed == ["kp_scale"] and soft.range("kp_scale") == default.range("kp_scale")
    assert soft.range("mass_scale") == (1.0, 1.0)
    assert NOMINAL.perturbed == [] and "latency_ticks" in default.perturbed


def test_a_slicker_floor_is_felt_by_the_soles():
    """A contact takes the larger friction of its two geoms: the draw scales every geom's, so
    that 0.6 under soles of 1.0 is 0.6 (it was 1.0: the floor's alone was scaled)."""
    import mujoco

    from sim2real.simulation.reality.randomize import perturbed_model

    for scale in (0.6, 1.0, 1.2):
        model, _ = perturbed_model(ROBOT, load_reality({"floor_friction_scale": scale}))
        data = mujoco.MjData(model)
        mujoco.mj_resetDataKeyframe(model, data, model.key("home").id)
        for _ in range(20):
            mujoco.mj_step(model, data)
        assert data.ncon and all(abs(c.friction[0] - scale) < 1e-12 for c in data.contact[:data.ncon])

"""Replaying a controller file in MuJoCo: measure it, watch it, film it.

The replay is the evaluation itself (:class:`LocomotionEvaluator` with one simulation and
no harness), so what you see is what evolution scored.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path
from typing import Any, Callable

import numpy as np

from evolve.locomotion.evaluator import LocomotionEvaluator
from evolve.locomotion.export import genome_from_controller
from evolve.locomotion.gait_tracking import GaitTracker
from evolve.locomotion.objectives import OBJECTIVES
from evolve.stages import parse_stages
from evolve.locomotion.task import TaskConfig
from sim2real.controller import channels
from sim2real.controller.activation import check_disabled_modules
from sim2real.controller.channels import turn_rad
from sim2real.controller.file import Controller
from sim2real.errors import ConfigError, UsageError
from sim2real.robot.names import ROBOT_FLAG
from sim2real.figures.gait import Gait
from sim2real.figures.reach import Reach as ReachPlot
from sim2real.simulation.model.builder import SimulationUnstable
from sim2real.simulation.model.physique import measured
from sim2real.simulation.reality.file import NOMINAL, Reality, load_reality


def controller_task(data: Controller, source: str) -> TaskConfig:
    """The task a controller file was evolved for, reading the file's own inputs whatever its
    task block says (the file is what the runtime runs)."""
    task = TaskConfig.from_mapping(dict(data.task), source, "task.")
    return dataclasses.replace(task, **channels.every_key(data.input_channels))


def controller_setup(path: Path | str, robot: str | None, seconds: float | None, episodes: int = 1,
                     keep_going: bool = False, reality: Reality = NOMINAL, disabled_modules: tuple[str, ...] = (),
                     stagnation_stop: bool = True, threads: int = 1, robot_flag: str | None = ROBOT_FLAG):
    """A controller file and its robot, an evaluator of ``episodes`` simulations on its task
    (the file's inputs whatever its task block says; ``seconds`` long, default the task's) and
    the genome it expresses: (controller, robot, evaluator, genome).  ``threads``: simulation
    threads (0: every core); results do not depend on them.  ``robot_flag``: how the command
    takes a robot file (None: it does not), for the error on a robot the file names that is
    not the project's (:meth:`Controller.load_for_robot`)."""
    data, spec = Controller.load_for_robot(path, robot, robot_flag=robot_flag)
    spec = measured(spec)
    check_disabled_modules(data, disabled_modules)
    task = controller_task(data, str(path))
    changes = {"episode_s": float(seconds)} if seconds is not None else {}
    if keep_going:
        changes.update(fall_height=1e-6, fall_tilt_deg=180.0)
    if keep_going or not stagnation_stop:  # selection's stopping rules off too: only a fall ends an episode
        changes.update(stagnation_s=1e9, flight_stop_share=0.0)
    task = dataclasses.replace(task, **changes)
    evaluator = LocomotionEvaluator(spec, task, max(1, episodes), threads=threads, reality=reality)
    if evaluator.n_ticks < 1:
        what = f"--seconds {seconds:g}" if seconds is not None else f"{path}: task.episode_s {task.episode_s:g}"
        raise UsageError(f"{what}: shorter than one control tick ({evaluator.tick_s:g} s)")
    if evaluator.layout != data.layout(spec):
        raise ConfigError(str(path), "joints.driven", f"the inputs/outputs do not match robot {spec.name}'s "
                          f"{task.control_set!r} control set (the task's, default 'walk')")
    genome = genome_from_controller(data)
    return data, spec, evaluator, genome


class TurnTracker:
    """``on_tick`` hook: how far each simulation's torso has turned about world up since the
    start (counter-clockwise positive, unwrapped) [rad], and the largest turn either way."""

    def __init__(self, n: int):
        self.last: np.ndarray | None = None
        self.turn, self.max_turn = np.zeros(n), np.zeros(n)

    def __call__(self, evaluator: LocomotionEvaluator, alive: np.ndarray) -> None:
        yaw = evaluator.heading(np.arange(len(self.turn)), 0, None)  # the true yaw: no drift
        if self.last is not None:
            step = turn_rad(yaw, self.last)
            self.turn[alive] += step[alive]
            self.max_turn[alive] = np.maximum(self.max_turn[alive], np.abs(self.turn[alive]))
        self.last = yaw


def evaluate_controller(path: Path | str, robot: str | None = None, seconds: float | None = None,
                        episodes: int = 1, disabled_modules: tuple[str, ...] = (),
                        randomize: str | Reality | None = None, seed: int = 0,
                        stagnation_stop: bool = True, by_perturbation: bool = False,
                        heading: Callable[[float], float] | None = None, threads: int = 1,
                        gait_measures: bool = False) -> dict[str, Any]:
    """Measure a controller on ``episodes`` episodes, each drawn from ``randomize`` (a reality
    file's ranges or fixed profile; None: the nominal robot) with seed ``seed``; without
    ``stagnation_stop`` only a fall (or the clock) ends an episode.  ``by_perturbation`` adds
    where it fails: the walk rate by third of each drawn perturbation (:func:`walk_rate_by_draw`).
    ``heading``: steer a controller with a heading input - the heading to hold [rad, from the
    start's] at a time [s] (:mod:`sim2real.controller.steering`); each episode then reports how
    far its torso ends from the heading it was told to hold (``heading_error_deg``).
    ``threads``: simulation threads (0: every core); the numbers do not depend on them.
    ``gait_measures`` adds ``gait``: each episode's gait after its start-up and how many walk
    a walk (:class:`GaitTracker`), or why a robot's gait cannot be measured (``unmeasured``)."""
    reality = load_reality(randomize)
    data, spec, evaluator, genome = controller_setup(path, robot, seconds, episodes, reality=reality,
                                           disabled_modules=disabled_modules, stagnation_stop=stagnation_stop,
                                           threads=threads)
    keys = np.array([[seed, e] for e in range(episodes)])
    perturbation = None if reality.is_nominal else evaluator.sample(keys)
    turn = TurnTracker(episodes)
    turns = None
    if heading is not None:
        if not data.heading_input:
            raise UsageError(f"{path}: a heading to hold was given, but the controller has no heading input")
        told = np.array([heading(t * evaluator.tick_s) for t in range(evaluator.n_ticks)])
        turns = np.broadcast_to(told, (episodes, evaluator.n_ticks)).copy()
    reaching = "reach" in data.input_channels  # scored as it was evolved: seed 002's reaching
    on_tick, gaits = turn, None
    if gait_measures:
        try:
            gaits = GaitTracker(spec, episodes, evaluator.tick_s)
        except ValueError as exc:  # a robot without a hip pitch joint on each side
            gaits = {"unmeasured": str(exc)}
        else:
            on_tick = lambda ev, alive: (turn(ev, alive), gaits(ev, alive))  # noqa: E731
    result = evaluator.evaluate([genome] * episodes, data.sigmoid_steepness, harness=0.0,
                                disabled_modules=disabled_modules, perturbation=perturbation, on_tick=on_tick,
                                turns=turns, objective=_objective(data))
    _refuse_unstable(result.unstable, reality)
    reach = {}
    if reaching:  # goals reached, the hand's mean distance to its goal while up [arm lengths]
        reach = {"reaches": float(np.mean(result.terms["reaches"])), "min_reaches": int(result.terms["reaches"].min()),
                 "hand_error": float(np.mean(result.terms["reaching"])),
                 "other_arm_deg": float(np.mean(result.terms["other_arm"])),
                 "reach_target_m": [round(float(v), 4) for v in evaluator.objective.control.target]}
    leg = spec.leg_length
    walked = result.walked(leg, evaluator.episode_s)
    return {
        "distance_m": float(np.mean(result.distance_m)),
        "min_distance_m": float(np.min(result.distance_m)),
        "max_distance_m": float(np.max(result.distance_m)),
        "upright_s": float(np.mean(result.upright_s)),
        "fell": bool(result.fell.any()),
        "falls": int(result.fell.sum()),
        "walked_share": float(walked.mean()),
        "walked": int(walked.sum()),
        "per_episode": [{"distance_m": float(d), "upright_s": float(u), "fell": bool(f), "turn_deg": float(t),
                         "max_turn_deg": float(m),
                         **({} if turns is None else {"heading_error_deg": float(np.degrees(turn_rad(
                             np.radians(t), turns[0, max(0, int(round(u / evaluator.tick_s)) - 1)])))})}
                        for d, u, f, t, m in zip(result.distance_m, result.upright_s, result.fell,
                                                 np.degrees(turn.turn), np.degrees(turn.max_turn))],
        "fitness": float(np.mean(result.fitness)),
        "leg_length_m": leg,
        "episodes": episodes,
        "reality": reality.name,
        "disabled_modules": list(disabled_modules),
        "seconds": evaluator.episode_s,
        **reach,
        **({} if gaits is None else {"gait": gaits if isinstance(gaits, dict) else gaits.report()}),
        **({"by_perturbation": walk_rate_by_draw(perturbation, walked)}
           if by_perturbation and perturbation is not None else {}),
    }


def _refuse_unstable(unstable: np.ndarray, reality: Reality) -> None:
    """A measure with an episode that went numerically unstable is no result (evolution scores
    such an episode eps; a report must not pass it off as a distance or a fall)."""
    if unstable.any():
        which = ", ".join(map(str, np.flatnonzero(unstable)[:5])) + (", ..." if unstable.sum() > 5 else "")
        raise SimulationUnstable(f"{int(unstable.sum())} of {len(unstable)} episodes went numerically unstable "
                                 f"(episode {which}): their distance and falls are no result (check the robot's "
                                 f"values and the reality {reality.name}'s)")


# what one episode drew, as one number: the mean over links or servos (the weakest servo's torque)
DRAWN = {"mass_scale": lambda p: p.mass_scale.mean(1), "com_offset_m": lambda p: np.linalg.norm(p.com_offset, axis=2).mean(1),
         "floor_friction_scale": lambda p: p.floor_friction_scale, "kp_scale": lambda p: p.kp_scale.mean(1),
         "torque_scale": lambda p: p.torque_scale.min(1), "damping_scale": lambda p: p.damping_scale.mean(1),
         "friction_scale": lambda p: p.friction_scale.mean(1), "armature_scale": lambda p: p.armature_scale.mean(1),
         "derivative_ms": lambda p: p.derivative_s * 1e3, "backlash_deg": lambda p: np.degrees(p.backlash_rad).mean(1),
         "latency_ms": lambda p: p.latency_s * 1e3, "joint_noise_deg": lambda p: np.degrees(p.joint_noise_sd_rad),
         "up_noise": lambda p: p.up_noise_sd, "foot_flip": lambda p: p.foot_flip_p,
         "heading_drift_deg_s": lambda p: np.degrees(np.abs(p.heading_drift_rad_s))}


def walk_rate_by_draw(p, walked: np.ndarray) -> dict[str, dict[str, Any]]:
    """For each perturbation that varies across the episodes: the share of episodes walked in
    the lowest, middle and highest third of its drawn values, and the correlation of the value
    with walking - which perturbations a controller fails on."""
    out = {}
    w = walked.astype(float)
    for key, value in DRAWN.items():
        v = np.asarray(value(p), dtype=float)
        if np.ptp(v) == 0 or len(v) < 3:
            continue
        order = np.argsort(v, kind="stable")
        thirds = np.array_split(order, 3)
        correlation = float(np.corrcoef(v, w)[0, 1]) if np.ptp(w) > 0 else 0.0
        out[key] = {"walked_by_third": [float(w[t].mean()) for t in thirds],
                    "third_edges": [float(v[thirds[1][0]]), float(v[thirds[2][0]])], "correlation": correlation}
    return out


def ablate_controller(path: Path | str, reality: str | Reality, episodes: int = 3, seed: int = 0,
                      **options: Any) -> dict[str, Any]:
    """Which perturbation breaks a controller: it is measured on the nominal robot, on
    ``reality`` as a whole, then with each of the reality's perturbations alone (the others
    nominal), every row on the same episode seeds (``seed``).  ``options`` go to
    :func:`evaluate_controller` (robot, seconds, disabled_modules)."""
    reality = load_reality(reality)
    if reality.is_nominal:
        raise ValueError("ablation needs a reality profile or ranges that differ from nominal")
    keep = ("distance_m", "min_distance_m", "falls", "walked_share")

    def measure(r: Reality | None) -> dict[str, Any]:
        report = evaluate_controller(path, episodes=episodes, randomize=r, seed=seed, **options)
        return {k: report[k] for k in keep}

    return {
        "reality": reality.name, "episodes": episodes, "seed": seed,
        "nominal": measure(None), "all": measure(reality),
        "only": {key: {"value": reality.to_dict()[key], **measure(reality.only(key))} for key in reality.perturbed},
    }


def gait(path: Path | str, robot: str | None = None, seconds: float | None = None,
         reality: str | Reality | None = None, seed: int = 0, disabled_modules: tuple[str, ...] = ()) -> Gait:
    """One episode's joint angles and foot contacts, tick by tick, until the episode ends or
    the robot falls (no stagnation stop), on the nominal robot or one of ``reality``."""
    reality = load_reality(reality)
    data, spec, evaluator, genome = controller_setup(path, robot, seconds, reality=reality, disabled_modules=disabled_modules,
                                           stagnation_stop=False)
    perturbation = None if reality.is_nominal else evaluator.sample(np.array([[seed, 0]]))
    times, angles, feet = [], [], []

    def record(ev: LocomotionEvaluator, alive: np.ndarray) -> None:
        times.append(len(times) * ev.tick_s)
        angles.append(ev.joint_angles(np.array([0]))[0])
        feet.append(ev.parts.feet_touching(ev.sensordata[0]))

    result = evaluator.evaluate([genome], data.sigmoid_steepness, harness=0.0, on_tick=record,
                                disabled_modules=disabled_modules, perturbation=perturbation)
    _refuse_unstable(result.unstable, reality)
    fell = float(result.upright_s[0]) if result.fell[0] else None
    where = "" if reality.is_nominal else f", {reality.name}"
    title = (f"{Path(path).name} on {spec.name}{where}: {result.distance_m[0]:.2f} m in {times[-1]:.1f} s"
             + (f", fell at {fell:.1f} s" if fell is not None else ""))
    return Gait(spec, np.array(times), spec.joint_names, np.array(angles), np.array(feet), fell, title)


class ReachMarks:
    """A reaching replay's marks for its frames: the target and the hand's path so far, in the
    world (the state machine's target is in the root's frame, which moves with the robot)."""

    PATH_TICKS = 90  # the path drawn: this many ticks back (3 s at OP3's tick)

    def __init__(self) -> None:
        self.path: list[np.ndarray] = []

    def draw(self, ev: LocomotionEvaluator, d, scene) -> None:
        from sim2real.simulation.rendering import draw_reach

        control = ev.reach
        if control is None:
            return
        rotation = d.xmat[ev.root].reshape(3, 3)
        target = d.xpos[ev.root] + rotation @ control.goals(np.array([0]))[0]
        self.path = (self.path + [d.xipos[ev.arm.hand].copy()])[-self.PATH_TICKS:]
        draw_reach(scene, target, control.cycle.tolerance * control.arm_length, np.array(self.path))


def _objective(data: Controller):
    """The objective a controller is replayed with: seed 002's reaching for a reaching one
    (its state machine runs; the weights of the reach stage it was evolved in, as its
    provenance records the run's config, else table 4.1's), else the evaluator's default,
    walking."""
    if "reach" not in data.input_channels:
        return None
    kind = OBJECTIVES["reach"]
    weights = kind.weights
    config = data.to_dict()["provenance"].get("config")
    stages = config.get("stages") if isinstance(config, dict) else None
    recorded = [s for s in stages if isinstance(s, dict) and s.get("objective") == "reach"] \
        if isinstance(stages, list) else []
    if recorded:
        try:
            (stage,) = parse_stages([recorded[-1]], "the controller's provenance")
            weights = stage.weights
        except ConfigError:  # a provenance is free-form: what it cannot say, table 4.1 does
            pass
    return lambda ev, n: kind.make(ev, n, weights, {})


def reach(path: Path | str, seconds: float | None = None, disabled_modules: tuple[str, ...] = ()) -> ReachPlot:
    """One episode of a reaching controller on the nominal robot, tick by tick, as a trace of a
    run records it: the state machine's state the networks read and the hand's distance to
    the goal it had (from the joint angles they read), until the end or a fall."""
    data, spec, evaluator, genome = controller_setup(path, None, seconds, disabled_modules=disabled_modules,
                                                     stagnation_stop=False, robot_flag=None)
    if "reach" not in data.input_channels:
        raise UsageError(f"{path}: not a reaching controller (no reach_input)")
    times, error, state = [], [], []

    def record(ev: LocomotionEvaluator, alive: np.ndarray) -> None:  # as a trace records them (Policy)
        times.append(len(times) * ev.tick_s)
        error.append(float(ev.reach.error[0]))
        state.append(float(ev.reach.cycle.state[0]))

    result = evaluator.evaluate([genome], data.sigmoid_steepness, harness=0.0, on_tick=record,
                                disabled_modules=disabled_modules, objective=_objective(data))
    _refuse_unstable(result.unstable, NOMINAL)
    fell = f", fell at {result.upright_s[0]:.1f} s" if result.fell[0] else ""
    off = f" without {', '.join(disabled_modules)}" if disabled_modules else ""
    return ReachPlot(np.array(times), np.array(error), np.array(state), data.input_channels["reach"]["reach_tolerance"],
                     f"{Path(path).name} on {spec.name}{off}{fell}")


def frames(path: Path | str, width: int = 640, height: int = 480, robot: str | None = None,
           seconds: float | None = None, every: int = 1,
           disabled_modules: tuple[str, ...] = ()) -> tuple[list[np.ndarray], float]:
    """Rendered frames of a replay from the tracking camera, and the time between frames [s]."""
    import mujoco

    from sim2real.simulation.rendering import (
        open_renderer,  # sets up offscreen GL before mujoco renders
    )

    # the film goes on after a fall or a stall (the score would have stopped there)
    data, spec, evaluator, genome = controller_setup(path, robot, seconds, keep_going=True, disabled_modules=disabled_modules,
                                                     robot_flag=None)  # `biped render CONTROLLER` takes no --robot
    images: list[np.ndarray] = []
    count = [0]
    marks = ReachMarks()
    with open_renderer(evaluator.model, width, height) as renderer:
        def grab(ev: LocomotionEvaluator, alive: np.ndarray) -> None:
            if count[0] % every == 0:
                d = ev.batch.get_data(0)
                mujoco.mj_forward(ev.model, d)
                renderer.update_scene(d, camera="track")
                marks.draw(ev, d, renderer.scene)
                images.append(renderer.render().copy())
            count[0] += 1

        evaluator.evaluate([genome], data.sigmoid_steepness, harness=0.0, on_tick=grab,
                           disabled_modules=disabled_modules, objective=_objective(data))
    return images, evaluator.tick_s * every


def strip(paths: list[Path | str], columns: int = 6, seconds: float | None = None, width: int = 320,
          height: int = 400) -> tuple[list[list[np.ndarray]], np.ndarray, list[str]]:
    """Seed 000's figure 1: each controller's replay filmed from its right side at ``columns``
    moments evenly over ``seconds`` (default: the shortest episode), every row from the same
    distance - that of the tallest robot - so that sizes compare.  Returns the frames by row
    and column, the moments [s] and a label per row."""
    import mujoco

    from sim2real.simulation.rendering import open_renderer

    setups = [controller_setup(p, None, seconds, keep_going=True, robot_flag=None) for p in paths]
    tallest = max(spec.height for _, spec, _, _ in setups)
    length = min(ev.episode_s for _, _, ev, _ in setups)
    tick_s = setups[0][2].tick_s  # the moments in the first controller's ticks
    ticks = np.unique(np.round(np.linspace(0, length / tick_s - 1, columns)).astype(int))
    rows, labels = [], []
    for path, (data, spec, evaluator, genome) in zip(paths, setups):
        wanted = set(np.round(ticks * tick_s / evaluator.tick_s).astype(int).tolist())
        camera = mujoco.MjvCamera()
        camera.type = mujoco.mjtCamera.mjCAMERA_FREE
        camera.azimuth, camera.elevation, camera.distance = 90.0, -8.0, 2.2 * tallest
        images, count = [], [0]
        marks = ReachMarks()
        with open_renderer(evaluator.model, width, height) as renderer:
            def grab(ev: LocomotionEvaluator, alive: np.ndarray) -> None:
                d = ev.batch.get_data(0)
                if count[0] in wanted:
                    mujoco.mj_forward(ev.model, d)
                    camera.lookat[:] = (d.subtree_com[ev.root][0], d.subtree_com[ev.root][1], 0.5 * tallest)
                    renderer.update_scene(d, camera=camera)
                    marks.draw(ev, d, renderer.scene)
                    images.append(renderer.render().copy())
                elif ev.reach is not None:  # the hand's path between the frames too
                    mujoco.mj_kinematics(ev.model, d)
                    marks.path = (marks.path + [d.xipos[ev.arm.hand].copy()])[-marks.PATH_TICKS:]
                count[0] += 1

            evaluator.evaluate([genome], data.sigmoid_steepness, harness=0.0, on_tick=grab,
                               objective=_objective(data))
        rows.append(images)
        preset = spec.anthropometry.get("preset") if spec.anthropometry else None
        labels.append(f"{Path(path).stem}\n{spec.name}" + (f":{preset}" if preset else "")
                      + f", {spec.height:.2f} m")
    return rows, ticks * tick_s, labels

"""Weight polish: an evolved walker's topology frozen, its weights tuned by CMA-ES on many
randomized robots (issue 33, after NEAT).

NEAT finds a topology and weights that walk on the robots it met; a walker that walks on half
of the robots a little off the model may need its weights nudged together, which mutation one
weight at a time rarely does.  Here the enabled connections' weights are one vector, and
CMA-ES (the ``cmaes`` package: Hansen's covariance matrix adaptation) moves it: every update
asks ``popsize`` candidates, runs each on the *same* ``robots`` robots drawn afresh for that
update (common random numbers: candidates differ by their weights, not their luck), and ranks
them by their mean selection score (the controller's task: eq. 3 plus any selection terms and
walk bonus).  Every ``every`` updates the search's mean is judged on ``validation`` fixed
robots that no update meets; the best of those (walk rate, then mean score) is kept.  At the
end the kept weights and the original walker are judged on ``test`` (100) fresh robots: the
polish is worth keeping only if it lifts the walk rate (``lifted``).

    result = polish(Path("walker.json"), out=Path("runs/polish"), updates=60)
    result["test"]["polished"]["walk_rate"], result["test"]["original"]["walk_rate"]

Each draw comes from a key of its own (``[seed, stream, update, robot]``): a seed fixes the
polish.  The evaluator is the evolution's (``mujoco.batch``), so the numbers are evolution's.

A polish takes an hour or more, so after every update ``out/checkpoint.json`` records what the
search was told (each update's candidate scores) and what it kept; ``resume=True`` continues a
cut polish from there.  The CMA-ES state is not stored: a seeded CMA-ES asked and told the same
scores again is the same search, so a resumed polish goes on exactly as the uncut one would
(each update's candidates are checked against a digest of the cut run's).
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import time
from pathlib import Path
from typing import Any, Callable, NamedTuple

import numpy as np

from evolve.locomotion.export import controller_from_genome
from evolve.neat import Genome, NeatConfig
from evolve.replay import controller_setup
from sim2real.atomic_json import read_json, write_json_atomic
from sim2real.controller.file import Controller
from sim2real.controller.purpose import require_walker
from sim2real.run_lock import holds_folder
from sim2real.errors import ConfigError
from sim2real.input_files import file_sha256
from sim2real.simulation.reality.file import Reality, load_reality
from sim2real.simulation.reality.randomize import Perturbation, latency_capacity_s, sample

WEIGHT_LIMIT = NeatConfig().weight_limit  # [the weights' unit] as evolution clips them
UPDATE_STREAM, VALIDATION_STREAM, TEST_STREAM = 0x504F_4C31, 0x504F_4C32, 0x504F_4C33  # keys' second entry
CHECKPOINT = "checkpoint.json"  # in a polish's folder: what resume=True continues from
CHECKPOINT_VERSION = 1
# the dock per unit of transfer shortfall, in the source walker's validation score: a candidate keeping 0.74
# where 0.85 is asked loses a third of that score, so one as much as 30 % slower that keeps enough ranks above it
TRANSFER_WEIGHT = 3.0
# how a transfer polish docks (a checkpoint of another rule is not resumed with this one)
TRANSFER_DOCK = "source-scale"


class Judged(NamedTuple):
    """Candidates' episodes (candidates, robots [+ the model]): selection scores, walked flags
    (the heading and speed gates applied), walked flags of any heading and speed, distances [m]."""
    score: np.ndarray
    walked: np.ndarray
    walked_any: np.ndarray
    distance_m: np.ndarray


def weights_of(genome: Genome) -> tuple[list[int], np.ndarray]:
    """The enabled connections' innovations, and their weights as one vector."""
    enabled = [k for k, gene in genome.conns.items() if gene.enabled]
    return enabled, np.array([genome.conns[k].weight for k in enabled])


def with_weights(genome: Genome, enabled: list[int], weights: np.ndarray, key: int = 0) -> Genome:
    """A copy of ``genome`` whose enabled connections carry ``weights`` (clipped as evolution clips them)."""
    out = genome.copy(key)
    for k, w in zip(enabled, np.clip(weights, -WEIGHT_LIMIT, WEIGHT_LIMIT)):
        out.conns[k].weight = float(w)
    return out


class Judge:
    """Runs weight vectors on drawn robots with the controller's evaluator: episodes of
    ``episode_s`` (None: the controller's task's), selection as the task's with ``selection``
    (TaskConfig fields, e.g. ``selection_straight_coeff``) changed, and with ``heading_deg`` a
    walk counts only if the torso never turned further than that from the start's heading,
    with ``min_speed_m_s`` only if it went at least that fast on average [m/s] (distance over
    the whole episode, its start-up included).
    With several ``realities`` robot k of a draw comes from ranges k mod their number: wide
    ranges buy a walk rate, narrow ones a walk near the model, and one search may want both."""

    def __init__(self, path: Path, realities: list[str], capacity: int, episode_s: float | None = None,
                 selection: dict[str, float] | None = None, heading_deg: float | None = None,
                 nominal: bool = False, min_speed_m_s: float | None = None, threads: int = 1,
                 robot: str | None = None):
        self.realities = [load_reality(name) for name in realities]

        def setup(reality: Reality):
            return controller_setup(path, robot, episode_s, episodes=capacity, reality=reality, threads=threads,
                                    robot_flag=None)
        self.data, self.robot, self.evaluator, self.genome = setup(self.realities[0])
        # the model keeps as much actuator history as the longest latency of any ranges needs
        widest = max(self.realities, key=lambda r: latency_capacity_s(r, self.evaluator.tick_s))
        if widest is not self.realities[0]:
            self.data, self.robot, self.evaluator, self.genome = setup(widest)
        if selection:
            self.evaluator.task = dataclasses.replace(self.evaluator.task, **selection)
        self.heading_deg, self.nominal, self.min_speed_m_s = heading_deg, nominal, min_speed_m_s
        self.enabled, self.start = weights_of(self.genome)
        self.steps = 0

    def run(self, candidates: list[np.ndarray], keys: np.ndarray) -> Judged:
        """Each candidate on every robot of ``keys`` (r, k), and on the nominal robot too with
        ``nominal`` (its last column): (candidates, r [+ 1]) arrays; simulations in batches of
        the evaluator's capacity."""
        r = len(keys)
        genomes = [with_weights(self.genome, self.enabled, x, i) for i, x in enumerate(candidates) for _ in range(r)]
        judged = [a.reshape(len(candidates), r) for a in self._episodes(genomes, np.tile(keys, (len(candidates), 1)))]
        if self.nominal:  # the model itself, which randomized draws seldom resemble
            on_model = [with_weights(self.genome, self.enabled, x, i) for i, x in enumerate(candidates)]
            judged = [np.hstack([a, b[:, None]]) for a, b in zip(judged, self._episodes(on_model, None))]
        return Judged(*judged)

    def draw(self, keys: np.ndarray) -> Perturbation:
        """One robot per row of ``keys``, from the ranges its robot index (last entry) picks."""
        ev = self.evaluator
        which = keys[:, -1] % len(self.realities)
        parts, rows = [], []
        for i, reality in enumerate(self.realities):
            mine = np.flatnonzero(which == i)
            if len(mine):
                parts.append(sample(reality, keys[mine], ev.model, ev.n_ticks, ev.tick_s))
                rows.append(mine)
        return Perturbation.stack(parts).rows(np.argsort(np.concatenate(rows)))

    def _episodes(self, genomes: list[Genome], keys: np.ndarray | None) -> Judged:
        """:class:`Judged` episodes of ``genomes``, each on its row of ``keys`` (None: the nominal robot)."""
        ev = self.evaluator
        score, walked, distance = np.empty(len(genomes)), np.empty(len(genomes), dtype=bool), np.empty(len(genomes))
        walked_any = np.empty(len(genomes), dtype=bool)
        for lo in range(0, len(genomes), ev.max_population):
            hi = min(lo + ev.max_population, len(genomes))
            episodes = ev.evaluate(genomes[lo:hi], self.data.sigmoid_steepness,
                                   perturbation=None if keys is None else self.draw(keys[lo:hi]))
            score[lo:hi], distance[lo:hi] = episodes.selection, episodes.distance_m
            walked_any[lo:hi] = walked[lo:hi] = episodes.walked(ev.leg, ev.episode_s)
            if self.heading_deg is not None:  # a walker that turns away is no walker
                walked[lo:hi] &= episodes.terms["turn"] <= self.heading_deg
            if self.min_speed_m_s is not None:  # the goal's speed: a slow walk is no walk either
                walked[lo:hi] &= episodes.distance_m >= self.min_speed_m_s * ev.episode_s
            self.steps += episodes.steps
        return Judged(score, walked, walked_any, distance)


def _keys(seed: int, stream: int, index: int, robots: int) -> np.ndarray:
    return np.array([[seed, stream, index, k] for k in range(robots)], dtype=np.int64)


def ranked_by(score: np.ndarray, worst: float) -> np.ndarray:
    """Each candidate's (row's) mean score on its worst ``worst`` share of the robots (at least one)."""
    if worst >= 1.0:  # the plain mean, summed as before the share existed
        return score.mean(axis=1)
    k = max(1, int(np.ceil(worst * score.shape[1] - 1e-9)))
    return np.sort(score, axis=1)[:, :k].mean(axis=1)


def docked_for_transfer(ranked: np.ndarray, judged: Judged, columns: list[int], keep: float,
                        scale: float) -> np.ndarray:
    """``ranked`` (a score per candidate) docked for keeping less than ``keep`` of the candidate's
    distance on the model (``judged``'s last column) on its robots ``columns`` (the transfer
    check's profile): by ``TRANSFER_WEIGHT`` x ``scale`` x the shortfall, so a candidate that keeps
    enough is not docked at all.  ``scale`` is one number for the whole search (the source
    walker's validation score): a dock in proportion to each candidate's own score would, past a
    shortfall of 1/``TRANSFER_WEIGHT``, exceed it and rank a higher score lower, and a search
    went to walkers that fall at once that way (OP3's seed 1, benchmarks/RESULTS.md).  A
    candidate that does not walk on the model keeps nothing (as in the transfer check): else a
    share would pay walking worse on the model, and a search found that (OP3, benchmarks/RESULTS.md)."""
    on_model = judged.distance_m[:, -1]
    share = judged.distance_m[:, columns].mean(axis=1) / np.maximum(on_model, 1e-9)
    share = np.where(judged.walked[:, -1], share, 0.0)
    shortfall = np.clip(keep - share, 0.0, None)
    return ranked - TRANSFER_WEIGHT * abs(scale) * shortfall


def plateaued(history: list[dict[str, Any]], kept_update: int, patience: int) -> bool:
    """Whether the last ``patience`` validations of ``history`` came after the kept update and
    kept nothing (the search's mean judged no better since)."""
    since = [entry for entry in history if entry["update"] > kept_update]
    return len(since) >= patience


def _digest(candidates: list[np.ndarray]) -> str:
    """A short fingerprint of one update's candidates (a replayed search must ask the same)."""
    return hashlib.sha256(np.stack(candidates).tobytes()).hexdigest()[:16]


def _resumed(checkpoint: Path, identity: dict[str, Any], updates: int) -> dict[str, Any]:
    """The cut polish's record in ``checkpoint``, checked against this polish's ``identity``
    (its source walker's digest and every setting that shapes the search but ``updates``)."""
    saved = read_json(checkpoint)
    if not isinstance(saved, dict) or saved.get("version") != CHECKPOINT_VERSION:
        raise ConfigError(checkpoint, "version", f"not a version-{CHECKPOINT_VERSION} polish checkpoint")
    for key, value in identity.items():
        if saved["identity"].get(key) != value:
            raise ConfigError(checkpoint, f"identity.{key}", f"the cut polish had {saved['identity'].get(key)!r}, "
                              f"this one {value!r}: resume it with its own walker and settings, or polish into "
                              "another folder")
    if len(saved["scores"]) > updates:
        raise ConfigError(checkpoint, "scores", f"the cut polish is at update {len(saved['scores'])}, beyond "
                          f"the {updates} updates asked")
    return saved


@holds_folder("out", what="biped polish")  # two polishes into one folder: the second refused
def polish(path: Path, out: Path, *, updates: int = 60, popsize: int = 16, robots: int = 8, sigma: float = 0.1,
           every: int = 5, validation: int = 30, test: int = 100, seed: int = 0, reality: str | list[str] = "randomize",
           episode_s: float | None = None, straight: float | None = None, heading_deg: float | None = None,
           speed_leg_s: float | None = None, min_speed_m_s: float | None = None, walk_bonus: float | None = None,
           nominal: bool = False, lr_adapt: bool = False, worst: float = 1.0, transfer_keep: float | None = None,
           on_best: Callable[[Path, dict[str, Any]], bool] | None = None, resume: bool = False,
           patience: int | Callable[[], int | None] | None = None, threads: int = 1,
           should_stop: Callable[[], bool] | None = None, robot: str | None = None,
           log: Callable[[str], None] = print) -> dict[str, Any]:
    """Polish the walker in ``path``; writes ``out/polished.json`` (the kept weights) and
    ``out/result.json`` (every judgement), returns the latter.  ``sigma``: CMA-ES's first
    step size [weight units] (NEAT perturbs a weight by about 0.5).  For a straight walk:
    ``episode_s`` longer episodes, ``straight`` selection's straight term weighted so
    (``selection_straight_coeff``), ``heading_deg`` walks that turn further not counted.
    For a faster walk: ``speed_leg_s`` the velocity kernel's target [leg lengths/s]
    (``selection_speed_leg_s``), ``min_speed_m_s`` slower walks not counted.  For a higher
    walk rate: ``walk_bonus`` what selection pays an episode that walks (``selection_walk_bonus``;
    a fast walker's speed can outweigh the task's bonus for a fall or two).
    ``nominal``: every candidate meets the nominal robot too, in each update (not in the
    validation and test, which judge drawn robots).  ``reality``: the ranges robots are drawn
    from, or a list of them that robots take turns at (validation and test draw the same way).
    ``lr_adapt``: CMA-ES with learning-rate adaptation (Nomura, Akimoto & Ono, GECCO 2023: the
    mean's and covariance's learning rates follow the update's signal-to-noise ratio, for noisy
    objectives at the default population size; a walk rate on 16 robots is one).
    ``worst``: candidates ranked by their mean score on the worst this share of the update's
    robots (a conditional value at risk, as EPOpt's robust policy search (Rajeswaran et al.,
    ICLR 2017) trains on its worst episodes): the robots a walker fails on weigh on every
    ranking instead of a few in the mean; 1 ranks by the mean over all.
    ``on_best(path, entry)``: called whenever validation keeps new weights, with them written
    to ``path`` (``out/kept.json``) and the history ``entry`` (its ``elapsed_s``: the
    polish's seconds so far); True stops the search there (the test still follows).
    ``resume``: continue from ``out/checkpoint.json`` (the same walker and settings; ``updates``
    may grow); without it a folder holding a checkpoint is refused, so no polish is lost.
    ``patience``: stop once this many validations in a row kept nothing (a plateau; None:
    run every update; a function: asked at each validation, so a caller's rule can change).
    ``threads``: simulation threads (0: every core); the search does not depend on them.
    ``should_stop()``: asked after every update (a time budget); True ends the search there.
    ``test`` 0: no final test (the caller measures the walker itself).  ``robot``: the walker's
    robot, a name or a file (None: the one the controller names)."""
    from cmaes import CMA  # the `sim` extra's: only the polish needs it

    data, _ = Controller.load_for_robot(path, robot, robot_flag=None)  # refused before the folder is made
    require_walker(data, str(path), "biped polish", "it tunes the weights for the share of randomized robots that walk")
    checkpoint = out / CHECKPOINT
    if checkpoint.exists() and not resume:
        raise FileExistsError(f"{out} holds a polish ({checkpoint}); resume it, or polish into another folder")
    out.mkdir(parents=True, exist_ok=True)
    started = time.monotonic()
    realities = [reality] if isinstance(reality, str) else list(reality)
    if transfer_keep is not None and (not nominal or "default" not in realities):
        raise ValueError("transfer_keep asks the model's distance and default.yaml robots: give nominal=True and "
                         f"'default' among the realities (got {realities})")
    # the draws' default.yaml robots: robot k comes from realities[k % their number]
    on_default = lambda n: [k for k in range(n) if realities[k % len(realities)] == "default"]  # noqa: E731
    selection = {key: value for key, value in (("selection_straight_coeff", straight),
                                               ("selection_speed_leg_s", speed_leg_s),
                                               ("selection_walk_bonus", walk_bonus)) if value is not None}
    judge = Judge(path, realities, max(popsize * robots, validation, 1), episode_s, selection, heading_deg,
                  nominal, min_speed_m_s, threads, robot)
    x0 = judge.start
    optimizer = CMA(mean=x0.copy(), sigma=sigma, population_size=popsize, seed=seed, lr_adapt=lr_adapt,
                    bounds=np.tile([-WEIGHT_LIMIT, WEIGHT_LIMIT], (len(x0), 1)))
    checks = _keys(seed, VALIDATION_STREAM, 0, validation)
    settings = {"updates": updates, "popsize": popsize, "robots": robots, "sigma": sigma, "seed": seed,
                "reality": reality, "episode_s": judge.evaluator.episode_s, "straight": straight,
                "heading_deg": heading_deg, "nominal": nominal, "speed_leg_s": speed_leg_s,
                "min_speed_m_s": min_speed_m_s, "walk_bonus": walk_bonus, "lr_adapt": lr_adapt,
                "worst": worst, **({"transfer_keep": transfer_keep, "transfer_dock": TRANSFER_DOCK}
                                   if transfer_keep is not None else {})}
    identity = json.loads(json.dumps({**{k: v for k, v in settings.items() if k != "updates"}, "every": every,
                                      "validation": validation,
                                      "source_sha256": file_sha256(path)}))

    def save(weights: np.ndarray, to: Path, outcome: dict[str, Any]) -> None:
        """The walker with ``weights``, the polish's settings and ``outcome`` in its provenance."""
        provenance = {**dict(judge.data.provenance), "polished_from": str(path), "polish": {**settings, **outcome}}
        controller_from_genome(with_weights(judge.genome, judge.enabled, weights), judge.robot,
                               judge.evaluator.layout, judge.evaluator.task, judge.data.sigmoid_steepness,
                               provenance).save(to)

    dock_scale: float | None = None  # a transfer polish's: the source walker's undocked validation score

    def validate(x: np.ndarray) -> dict[str, float]:
        judged = judge.run([x], checks)
        score, walked = judged.score, judged.walked
        if nominal:  # (judged on drawn robots only)
            score, walked = score[:, :-1], walked[:, :-1]
        mean = score.mean(axis=1)
        undocked = float(mean[0])
        if transfer_keep is not None:  # the source walker's own validation docks on its own score
            mean = docked_for_transfer(mean, judged, on_default(validation), transfer_keep,
                                       undocked if dock_scale is None else dock_scale)
        return {"walk_rate": float(walked.mean()), "score": float(mean[0]), "undocked": undocked}

    def better(checked: dict[str, float], than: dict[str, float]) -> bool:
        """Whether validation keeps ``checked`` over ``than``: by the walk rate, then the score; a
        transfer polish by its docked score alone (its walker starts robust, and the stage tests
        every walker it keeps against the bar: a walk rate first would keep only weights that
        walk on as many validation robots as a walker on all of them)."""
        if transfer_keep is not None:
            return checked["score"] > than["score"]
        return (checked["walk_rate"], checked["score"]) > (than["walk_rate"], than["score"])

    told: dict[str, Any] = {"scores": [], "digests": [], "stopped": False}  # what the checkpoint keeps

    def tell(candidates: list[np.ndarray], scores: list[float]) -> None:
        optimizer.tell([(x, -s) for x, s in zip(candidates, scores)])  # CMA minimizes
        told["scores"].append(scores)
        told["digests"].append(_digest(candidates))

    if resume and checkpoint.exists():
        saved = _resumed(checkpoint, identity, updates)
        for update, (scores, digest) in enumerate(zip(saved["scores"], saved["digests"]), 1):
            candidates = [optimizer.ask() for _ in range(popsize)]
            if _digest(candidates) != digest:
                raise ConfigError(checkpoint, f"digests[{update - 1}]", "this search asks other candidates "
                                  "than the cut polish did (another cmaes version?); polish into another folder")
            tell(candidates, scores)
        told["stopped"] = saved["stopped"]
        best = {**saved["best"], "weights": np.array(saved["best"]["weights"])}
        history, judge.steps = saved["history"], saved["physics_steps"]
        dock_scale = history[0].get("undocked") if transfer_keep is not None else None  # the source's validation
        started -= saved["elapsed_s"]
        log(f"polish {path.name}: resumed at update {len(saved['scores'])}/{updates} "
            f"(best validation walk rate {best['walk_rate']:.2f} at update {best['update']})")
    else:
        best = {"update": 0, "weights": x0.copy(), **validate(x0)}
        dock_scale = best["undocked"] if transfer_keep is not None else None
        history = [{"update": 0, **{k: best[k] for k in ("walk_rate", "score", "undocked")}}]
        log(f"polish {path.name}: {len(x0)} weights, {popsize} candidates x {robots} robots an update; "
            f"validation walk rate {best['walk_rate']:.2f} at the start")

    def save_checkpoint() -> None:
        write_json_atomic(checkpoint, {
            "version": CHECKPOINT_VERSION, "identity": identity, **told, "history": history,
            "best": {**best, "weights": best["weights"].tolist()}, "physics_steps": judge.steps,
            "elapsed_s": time.monotonic() - started})

    first = len(told["scores"]) + 1
    for update in range(first, first if told["stopped"] else updates + 1):
        candidates = [optimizer.ask() for _ in range(popsize)]
        judged = judge.run(candidates, _keys(seed, UPDATE_STREAM, update, robots))
        ranked = ranked_by(judged.score, worst)
        if transfer_keep is not None:
            ranked = docked_for_transfer(ranked, judged, on_default(robots), transfer_keep, dock_scale)
        walked = judged.walked
        tell(candidates, [float(s) for s in ranked])
        if update % every == 0 or update == updates:
            checked = validate(optimizer.mean)
            entry = {"update": update, "candidates_walked": float(walked.mean()), **checked,
                     "elapsed_s": time.monotonic() - started}
            history.append(entry)
            improved = better(checked, best)
            if improved:
                best = {"update": update, "weights": optimizer.mean.copy(), **checked}
            log(f"update {update}/{updates}: candidates walked {walked.mean():.2f}, validation walk rate "
                f"{checked['walk_rate']:.2f} (best {best['walk_rate']:.2f} at update {best['update']}), "
                f"{entry['elapsed_s']:.0f} s")
            if improved and on_best is not None:
                save(best["weights"], out / "kept.json", {"kept_update": update, "validation_walk_rate": best["walk_rate"]})
                told["stopped"] = on_best(out / "kept.json", entry)
            limit = patience() if callable(patience) else patience
            if limit is not None and plateaued(history, best["update"], limit):
                log(f"validation kept nothing in the last {limit} validations: a plateau")
                told["stopped"] = True
        if should_stop is not None and not told["stopped"] and should_stop():
            log(f"out of time at update {update}")
            told["stopped"] = True
        save_checkpoint()  # after on_best: a polish cut during its test does this update again
        if told["stopped"]:
            log(f"stopped at update {update}")
            break
    search_s = time.monotonic() - started
    if test:
        fresh = _keys(seed, TEST_STREAM, 0, test)
        _, walked, walked_any, _ = judge.run([x0, best["weights"]], fresh)
        walked, walked_any = walked[:, :test], walked_any[:, :test]  # drawn robots only
        test_rates = {"original": float(walked[0].mean()), "polished": float(walked[1].mean())}
        # the gates' own walk rate, and the plain one: a faster walker may walk on fewer robots
        judged = {name: {"walk_rate": test_rates[name], "walk_rate_any": float(walked_any[i].mean())}
                  for i, name in enumerate(("original", "polished"))}
    else:
        test_rates = {"original": None, "polished": None}
        judged = {name: {"walk_rate": None, "walk_rate_any": None} for name in ("original", "polished")}
    save(best["weights"], out / "polished.json", {"kept_update": best["update"],
                                                  "validation_walk_rate": best["walk_rate"],
                                                  "test_walk_rate": test_rates})
    result = {"controller": str(path), "polished": str(out / "polished.json"), "weights": len(x0), **settings,
              "kept_update": best["update"], "history": history,
              **({"dock_scale": dock_scale} if transfer_keep is not None else {}),
              "test": {"robots": test, **judged},
              "lifted": test_rates["polished"] > test_rates["original"] if test else None,
              "physics_steps": judge.steps, "search_minutes": search_s / 60,
              "minutes": (time.monotonic() - started) / 60}
    write_json_atomic(out / "result.json", result)
    if not test:
        log(f"kept the weights of update {best['update']}; wrote {out / 'polished.json'}")
        return result
    gates = "" if heading_deg is None and min_speed_m_s is None else \
        f", any heading and speed {judged['original']['walk_rate_any']:.2f} -> {judged['polished']['walk_rate_any']:.2f}"
    log(f"test on {test} fresh robots: walk rate {test_rates['original']:.2f} -> {test_rates['polished']:.2f}{gates}"
        f" ({'lifted' if result['lifted'] else 'not lifted: keep the original'}); wrote {out / 'polished.json'}")
    return result

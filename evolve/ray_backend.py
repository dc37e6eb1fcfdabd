"""Evaluation on a Ray cluster: ``biped evolve CONFIG --backend ray [--address ADDR]``.

A generation's simulations are cut into one chunk per worker CPU.  Each chunk travels as
genome data and simulation keys; each worker process builds its evaluator (the MuJoCo model
and a ``mujoco.batch`` sized for a chunk) once and keeps it for every later generation.
Results are bit-identical to the local backend: every simulation's outcome depends only on
its genome and key.  A chunk whose worker dies is run again elsewhere (``max_retries``);
the generation waits for it and its result does not change.
"""

from __future__ import annotations

import math

from evolve.evaluation import EvaluatorSpec, Job, build_evaluator, concatenate, run_job
from evolve.locomotion.evaluator import LocomotionEvaluator
from evolve.locomotion.objectives import Episodes
from sim2real.errors import BipedError

MAX_RETRIES = 5


class WorkerEvaluator:
    """The evaluator a Ray worker process keeps between the chunks it runs: built at the
    first chunk of a spec, kept while chunks of that spec come, replaced for another."""

    def __init__(self) -> None:
        self.spec: EvaluatorSpec | None = None
        self.evaluator: LocomotionEvaluator | None = None

    def get(self, spec: EvaluatorSpec) -> LocomotionEvaluator:
        if self.evaluator is None or spec != self.spec:
            self.evaluator, self.spec = build_evaluator(spec), spec
        return self.evaluator


_WORKER = WorkerEvaluator()  # this process's, when it is a Ray worker


def _evaluate_chunk(spec: EvaluatorSpec, job: Job) -> Episodes:
    return run_job(_WORKER.get(spec), job)


class RayBackend:
    def __init__(self, spec: EvaluatorSpec, address: str | None = None, num_cpus: int | None = None):
        try:
            import ray
        except ImportError:
            raise BipedError("--backend ray needs Ray: pip install 'servo-biped-evolve[cluster]'") from None
        self.ray = ray
        if not ray.is_initialized():
            # without an address a local Ray starts, with as many CPUs as asked (default: all)
            ray.init(address=address, num_cpus=None if address else num_cpus, include_dashboard=False,
                     log_to_driver=False, ignore_reinit_error=True)
        self.workers = max(1, int(ray.cluster_resources().get("CPU", 1)))
        self.chunk = math.ceil(spec.capacity / self.workers)
        # one simulation thread per worker: Ray gives each task one CPU
        self.spec = EvaluatorSpec(spec.robot, spec.task, spec.reality, self.chunk, threads=1)
        self.remote = ray.remote(num_cpus=1, max_retries=MAX_RETRIES, retry_exceptions=False)(_evaluate_chunk)
        self.spec_ref = ray.put(self.spec)

    def run(self, job: Job) -> Episodes:
        n = len(job.genomes)
        futures = [self.remote.remote(self.spec_ref, job.rows(lo, hi)) for lo, hi in chunk_bounds(n, self.chunk)]
        return concatenate(self.ray.get(futures))


def chunk_bounds(n: int, chunk: int) -> list[tuple[int, int]]:
    return [(lo, min(n, lo + chunk)) for lo in range(0, n, chunk)]

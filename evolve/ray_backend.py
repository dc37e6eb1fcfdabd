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
import socket

from evolve.evaluation import EvaluatorSpec, Job, build_evaluator, concatenate, run_job
from evolve.locomotion.evaluator import LocomotionEvaluator
from evolve.locomotion.objectives import Episodes
from sim2real.arg_types import host_port
from sim2real.errors import BipedError, UsageError

MAX_RETRIES = 5
CONNECT_TIMEOUT_S = 5.0  # a cluster head answers a TCP connect in milliseconds; ray.init retries for a minute+
# An HTTP/2 client's connection preface: the fixed string and an empty SETTINGS frame (9-byte frame header:
# length 0, type 4, flags 0, stream 0).  A server's first frame must be SETTINGS (RFC 9113 section 3.4).
HTTP2_PREFACE = b"PRI * HTTP/2.0\r\n\r\nSM\r\n\r\n" + bytes([0, 0, 0, 4, 0, 0, 0, 0, 0])
HTTP2_SETTINGS = 4  # the frame type, byte 3 of a frame header


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
        if address is not None:
            check_reachable(address)
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


def check_reachable(address: str, timeout_s: float = CONNECT_TIMEOUT_S) -> None:
    """Refuse (:class:`UsageError` naming ``--address``) a cluster address nothing answers at
    within ``timeout_s`` [s] - an unknown host, a refused or unanswered port, a server that does
    not speak gRPC - before
    ``ray.init``, which would retry for a minute or more.  ``auto`` is left to Ray (it reads
    the address of the cluster this machine runs and fails at once without one)."""
    if address == "auto":
        return
    try:
        host, port = host_port(address)
    except ValueError as exc:
        raise UsageError(f"--address: {exc}") from None
    try:
        with socket.create_connection((host, port), timeout=timeout_s) as sock:
            # A TCP connect alone proves little (a proxy or firewall may accept any): Ray's head
            # speaks gRPC, so it must answer an HTTP/2 client preface with its own SETTINGS frame
            sock.settimeout(timeout_s)
            sock.sendall(HTTP2_PREFACE)
            reply = sock.recv(9)
    except socket.gaierror as exc:
        raise UsageError(f"--address {address}: cannot resolve the host {host!r} ({exc.strerror or exc})") from None
    except TimeoutError:
        raise UsageError(f"--address {address}: no answer within {timeout_s:g} s (no Ray cluster's head there, or "
                         "a firewall between)") from None
    except OSError as exc:
        raise UsageError(f"--address {address}: cannot connect ({exc.strerror or exc}); is a Ray cluster's head "
                         "running there (ray start --head)?") from None
    if len(reply) < 4 or reply[3] != HTTP2_SETTINGS:
        raise UsageError(f"--address {address}: something answers there, but not a Ray cluster's head (it does not "
                         "speak gRPC); give the head's address, HOST:6379 by default")


def chunk_bounds(n: int, chunk: int) -> list[tuple[int, int]]:
    return [(lo, min(n, lo + chunk)) for lo in range(0, n, chunk)]

"""`--backend ray`: a few generations on a local Ray with 2 CPUs equal the local backend."""

import pytest
import yaml

ray = pytest.importorskip("ray")

from evolve.config import parse_evolve_config  # noqa: E402
from evolve.run import Run  # noqa: E402

SMALL = {
    "robot": "xl430_biped", "seed": 9, "generations": 3, "threads": 1,
    "task": {"episode_s": 0.8, "harness_generations": 2, "harness_fade_generations": 1},
    "neat": {"population_size": 10, "target_species": 3, "compat_threshold": 0.5,
             "add_node_prob": 0.3, "add_link_prob": 0.5},
    "randomize": {"reality": "randomize", "episodes": 2, "score": "worst"},
}
COLUMNS = slice(0, 9)  # generation .. mean_hidden: everything but timings


@pytest.fixture(scope="module")
def local_ray():
    ray.init(num_cpus=2, include_dashboard=False, log_to_driver=False)
    yield
    ray.shutdown()


def _rows(out):
    return [line.split(",")[COLUMNS] for line in (out / "stats.csv").read_text().splitlines()]


def test_ray_and_local_give_the_same_run(tmp_path, local_ray):
    config = parse_evolve_config(SMALL, "small")
    Run.create(config, tmp_path / "local", log=lambda _: None).evolve()
    remote = Run.create(config, tmp_path / "ray", log=lambda _: None, backend="ray")
    assert remote.backend.workers == 2 and remote.backend.chunk == 10  # 20 simulations in 2 chunks
    remote.evolve()
    assert _rows(tmp_path / "ray") == _rows(tmp_path / "local")
    assert (tmp_path / "ray" / "best.json").read_text() == (tmp_path / "local" / "best.json").read_text()
    assert yaml.safe_load((tmp_path / "ray" / "config.yaml").read_text())["randomize"]["episodes"] == 2


def _chunk_workers() -> list[int]:
    """Ray worker processes running a chunk now (Ray titles them after the task)."""
    from pathlib import Path

    pids = []
    for proc in Path("/proc").iterdir():
        try:
            if proc.name.isdigit() and b"ray::_evaluate_chunk" in (proc / "cmdline").read_bytes():
                pids.append(int(proc.name))
        except OSError:
            pass
    return pids


def test_a_worker_killed_mid_generation_changes_nothing(tmp_path, local_ray):
    import os
    import signal
    import threading
    import time

    import numpy as np

    from evolve.evaluation import EvaluatorSpec, Job, LocalBackend
    from evolve.neat import NeatConfig, Population
    from evolve.ray_backend import RayBackend

    spec = EvaluatorSpec("xl430_biped", {"episode_s": 3.0}, "randomize", 8, threads=1)
    local = LocalBackend(spec)
    genomes = Population(NeatConfig(population_size=8, target_species=2), local.evaluator.neat_layout, seed=4).genomes
    job = Job(genomes, np.array([[1, 0, 0, i, 0] for i in range(8)]), 1.0, 0.0, None, 1.0)
    expected = local.run(job)
    backend = RayBackend(spec)
    backend.run(job)  # workers warm: each has built its evaluator
    killed = []

    def kill_one():
        deadline = time.monotonic() + 20
        while time.monotonic() < deadline and not killed:
            pids = _chunk_workers()
            if pids:
                os.kill(pids[0], signal.SIGKILL)
                killed.append(pids[0])
            time.sleep(0.02)

    killer = threading.Thread(target=kill_one)
    killer.start()
    result = backend.run(job)
    killer.join()
    assert killed, "no chunk worker was seen running"
    assert np.array_equal(result.fitness, expected.fitness) and np.array_equal(result.fell, expected.fell)

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

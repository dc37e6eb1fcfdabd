import os
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
# What the SDK's client allows each reply from a simulated or emulated servo beyond what the wire
# needs [us]: on a shared, busy host a reply from a thread or process of the tests can be late,
# and only the tests of the wire's own timeouts leave it out
REPLY_ALLOWANCE_US = 25_000
if sys.platform.startswith("linux") and not os.environ.get("DISPLAY"):
    os.environ.setdefault("MUJOCO_GL", "egl")

from sim2real.robot import available_robots  # noqa: E402
from sim2real.robot.validation import load_yaml  # noqa: E402


def all_robot_names() -> list[str]:
    """Every robot config, and every preset of those that have presets."""
    names = []
    for name in available_robots():
        doc = load_yaml(ROOT / "configs" / "robots" / f"{name}.yaml")
        presets = (doc.get("anthropometry") or {}).get("presets")
        names += [f"{name}:{p}" for p in presets] if presets else [name]
    return names


@pytest.fixture
def robots_dir() -> Path:
    return ROOT / "configs" / "robots"


@pytest.fixture(scope="session")
def grown_controller():
    """A controller for the default robot with some grown structure (hidden nodes, recurrent
    links): five NEAT generations on random fitness, seeded."""
    import numpy as np

    from evolve.locomotion.evaluator import neat_layout
    from evolve.locomotion.export import controller_from_genome
    from evolve.locomotion.task import TaskConfig
    from evolve.neat import NeatConfig, Population
    from sim2real.controller.symmetry import symmetric_layout
    from sim2real.robot import load_robot

    robot = load_robot()
    layout = symmetric_layout(robot, robot.control_sets["walk"])
    pop = Population(NeatConfig(population_size=10, target_species=2, add_node_prob=0.4), neat_layout(layout), seed=1)
    rng = np.random.default_rng(1)
    for _ in range(5):
        pop.step(lambda gs: rng.random(len(gs)))
    return controller_from_genome(pop.genomes[0], robot, layout, TaskConfig(), 1.0, {"seed": 1})


@pytest.fixture
def served_chain():
    """The default robot's servos emulated behind a pseudo-terminal, as the official SDK meets
    real ones: (the emulated chain, to read their registers straight; the port's path)."""
    from sim2real.hardware import MockBus
    from sim2real.robot import load_robot
    from sim2real.simulation.simbus.server import EmulatedChain, PtyServer

    chain = EmulatedChain(MockBus(load_robot()).devices)
    with PtyServer(chain, baud=1_000_000) as server:
        yield chain, server.port

"""Genomes to controllers and back (:class:`sim2real.controller.file.Controller`)."""

from __future__ import annotations

from typing import Any

from evolve.locomotion.task import TaskConfig
from evolve.neat import Genome, Layout
from evolve.neat.genome import ConnectionGene
from evolve.neat.network import expressed
from sim2real.controller.file import Controller
from sim2real.controller.symmetry import SymmetricLayout
from sim2real.robot import RobotSpec
from sim2real.simulation.model.builder import build_model
from sim2real.simulation.model.robot_model import Arm, arm_chain


def controller_from_genome(genome: Genome, robot: RobotSpec, layout: SymmetricLayout, task: TaskConfig,
                           steepness: float, provenance: dict[str, Any]) -> Controller:
    """The genome's expressed network (enabled genes, every module) as ``robot``'s controller
    (its inputs as ``layout`` has them)."""
    nodes, conns = expressed(genome)
    module_of = {(g.src, g.dst): g.module for g in genome.conns.values() if g.enabled}
    return Controller.for_robot(
        robot, layout, sigmoid_steepness=steepness, modules=genome.modules,
        hidden=[(n, genome.hidden[n]) for n in nodes if n in genome.hidden],
        connections=[(s, d, w, module_of[(s, d)]) for s, d, w in conns],
        task=task.to_dict(), provenance=provenance, reach_arm=reach_arm(robot) if layout.reach else None)


def reach_arm(robot: RobotSpec) -> dict[str, Any]:
    """The right arm's chain a reaching controller carries (its runtime's forward kinematics),
    from the robot's nominal model."""
    model = build_model(robot)
    return arm_chain(model, robot, Arm.of(model, robot))


def genome_from_controller(controller: Controller) -> Genome:
    """A genome expressing exactly the controller's network (enabled genes only)."""
    layout = Layout(len(controller.inputs), len(controller.bias[0]), len(controller.outputs))
    genome = Genome(0, layout, controller.modules)
    genome.hidden = {int(n): int(m) for n, m in controller.hidden}
    for i, (src, dst, weight, module) in enumerate(controller.connections):
        genome.add_connection(ConnectionGene(i, int(src), int(dst), float(weight), True, int(module)))
    return genome

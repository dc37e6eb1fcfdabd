"""Genomes to controller files and back (the format of :mod:`sim2real.controller.file`)."""

from __future__ import annotations

from typing import Any

from evolve.locomotion.task import TaskConfig
from evolve.neat import Genome, Layout
from evolve.neat.network import expressed
from sim2real.controller.file import FORMAT, VERSION, joint_map_hash
from sim2real.controller.symmetry import SymmetricLayout
from sim2real.robot import RobotSpec
from sim2real.robot.timing import control_timing


def controller_from_genome(genome: Genome, robot: RobotSpec, layout: SymmetricLayout, task: TaskConfig,
                           steepness: float, provenance: dict[str, Any]) -> dict[str, Any]:
    nodes, conns = expressed(genome)
    module_of = {(g.src, g.dst): g.module for g in genome.conns.values() if g.enabled}
    joints = {j.name: j for j in robot.joints}
    return {
        "format": FORMAT,
        "version": VERSION,
        "robot": {"name": robot.name, "joint_map_hash": joint_map_hash(robot)},
        "tick_s": control_timing(robot).tick_s,
        "inputs": list(layout.input_names),
        "outputs": list(layout.output_names),
        "bias": [[1.0, 1.0], [1.0, -1.0]],  # right network, left network
        "symmetry": {
            "networks": ["right", "left"],
            "leg_joints": {side: [robot.joints[i].name for i in layout.leg_index[side]] for side in ("right", "left")},
            "center_joints": [robot.joints[i].name for i in layout.center_index],
            "center_mirror_for_left": layout.center_mirror.tolist(),
            "center_output": "mean of both networks",
        },
        "sigmoid_steepness": steepness,
        "modules": [{"name": m, "enabled": True} for m in genome.modules],
        "hidden": [[n, genome.hidden[n]] for n in nodes if n in genome.hidden],
        "connections": [[s, d, w, module_of[(s, d)]] for s, d, w in conns],
        "joints": {
            "driven": list(layout.driven),
            "range_rad": {n: list(j.range_rad) for n, j in joints.items()},
            "hold_rad": {n: j.center_rad for n, j in joints.items() if n not in layout.driven},
            "output_rule": "central 0.8 of the range: 0.1 -> low, 0.9 -> high",
        },
        "task": task.to_dict(),
        "provenance": provenance,
    }


def genome_from_controller(data: dict[str, Any]) -> Genome:
    """A genome expressing exactly the controller's network (enabled genes only)."""
    from evolve.neat.genome import ConnectionGene

    layout = Layout(len(data["inputs"]), len(data["bias"][0]), len(data["outputs"]))
    genome = Genome(0, layout, tuple(m["name"] for m in data["modules"]))
    genome.hidden = {int(n): int(m) for n, m in data["hidden"]}
    for i, (src, dst, weight, module) in enumerate(data["connections"]):
        genome.add_connection(ConnectionGene(i, int(src), int(dst), float(weight), True, int(module)))
    return genome

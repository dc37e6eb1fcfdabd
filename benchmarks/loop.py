"""The real-time loop on the mock bus: compute time, jitter and overruns.

    python -m benchmarks.loop --json

10,000 ticks of a 300-connection controller at a 10 ms tick on the default robot.
``compute_us`` is the policy alone (inputs, both networks, mapping), without the bus;
``jitter_ms`` is each tick's start against its deadline.  Goals: compute p99 <= 100 us,
jitter p99 <= 1 ms, no overruns.
"""

from __future__ import annotations

import numpy as np

from benchmarks.common import parser, progress, report
from sim2real.bus import MockBus
from sim2real.controller import joint_map_hash
from sim2real.deploy import drive
from sim2real.robot import load_robot
from sim2real.symmetry import symmetric_layout


def random_controller(robot, connections: int, hidden: int, seed: int) -> dict:
    """A controller with the given size and random weights (recurrent, self-loops allowed)."""
    rng = np.random.default_rng(seed)
    layout = symmetric_layout(robot, robot.control_sets["walk"])
    n_in, n_out = layout.n_inputs, layout.n_outputs
    interface = n_in + 2 + n_out
    nodes = list(range(interface)) + list(range(interface, interface + hidden))
    targets = nodes[n_in + 2:]
    pairs = set()
    while len(pairs) < connections:
        pairs.add((int(rng.choice(nodes)), int(rng.choice(targets))))
    return {
        "format": "biped-controller", "version": 1,
        "robot": {"name": robot.name, "joint_map_hash": joint_map_hash(robot)},
        "tick_s": 0.01, "inputs": list(layout.input_names), "outputs": list(layout.output_names),
        "bias": [[1.0, 1.0], [1.0, -1.0]], "symmetry": {}, "sigmoid_steepness": 1.0,
        "modules": [{"name": "main", "enabled": True}],
        "hidden": [[n, 0] for n in range(interface, interface + hidden)],
        "connections": [[s, d, float(rng.normal()), 0] for s, d in sorted(pairs)],
        "joints": {"driven": list(layout.driven), "range_rad": {}}, "task": {}, "provenance": {"seed": seed},
    }


def main(argv=None) -> None:
    p = parser(__doc__.splitlines()[0])
    p.add_argument("--ticks", type=int, default=10_000)
    p.add_argument("--tick-ms", type=float, default=10.0)
    p.add_argument("--connections", type=int, default=300)
    args = p.parse_args(argv)
    robot = load_robot()
    controller = random_controller(robot, args.connections, hidden=40, seed=0)
    controller["tick_s"] = args.tick_ms / 1000.0
    progress(f"{args.ticks} ticks at {args.tick_ms} ms on the mock bus...", args.json)
    result = drive(MockBus(robot), robot, controller, duration_s=args.ticks * controller["tick_s"],
                   log=lambda s: None, ramp_s=0.1)
    summary = result.summary()
    report({
        "ticks": summary["ticks"], "tick_ms": args.tick_ms, "connections": args.connections,
        "compute_us_p50": summary["compute_us_p50"], "compute_us_p99": summary["compute_us_p99"],
        "jitter_ms_p99": summary["jitter_ms_p99"], "overruns": summary["overruns"],
        "stop_reason": summary["stop_reason"],
    }, args.json)


if __name__ == "__main__":
    main()

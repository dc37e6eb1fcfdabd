"""MuJoCo's log file: none.

MuJoCo appends each warning (an unstable simulation, a model it corrects) to
``MUJOCO_LOG.TXT`` in the current working folder - wherever the user happens to stand, which
is no output of this project's - besides printing it.  :func:`no_log_file` switches the file
off for this process through MuJoCo's log configuration (``mujoco.MjLogConfig``, MuJoCo 3.4+:
``get()``, the ``logto_file`` switch, ``set()``); the printed line stays, and every warning
the project acts on it reads from ``MjData.warning`` (e.g.
:func:`sim2real.simulation.model.builder.instability`), not from the log.
:mod:`sim2real.simulation.model.robot_model`, which every MuJoCo model of the project passes
through (model building, model files, the simulated bus, evaluation), calls it on import, so
each process that simulates - ``biped``, the simulated bus's, a Ray worker - has it.
"""

from __future__ import annotations

import mujoco


def no_log_file() -> None:
    """Stop MuJoCo writing ``MUJOCO_LOG.TXT`` in this process (idempotent)."""
    config = mujoco.MjLogConfig.get()
    if config.logto_file:
        config.logto_file = False
        config.set()

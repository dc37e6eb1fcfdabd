"""Pictures of what the project makes, as seed 000 draws them: a walk's joint angles and
phase portraits (:mod:`.gait`, its figures 2 and 3) and an evolved network (:mod:`.network`).

Matplotlib only (the ``plot`` extra), offscreen; no MuJoCo, so a robot computer can draw
its own traces.
"""

from __future__ import annotations

from typing import Any

from sim2real.errors import BipedError


def pyplot() -> Any:
    """``matplotlib.pyplot`` on the offscreen Agg backend, or a clear error without it."""
    try:
        import matplotlib
    except ImportError as exc:
        raise BipedError("pictures need matplotlib: pip install 'servo-biped-evolve[plot]'") from exc
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt

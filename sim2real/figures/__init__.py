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


def save_figure(fig: Any, path: Any, **savefig: Any) -> None:
    """``fig.savefig(path, **savefig)``, closed, and written atomically (a temporary file
    beside, renamed when whole: a full disk leaves no half picture, and the error names
    ``path``).  The format is the name's suffix (.png, .svg, .pdf)."""
    import io
    from pathlib import Path

    from sim2real.atomic_json import write_bytes_atomic

    path = Path(path)
    buffer = io.BytesIO()  # drawn in memory: a backend meeting a full disk mid-file fails obscurely (PDF: zlib)
    try:
        fig.savefig(buffer, format=path.suffix.lstrip(".").lower() or None, **savefig)
    finally:
        pyplot().close(fig)
    write_bytes_atomic(path, buffer.getvalue())

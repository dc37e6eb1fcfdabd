"""Offscreen pictures of a MuJoCo scene, from the robot's tracking camera.

On a machine without a display MuJoCo needs an offscreen OpenGL: EGL (the default we
pick here, with Mesa's libEGL) or OSMesa (``MUJOCO_GL=osmesa``, Debian package
``libosmesa6``).  Images are written with ``imageio`` (the ``plot`` extra).
"""

from __future__ import annotations

import os
import sys
from pathlib import Path

import numpy as np

if sys.platform.startswith("linux") and not os.environ.get("DISPLAY"):
    os.environ.setdefault("MUJOCO_GL", "egl")  # must precede the first mujoco import

import mujoco  # noqa: E402


def render_image(model: mujoco.MjModel, data: mujoco.MjData, width: int, height: int,
                 camera: str = "track") -> np.ndarray:
    """One RGB frame, shape (height, width, 3), from ``camera``."""
    width = min(width, model.vis.global_.offwidth)
    height = min(height, model.vis.global_.offheight)
    try:
        renderer = mujoco.Renderer(model, height=height, width=width)
    except Exception as exc:  # the GL backends raise a variety of errors
        raise RuntimeError(
            f"cannot open an offscreen OpenGL context (MUJOCO_GL={os.environ.get('MUJOCO_GL')}): {exc}. "
            "Install Mesa's EGL (Debian: libegl1 libgl1-mesa-dri) or OSMesa (libosmesa6, then "
            "MUJOCO_GL=osmesa)."
        ) from exc
    with renderer:
        renderer.update_scene(data, camera=camera)
        return renderer.render().copy()


def save_image(path: Path, image: np.ndarray) -> None:
    try:
        import imageio.v3 as iio
    except ImportError as exc:
        raise SystemExit("writing images needs imageio: pip install 'servo-biped-evolve[plot]'") from exc
    Path(path).parent.mkdir(parents=True, exist_ok=True)
    iio.imwrite(path, image)

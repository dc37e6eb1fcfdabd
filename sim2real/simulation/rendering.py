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

from sim2real.atomic_json import atomic_output, write_bytes_atomic  # noqa: E402
from sim2real.errors import BipedError  # noqa: E402


def open_renderer(model: mujoco.MjModel, width: int, height: int) -> mujoco.Renderer:
    """An offscreen renderer (close it, or use it in ``with``), with a clear error if no GL."""
    if width > model.vis.global_.offwidth or height > model.vis.global_.offheight:
        raise ValueError(f"{width} x {height} pixels: larger than the model's offscreen buffer "
                         f"({model.vis.global_.offwidth} x {model.vis.global_.offheight})")
    try:
        return mujoco.Renderer(model, height=height, width=width)
    except Exception as exc:  # the GL backends raise a variety of errors
        raise BipedError(
            f"cannot open an offscreen OpenGL context (MUJOCO_GL={os.environ.get('MUJOCO_GL')}): {exc}. "
            "Install Mesa's EGL (Debian: libegl1 libgl1-mesa-dri) or OSMesa (libosmesa6, then "
            "MUJOCO_GL=osmesa)."
        ) from exc


def render_image(model: mujoco.MjModel, data: mujoco.MjData, width: int, height: int,
                 camera: str = "track") -> np.ndarray:
    """One RGB frame, shape (height, width, 3), from ``camera``."""
    with open_renderer(model, width, height) as renderer:
        renderer.update_scene(data, camera=camera)
        return renderer.render().copy()


TARGET_RGBA = np.array([0.9, 0.2, 0.2, 0.8], dtype=np.float32)
PATH_RGBA = np.array([0.2, 0.5, 0.95, 0.9], dtype=np.float32)


def draw_reach(scene: mujoco.MjvScene, target: np.ndarray, radius: float, path: np.ndarray) -> None:
    """Add a reach's target (a sphere of ``radius`` [m] at ``target`` (3,), world) and the hand's
    path so far (``path`` (k, 3), world, a line of segments) to a scene about to be rendered."""
    def add() -> mujoco.MjvGeom | None:
        if scene.ngeom >= scene.maxgeom:  # a full scene: the rest of the path is left out
            return None
        scene.ngeom += 1
        return scene.geoms[scene.ngeom - 1]

    geom = add()
    if geom is not None:
        mujoco.mjv_initGeom(geom, mujoco.mjtGeom.mjGEOM_SPHERE, np.full(3, radius), np.asarray(target, float),
                            np.eye(3).ravel(), TARGET_RGBA)
    width = 0.15 * radius
    for a, b in zip(path[:-1], path[1:]):
        geom = add()
        if geom is None:
            return
        mujoco.mjv_initGeom(geom, mujoco.mjtGeom.mjGEOM_CAPSULE, np.zeros(3), np.zeros(3), np.eye(3).ravel(),
                            PATH_RGBA)
        mujoco.mjv_connector(geom, mujoco.mjtGeom.mjGEOM_CAPSULE, width, np.asarray(a, float), np.asarray(b, float))


def save_video(path: Path, frames: list[np.ndarray], frame_s: float) -> None:
    """An .mp4 (needs imageio-ffmpeg) or .gif from RGB frames ``frame_s`` apart [s]."""
    try:
        import imageio.v3 as iio
    except ImportError as exc:
        raise BipedError("writing videos needs imageio: pip install 'servo-biped-evolve[plot]'") from exc
    path = Path(path)
    if path.suffix.lower() == ".gif":  # made in memory: only the one write below can meet a full disk
        write_bytes_atomic(path, iio.imwrite("<bytes>", np.stack(frames), extension=".gif",
                                             duration=frame_s * 1000, loop=0))
        return
    with atomic_output(path) as tmp:  # ffmpeg writes to a path: a temporary one beside, renamed when whole
        iio.imwrite(tmp, np.stack(frames), fps=round(1.0 / frame_s), codec="libx264", macro_block_size=8)
        _check_video(tmp, len(frames))


def _check_video(path: Path, frames: int) -> None:
    """Raise ``OSError`` unless the video at ``path`` holds ``frames`` frames: imageio-ffmpeg
    does not look at ffmpeg's exit status, so an encoder that could not write (a full disk)
    would otherwise leave an empty or cut video behind a success."""
    import errno

    import imageio_ffmpeg

    try:
        found, _ = imageio_ffmpeg.count_frames_and_secs(str(path))
    except (RuntimeError, OSError):
        found = 0
    if found != frames:
        free = os.statvfs(path.parent)
        if free.f_bavail * free.f_frsize < 1 << 20:  # under 1 MiB left: what ffmpeg met, most likely
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
        raise OSError(errno.EIO, f"ffmpeg wrote {found} of {frames} frames (its messages above say why)")


def save_image(path: Path, image: np.ndarray) -> None:
    try:
        import imageio.v3 as iio
    except ImportError as exc:
        raise BipedError("writing images needs imageio: pip install 'servo-biped-evolve[plot]'") from exc
    path = Path(path)
    write_bytes_atomic(path, iio.imwrite("<bytes>", image, extension=path.suffix.lower()))

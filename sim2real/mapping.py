"""Network outputs to joint goals, and joint angles to what the robot sees (no MuJoCo).

Seed 000 section 7.2: an output in [0, 1] drives its joint through the central 0.8 of its
range - 0.1 maps to the low end, 0.9 to the high end, beyond that it clamps.  A goal may
move at most the servo's no-load speed times the tick in one tick.  Angles are read
quantized to the encoder's resolution, as the servo reports them.

All functions take numpy arrays and broadcast; angles in [rad].
"""

from __future__ import annotations

import numpy as np

OUTPUT_MARGIN = 0.1  # output range clamped at each end


def output_to_angle(output: np.ndarray, low: np.ndarray, high: np.ndarray) -> np.ndarray:
    """Central-0.8 rule: output 0.1 -> low, 0.9 -> high, clamped outside [rad]."""
    fraction = np.clip((output - OUTPUT_MARGIN) / (1.0 - 2.0 * OUTPUT_MARGIN), 0.0, 1.0)
    return low + fraction * (high - low)


def angle_to_output(angle: np.ndarray, low: np.ndarray, high: np.ndarray) -> np.ndarray:
    """Inverse of :func:`output_to_angle` inside the range."""
    return OUTPUT_MARGIN + (1.0 - 2.0 * OUTPUT_MARGIN) * (angle - low) / (high - low)


def rate_limit(goal: np.ndarray, previous: np.ndarray, max_step: np.ndarray) -> np.ndarray:
    """Move from ``previous`` toward ``goal`` by at most ``max_step`` [rad]."""
    return previous + np.clip(goal - previous, -max_step, max_step)


def quantize(angle: np.ndarray, resolution: np.ndarray) -> np.ndarray:
    """Round to the encoder's resolution [rad a tick] (0 leaves the angle as is)."""
    resolution = np.asarray(resolution, dtype=float)
    safe = np.where(resolution > 0, resolution, 1.0)
    return np.where(resolution > 0, np.round(angle / safe) * safe, angle)


def normalized_angle(angle: np.ndarray, low: np.ndarray, high: np.ndarray) -> np.ndarray:
    """A joint angle as a network input: -1 at the low end of the range, +1 at the high end."""
    return 2.0 * (angle - low) / (high - low) - 1.0

"""Output-to-goal mapping and what the robot reads (sim2real.mapping)."""

import numpy as np
import pytest

from sim2real.mapping import angle_to_output, normalized_angle, output_to_angle, quantize, rate_limit


def test_central_0_8_of_the_output_spans_the_range_and_the_ends_clamp():
    low, high = -0.5, 1.5
    out = output_to_angle(np.array([0.0, 0.05, 0.1, 0.5, 0.9, 0.95, 1.0]), low, high)
    assert out == pytest.approx([low, low, low, 0.5, high, high, high])
    angles = np.linspace(low, high, 7)
    assert output_to_angle(angle_to_output(angles, low, high), low, high) == pytest.approx(angles)


def test_rate_limit_moves_at_most_max_step():
    assert rate_limit(np.array([1.0, -1.0, 0.05]), np.zeros(3), 0.1) == pytest.approx([0.1, -0.1, 0.05])


def test_quantize_rounds_to_the_encoder_resolution_and_zero_means_exact():
    tick = 2 * np.pi / 4096
    got = quantize(np.array([0.3, 0.3]), np.array([tick, 0.0]))
    assert abs(got[0] - 0.3) <= tick / 2 and got[0] / tick == pytest.approx(round(got[0] / tick))
    assert got[1] == 0.3


def test_normalized_angle_is_minus_one_to_one_over_the_range():
    assert normalized_angle(np.array([0.0, 1.0, 2.0]), 0.0, 2.0) == pytest.approx([-1, 0, 1])

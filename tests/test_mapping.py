"""Output-to-goal mapping and what the robot reads (sim2real.controller.mapping)."""

import numpy as np
import pytest

from sim2real.controller.mapping import (
    angle_to_output,
    normalized_angle,
    output_to_angle,
    quantize,
    rate_limit,
)


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


from hypothesis import given, settings  # noqa: E402
from hypothesis import strategies as st  # noqa: E402

from sim2real.controller.mapping import ServoMapping  # noqa: E402
from sim2real.robot import load_robot  # noqa: E402

XL430 = ServoMapping(load_robot("xl430_biped"))


def test_ticks_and_angles_round_trip_within_one_tick():
    angles = (XL430.low + XL430.high) / 2 + 0.1
    back = XL430.angles(XL430.ticks(angles))
    assert np.all(np.abs(back - angles) <= XL430.rad_per_tick / 2 + 1e-12)


def test_direction_and_zero_offset_are_applied():
    robot = load_robot("xl430_biped")
    zero = XL430.ticks(np.zeros(len(robot.joints)))
    assert np.all(zero == 2048)  # joint 0 is the horn's centre on this robot
    names = list(XL430.names)
    right, left = names.index("right_knee"), names.index("left_knee")
    bent = np.zeros(len(names))
    bent[[right, left]] = 0.5
    ticks = XL430.ticks(bent)
    assert ticks[right] > 2048 > ticks[left]  # the left knee's servo is mounted mirrored


@settings(max_examples=300, deadline=None)
@given(st.lists(st.floats(allow_nan=False, allow_infinity=False, min_value=-1e6, max_value=1e6),
                min_size=11, max_size=11))
def test_no_goal_ever_leaves_the_joint_or_servo_limits(values):
    ticks = XL430.ticks(np.array(values))
    assert np.all(ticks >= XL430.min_tick) and np.all(ticks <= XL430.max_tick)
    angles = XL430.angles(ticks)
    assert np.all(angles >= XL430.low - 1e-9) and np.all(angles <= XL430.high + 1e-9)


def test_the_home_rule_puts_an_output_of_half_at_home_and_the_ends_where_they_were():
    low, high, home = np.array([0.0, -1.0, -0.5]), np.array([2.0, 1.0, 0.5]), np.array([0.0, 0.5, -0.1])
    outputs = np.array([0.1, 0.3, 0.5, 0.7, 0.9])[:, None]
    angles = output_to_angle(outputs, low, high, home)
    assert np.array_equal(angles[2], home) and np.allclose(angles[0], low) and np.allclose(angles[-1], high)
    assert np.all(np.diff(angles, axis=0) >= 0)  # monotonic, flat below home where home is the low end
    assert angles[1, 0] == 0.0 and angles[3, 0] == pytest.approx(1.0)
    inside = np.array([[0.3, -0.2, 0.2], [1.5, 0.9, -0.4]])
    assert output_to_angle(angle_to_output(inside, low, high, home), low, high, home) == pytest.approx(inside)

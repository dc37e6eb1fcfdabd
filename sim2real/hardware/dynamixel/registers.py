"""Names of the control-table entries the code addresses, as in ``firmware_profiles/*.yaml``.

Addresses, sizes, signedness and units are data, read from each device's profile; the code
names an entry only through :class:`Reg`, so a misspelt name fails at import, not on the
robot.  A :class:`Reg` is a ``str``: ``profile.register(Reg.GOAL_POSITION)`` and
``Reg.GOAL_POSITION in profile.control_table`` look it up like the plain name.
Source of the names: the ROBOTIS e-manual's control tables (X series, AX-12A), and this
project's foot-sensor board (``firmware_profiles/foot_sensor_board.yaml``).
"""

from __future__ import annotations

from enum import StrEnum


class Reg(StrEnum):
    """Control-table entries by their profile name."""

    # every device (the header that generic tools use)
    MODEL_NUMBER = "model_number"
    FIRMWARE_VERSION = "firmware_version"
    ID = "id"
    RETURN_DELAY_TIME = "return_delay_time"  # [2 us]
    HARDWARE_ERROR_STATUS = "hardware_error_status"  # bits: see dynamixel.errors.HARDWARE_ERRORS
    # servos
    OPERATING_MODE = "operating_mode"
    MIN_POSITION_LIMIT = "min_position_limit"  # [tick]
    MAX_POSITION_LIMIT = "max_position_limit"  # [tick]
    BUS_WATCHDOG = "bus_watchdog"  # [20 ms]
    TORQUE_ENABLE = "torque_enable"
    GOAL_POSITION = "goal_position"  # [tick]
    PRESENT_POSITION = "present_position"  # [tick]
    PRESENT_VELOCITY = "present_velocity"  # [velocity_unit_rpm of the profile]
    PRESENT_LOAD = "present_load"  # [0.1 % of stall torque]
    PRESENT_CURRENT = "present_current"  # [the entry's unit, e.g. 2.69 mA]
    # the foot-sensor board
    FOOT_SWITCH_LEFT = "foot_switch_left"
    FOOT_SWITCH_RIGHT = "foot_switch_right"
    UP_VECTOR_X = "up_vector_x"
    UP_VECTOR_Y = "up_vector_y"
    UP_VECTOR_Z = "up_vector_z"
    HEADING = "heading"  # [heading_unit of the profile: rad] the IMU's yaw, counter-clockwise from above
    GYRO_X = "gyro_x"  # [gyro_unit of the profile: rad/s] the torso's roll rate
    GYRO_Y = "gyro_y"  # [gyro_unit] pitch rate
    GYRO_Z = "gyro_z"  # [gyro_unit] yaw rate


POSITION_MODE = 3  # Operating Mode value of position control (X series e-manual, address 11)

"""The robot and its data: the robot description (:mod:`.spec`, read by :mod:`.loading`,
the human character's body from :mod:`.anthropometry`), Dynamixel firmware profiles
(:mod:`.profiles`), the servo model's numbers (:mod:`.servo_model`), the control tick
(:mod:`.timing`), config validation helpers (:mod:`.validation`) and where data lives
(:mod:`.paths`).  No MuJoCo here."""

from sim2real.robot.loading import (
           available_robots,
           load_robot,
           parse_robot,
           resolve_robot_path,
)
from sim2real.robot.spec import DEFAULT_ROBOT, Joint, RobotSpec

__all__ = ["DEFAULT_ROBOT", "Joint", "RobotSpec", "available_robots", "load_robot", "parse_robot",
           "resolve_robot_path"]

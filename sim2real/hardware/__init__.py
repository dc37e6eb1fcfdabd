"""Dynamixel buses: one interface (:class:`Bus`), a mock for tests, the real SDK-backed one.

Above the bus nothing knows which one it talks to; :class:`ServoChain` adds the robot
(names, signedness, retries) on top of any of them.
"""

from sim2real.hardware.bus import Bus, CommunicationError, ServoError
from sim2real.hardware.dynamixel.chain import ServoChain
from sim2real.hardware.mock import MockBus

__all__ = ["Bus", "CommunicationError", "ServoError", "ServoChain", "MockBus"]

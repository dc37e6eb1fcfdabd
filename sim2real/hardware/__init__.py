"""Driving servos: one interface (:class:`Bus`), a mock for tests, the Dynamixel package
(the SDK-backed bus, the chain, registers, errors, start-up), the real-time loop and traces.

Above the bus nothing knows which one it talks to; :class:`ServoChain` adds the robot
(names, signedness, retries) on top of any of them.
"""

from sim2real.hardware.bus import Bus, CommunicationError, ServoError
from sim2real.hardware.dynamixel.chain import ServoChain
from sim2real.hardware.mock import MockBus

__all__ = ["Bus", "CommunicationError", "ServoError", "ServoChain", "MockBus"]

"""Dynamixel specifics: the bus through the official SDK (:mod:`.sdk_bus`) and the robot's
devices by register name on any bus (:mod:`.chain`)."""

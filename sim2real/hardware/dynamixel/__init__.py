"""Dynamixel specifics: the bus through the official SDK (:mod:`.sdk_bus`), the robot's
devices by register name on any bus (:mod:`.chain`), the control-table names the code uses
(:mod:`.registers`), status and hardware errors in words (:mod:`.errors`), and the checks and
writes before a run (:mod:`.startup`).  Another servo brand gets a package beside this one."""

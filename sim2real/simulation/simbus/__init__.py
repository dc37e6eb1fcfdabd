"""A wire-level emulated Dynamixel chain on a pseudo-terminal: any Dynamixel client (the
official SDK included) talks to it as to real servos."""

"""The controller: its file format (:mod:`.file`: the frozen, versioned :class:`Controller`,
checked whole on load; :mod:`.schema` the format's keys and bounds, read from its published
schema; :mod:`.json_reader` the hardened decoding of its bytes; :mod:`.checks` every field,
:mod:`.robot_checks` against a robot, both through :mod:`.field_checker`), the networks' activation (:mod:`.activation`, which evolution runs
batched and the runtime per tick), bilateral symmetry's wiring (:mod:`.symmetry`), outputs
to joint goals and angles to inputs (:mod:`.mapping`), and both together as a per-tick
policy (:mod:`.policy`).  Evolution and the runtime read these same modules.  No MuJoCo
here."""

from sim2real.controller.checks import check_controller
from sim2real.controller.file import Controller
from sim2real.controller.robot_checks import joint_map_hash

__all__ = ["Controller", "check_controller", "joint_map_hash"]

"""The controller: its file format (:mod:`.file`: the frozen, versioned :class:`Controller`,
checked whole on load), the networks' activation (:mod:`.activation`, which evolution runs
batched and the runtime per tick), bilateral symmetry's wiring (:mod:`.symmetry`), outputs
to joint goals and angles to inputs (:mod:`.mapping`), and both together as a per-tick
policy (:mod:`.policy`).  Evolution and the runtime read these same modules.  No MuJoCo
here."""

from sim2real.controller.file import Controller, check_controller, joint_map_hash

__all__ = ["Controller", "check_controller", "joint_map_hash"]

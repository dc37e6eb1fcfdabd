"""The controller: its file format (:mod:`.file`: versioned JSON, checked whole on load), the
networks' activation (:mod:`.activation`), bilateral symmetry's wiring (:mod:`.symmetry`),
outputs to joint goals and angles to inputs (:mod:`.mapping`), and both together as a
per-tick policy (:mod:`.policy`).  Evolution and the runtime read these same modules.  No
MuJoCo here."""

from sim2real.controller.file import (
    check_controller,
    joint_map_hash,
    load_controller,
    save_controller,
)

__all__ = ["check_controller", "joint_map_hash", "load_controller", "save_controller"]

"""Does a robot stand, and can its servos hold it?

:mod:`.check` leaves the built robot standing at its home for a few seconds and judges it;
:mod:`.home` proposes a home that stands for a robot whose home falls; :mod:`.imported` runs
both on what ``biped robot import`` inferred, before its YAML is written; :mod:`.statics`
gives each joint's holding torque in a crouch against its servo's stall torque.

These judge a robot on its model and are no part of building one: they import
:mod:`sim2real.simulation.model`, which never imports them."""

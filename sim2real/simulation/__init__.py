"""The robot in MuJoCo, by job: robots made MuJoCo models (:mod:`.model`: the box builder, model
files, ``biped robot import``, inertias, the physique; :class:`~.model.robot_model.RobotModel`
owns the names the simulation reads), whether a robot stands and what its servos hold
(:mod:`.standing`), reality files and randomization (:mod:`.reality`), the simulated Dynamixel
bus (:mod:`.simbus`), dry runs on it and traces compared with the simulation (:mod:`.transfer`),
system identification (:mod:`.identify`) and pictures (:mod:`.rendering`).

Model building is the floor: it imports :mod:`sim2real.robot` and none of the other jobs, and
:mod:`sim2real.robot` imports none of these (both held by ``tests/test_architecture.py``)."""

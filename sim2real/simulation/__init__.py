"""The robot in MuJoCo, by job: robots made MuJoCo models (:mod:`.model`: the box builder, model
files, ``biped robot import``, inertias, the physique; :class:`~.model.robot_model.RobotModel`
owns the names the simulation reads), whether a robot stands and what its servos hold
(:mod:`.standing`), reality files and randomization (:mod:`.reality`), the simulated Dynamixel
bus (:mod:`.simbus`), dry runs on it and traces compared with the simulation (:mod:`.transfer`),
system identification (:mod:`.identify`) and pictures (:mod:`.rendering`).

Each package depends only on those before it in this list (``model`` on :mod:`sim2real.robot`
alone); :mod:`sim2real.robot` imports none of them."""

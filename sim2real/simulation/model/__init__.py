"""Robots as MuJoCo models: everything that needs MuJoCo to make a robot of the project.

* the box tree of the project's robots and :func:`~.builder.build_model` for every robot
  (:mod:`.builder`), a user's MJCF or URDF made a project model (:mod:`.file_robot`), the parts
  both are given alike (:mod:`.parts`), and what a joint carries (:mod:`.joint_loads`);
* reading model files safely (:mod:`.files`, :mod:`.guard`), the roles a robot YAML gives their
  bodies checked on the model's tree (:mod:`.body_roles`), implausible inertias (:mod:`.inertias`);
* the physique of a robot from a model file - mass, height and leg length measured on its
  compiled model - handed to its spec where it is loaded to be simulated (:mod:`.physique`);
* ``biped robot import``: a robot YAML inferred from a model file (:mod:`.importing`);
* :class:`~.robot_model.RobotModel`, the one owner of the names and addresses the simulation
  reads from a compiled model, and MuJoCo's log file switched off (:mod:`.mujoco_log`).

It imports :mod:`sim2real.robot` (the description it builds from) and nothing else of the
simulation."""

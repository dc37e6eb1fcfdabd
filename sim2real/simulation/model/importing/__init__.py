"""``biped robot import``: a starting robot YAML inferred from a user's MJCF or URDF.

:func:`~.importer.import_robot` reads the compiled model at its zero pose and infers from its
structure the legs, arms, spine and neck (:mod:`.structure`), which way the robot faces
(:mod:`.facing`), the left-right pairs (:mod:`.mirror`), each hinge's role and sign
(:mod:`.roles`); names are only a hint (:mod:`.joint_names`).  :mod:`.robot_yaml` writes the
result with every guess commented.  Whether the imported robot stands, and a home that does,
is :mod:`sim2real.simulation.standing.imported`'s."""

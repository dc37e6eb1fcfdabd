"""The deployment side's ``biped`` subcommands: ``robot`` (:mod:`.robot_commands`); ``view``,
``render`` (:mod:`.view_commands`); ``run``, ``dry-run``, ``simbus``, ``compare``
(:mod:`.deploy_commands`); checked flag values and result printing (:mod:`.args`).
:mod:`evolve.cli` assembles them with the evolution commands into one program."""

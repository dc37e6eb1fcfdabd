"""Before and after the real robot: a dry run of the real runtime against the simulated bus
(:mod:`.dry_run`), and a trace of a run, real or dry, compared with the simulation
(:mod:`.compare`)."""

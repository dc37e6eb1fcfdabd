"""The robot in MuJoCo: the model builder (:mod:`.model_builder`, with :mod:`.statics`),
reality profiles and randomization (:mod:`.reality`), the simulated Dynamixel bus
(:mod:`.simbus`) and dry runs on it (:mod:`.dry_run`), traces compared with the simulation
(:mod:`.compare`), pictures and videos (:mod:`.rendering`)."""

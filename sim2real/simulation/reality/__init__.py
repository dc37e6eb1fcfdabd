"""How a real robot differs from its nominal model: reality files and randomization (:mod:`.file`)."""

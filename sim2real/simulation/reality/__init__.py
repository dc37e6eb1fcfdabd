"""How a real robot differs from its nominal model: reality files, read and checked without
MuJoCo (:mod:`.file`), and the randomization drawn from them into models (:mod:`.randomize`)."""

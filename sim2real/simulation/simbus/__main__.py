"""``python -m sim2real.simulation.simbus``: the simulated bus as a process (see :mod:`.service`)."""

import sys

from sim2real.simulation.simbus.service import main

sys.exit(main())

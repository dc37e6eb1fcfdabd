"""``python -m sim2real.simbus``: the simulated bus as a process (see :mod:`.service`)."""

import sys

from sim2real.simbus.service import main

sys.exit(main())

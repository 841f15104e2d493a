#!/usr/bin/env python
"""Showed that a standing wheel draws next to no battery power at the logs' stops (nobody balancing it), the evidence for the stop model: docs/ride_simulation.md.

    python studies/stop_power.py [--data ../shared/data]

The code is :mod:`euc_sim.evaluation.stop_power` (tests/ check its helpers there).
"""

import sys

from euc_sim.evaluation.stop_power import main

if __name__ == "__main__":
    sys.exit(main())

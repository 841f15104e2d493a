#!/usr/bin/env python
"""Measured how far a real ride's battery power is from itself band by band (half against half), the yardstick of the held-out band score: docs/ride_simulation.md.

    python studies/band_halves.py [--data ../shared/data]

The code is :mod:`euc_sim.evaluation.band_halves` (tests/ check its helpers there).
"""

import sys

from euc_sim.evaluation.band_halves import main

if __name__ == "__main__":
    sys.exit(main())

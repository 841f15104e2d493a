#!/usr/bin/env python
"""Showed where the rider fit of a ride page falls, design point by design point: docs/rider_calibration.md.

    nice -n 10 python studies/rider_fit_falls.py RIDE.json FIT_LOG --out OUT.json

The code is :mod:`euc_sim.evaluation.rider_fit_falls` (tests/ check its helpers there).
"""

import sys

from euc_sim.evaluation.rider_fit_falls import main

if __name__ == "__main__":
    sys.exit(main())

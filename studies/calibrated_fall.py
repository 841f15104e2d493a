#!/usr/bin/env python
"""Showed why the calibrated rider falls in a pair's drivetrain step (Lynx 0 -> 2, Blitz 2 -> 4), its window measured: docs/ride_simulation.md.

    nice -n 10 python studies/calibrated_fall.py PAIR_DIR HELD_LOG SPEC [--start 541] [--end 600]

The code is :mod:`euc_sim.evaluation.calibrated_fall` (tests/ check its helpers there).
"""

import sys

from euc_sim.evaluation.calibrated_fall import main

if __name__ == "__main__":
    sys.exit(main())

#!/usr/bin/env python
"""Reproduces the table of docs/ride_simulation.md: the simulated ride step by step on every shared pair of one wheel.

    nice -n 10 python scripts/tables/ride_simulation_table.py --out /tmp/ridesim [--workers 2]

The code is :mod:`euc_sim.evaluation.ride_simulation_table` (tests/ check its helpers there).
"""

import sys

from euc_sim.evaluation.ride_simulation_table import main

if __name__ == "__main__":
    sys.exit(main())

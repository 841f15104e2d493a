#!/usr/bin/env python
"""Soak the command line (docs/robustness.md): N random valid command lines and N malformed
inputs, sorted into finished / refused / internal / crash / leftovers
(:mod:`euc_sim.evaluation.soak`).

    nice python scripts/soak.py --valid 60 --malformed 60 --workers 2 --json soak.json
"""

import sys

from euc_sim.evaluation.soak import main

if __name__ == "__main__":
    sys.exit(main())

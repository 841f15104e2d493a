#!/usr/bin/env python
"""Reproduces the ROC table of the diagnosis's acceptance rule (null recordings against weak true effects) in docs/diagnosis.md.

    python scripts/tables/acceptance_roc.py --nulls blind/cal7 --study blind/s7

The code is :mod:`euc_sim.evaluation.acceptance_roc` (tests/ check its helpers there).
"""

import sys

from euc_sim.evaluation.acceptance_roc import main

if __name__ == "__main__":
    sys.exit(main())

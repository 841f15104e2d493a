#!/usr/bin/env python
"""The blind study of docs/diagnosis.md (its confusion table and targets): recordings with a
concealed effect, diagnosed blind and scored (:mod:`euc_sim.evaluation.blind_study`).

    python scripts/tables/blind_study.py --out blind/ --per-effect 10 --nulls 6 --seed 0
"""

import sys

from euc_sim.evaluation.blind_study import main

if __name__ == "__main__":
    sys.exit(main())

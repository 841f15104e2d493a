"""``python -m euc_sim.cli``: the ``euc-sim`` command without the installed script."""
import sys

from euc_sim.cli import main

sys.exit(main())

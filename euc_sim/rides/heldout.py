"""Terms kept by held-out validation for the ride fits: :mod:`euc_sim.stats`'s.

The balance fit, the mass and the PWM duty model all select their terms with
:func:`euc_sim.stats.forward_select` over contiguous time folds
(:func:`euc_sim.stats.time_blocks`); the names are kept here for their callers.
"""

from __future__ import annotations

from euc_sim.stats import forward_select as select_by_heldout
from euc_sim.stats import time_blocks

__all__ = ["select_by_heldout", "time_blocks"]

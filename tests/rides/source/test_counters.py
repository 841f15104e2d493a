"""The app's counters (euc_sim.rides.source.counters): the running median rises() reads through."""

from __future__ import annotations

import numpy as np
import pandas as pd

from euc_sim.rides.source.counters import _median5


def test_the_running_median_is_pandas_centred_rolling_median_to_the_bit():
    rng = np.random.default_rng(1)
    for n in [*range(1, 12), 100, 1001]:
        for _ in range(10):
            x = np.round(rng.normal(size=n) * rng.lognormal(0.0, 3.0), rng.integers(0, 4))
            ref = pd.Series(x).rolling(5, center=True, min_periods=1).median().to_numpy()
            assert np.array_equal(_median5(x), ref), n

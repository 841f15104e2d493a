"""The riding rows a balance law is read from (euc_sim/rides/grids/law_signals.py): rates and
interval means on uneven time stamps, and the logs that give no rows."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from euc_sim.rides.grids.law_signals import LawUnavailable, _rate, _simpson_weights, law_rows
from euc_sim.rides.source.gaps import GAP_POLICY
from euc_sim.rides.source.logs import Ride


def test_rate_is_the_mean_rate_on_uneven_stamps_and_nan_at_a_gap():
    rng = np.random.default_rng(3)
    t = np.cumsum(rng.uniform(0.1, 0.3, 40))
    t[20:] += 2 * GAP_POLICY.bridge                                   # a gap between rows 19 and 20
    x = 0.7 * t ** 2                                    # d/dt = 1.4 t; central mean rate = 0.7 (t₊₁ + t₋₁)
    d = _rate(x, t)
    inner = np.r_[1:18, 21:39]
    assert np.allclose(d[inner], 0.7 * (t[inner + 1] + t[inner - 1]))
    assert np.isnan(d[[0, 19, 20, 39]]).all()


def test_simpson_weights_average_a_parabola_exactly():
    rng = np.random.default_rng(4)
    t = np.cumsum(rng.uniform(0.05, 0.4, 30))
    x = 2.0 - 3.0 * t + 0.5 * t ** 2
    w = _simpson_weights(t)
    x3 = np.column_stack([np.r_[x[:1], x[:-1]], x, np.r_[x[1:], x[-1:]]])
    lo, hi = t[:-2], t[2:]
    exact = (2.0 * (hi - lo) - 1.5 * (hi ** 2 - lo ** 2) + (hi ** 3 - lo ** 3) / 6) / (hi - lo)
    assert np.allclose(np.sum(w * x3, axis=1)[1:-1], exact)


def _log(cols: dict) -> Ride:
    return Ride(path="synthetic.csv", layout="eucworld", variant="", data=pd.DataFrame(cols),
                   start=pd.Timestamp("2026-01-01"), absent=(), warnings=(), n_rows_read=len(cols["t"]),
                   n_rows_merged=0)


@pytest.mark.parametrize("cols, words", [
    ({"phase_current": 1.0}, "no pitch"),
    ({"tilt": 0.01}, "neither phase current nor motor torque"),
])
def test_a_log_without_pitch_or_torque_gives_no_rows(cols, words):
    t = np.arange(0, 200, 0.2)
    data = {"t": t, "v": np.full_like(t, 5.0)}
    data.update({k: np.full_like(t, v) + 0.001 * np.sin(t) for k, v in cols.items()})
    with pytest.raises(LawUnavailable, match=words):
        law_rows(_log(data))

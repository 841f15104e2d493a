"""The grade the battery-power balance implies (euc_sim.rides.drive.grade), against GPS altitude."""

from __future__ import annotations

import numpy as np
import pytest

from euc_sim.rides.drive.grade import grade_profile
from euc_sim.rides.drive.mass import MassFit
from euc_sim.rides.grids.power import G, PowerSignals, SpeedScale


def _ride(m=110.0, c1=50.0, gap_at=300.0, gps_noise=0.0, seed=0):
    """Two segments on a 10 Hz grid over a hill; battery power = m·a·v + m·g·ḣ + c1·v."""
    rng = np.random.default_rng(seed)
    t = np.arange(0.0, 600.0, 0.1)
    seg = (t >= gap_at).astype(int)
    v = 6.0 + 2.0 * np.sin(2 * np.pi * t / 97.0)
    a = np.gradient(v, t)
    h = 40.0 + 25.0 * np.sin(2 * np.pi * t / 400.0) ** 2          # m
    climb = G * np.gradient(h, t)
    P = m * v * a + m * climb + c1 * v
    sig = PowerSignals(t=t, segment=seg, v=v, a=a, av=v * a, P=P, climb=climb, signed=True,
                       scale=SpeedScale(1.0, 0.01, "gps"), extra={})
    fit = MassFit(estimate=m, ci95=(m - 5, m + 5), coef={"inertia": m, "rolling": c1},
                  coef_ci95={}, terms=["inertia", "rolling"], history=[], lag=0.0,
                  scale=sig.scale, signed=True, n_samples=t.size, unidentified={})
    return sig, fit, t, h + rng.normal(0, gps_noise, t.size)


def test_implied_altitude_follows_the_hill():
    sig, fit, t, h = _ride()
    g = grade_profile(sig, fit, t, h)
    assert g.rms_m < 0.5                                   # the only unexplained power is climbing
    assert g.climb_implied_m == pytest.approx(g.climb_gps_m, rel=0.02)
    assert g.fitted is None                                # the fit kept no grade term
    assert g.distance[-1] == pytest.approx(np.sum(sig.v[1:] * 0.1) / 1000, rel=1e-3)


def test_a_wrong_mass_shows_as_a_drifting_altitude():
    sig, fit, t, h = _ride()
    wrong = MassFit(**{**fit.__dict__, "coef": {"inertia": 110.0, "rolling": 30.0}})
    assert grade_profile(sig, wrong, t, h).rms_m > 10.0   # a missing 20 N reads as a climb


def test_no_altitude_or_no_mass_gives_none():
    sig, fit, t, h = _ride()
    assert grade_profile(sig, fit, t, np.full_like(h, np.nan)) is None
    unknown = MassFit(**{**fit.__dict__, "estimate": None})
    assert grade_profile(sig, unknown, t, h) is None

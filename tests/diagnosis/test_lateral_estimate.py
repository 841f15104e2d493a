"""lateral_dynamics' estimate: √s times the peak tilt over the couplings' bandwidth, and an
interval that carries the choices the recording cannot make."""

import math

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from euc_sim.diagnosis import candidates
from euc_sim.diagnosis.estimates import estimate_of
from euc_sim.diagnosis.prepare import marker_tilt, prepare
from euc_sim.model.parameters import TABLE3
from euc_sim.simulation.effects import band_peak_tilt


def _circling(seed: int = 0):
    """Motion capture of a rider circling at 2 m/s (R 4 m), the EUC tilted 0.1 rad with a
    6 Hz wobble, the rider leaning 0.05 rad more; the angle channel with the paper's 0.5°."""
    p = TABLE3
    rng = np.random.default_rng(seed)
    t = np.arange(0.0, 12.0, 1.0 / 120.0)
    ramp = np.clip(t / 3.0, 0.0, 1.0)
    psi = 0.5 * t * ramp
    theta = -0.1 * ramp + 0.01 * np.sin(2 * np.pi * 6.0 * t)
    gamma = 0.02 * np.sin(2.0 * t)
    phi = 0.03 * np.sin(1.1 * t)
    C = np.column_stack([4.0 * np.sin(psi), 4.0 * (1 - np.cos(psi)), np.full_like(t, p.R)])
    body = Rotation.from_euler("ZXY", np.column_stack([psi, theta, gamma]))
    rider = Rotation.from_euler("ZXY", np.column_stack([psi, theta, phi])) * Rotation.from_euler("X", -0.05 * ramp[:, None])
    G = C + body.apply([0.0, 0.0, -p.l0]) + rider.apply([0.0, 0.0, p.h])
    E = C + body.apply([0.0, 0.0, 0.42])
    cols = {"t": t, "psi": psi, "theta": theta + rng.normal(0, math.radians(0.5), t.size), "gamma": gamma}
    for name, X in (("C", C), ("E", E), ("G", G)):
        cols.update({f"{name}_{a}": X[:, i] + rng.normal(0, 2e-4, t.size) for i, a in enumerate("XYZ")})
    import pandas as pd
    return pd.DataFrame(cols), theta


def test_the_scale_is_the_recorded_tilts_band_peak_and_the_choices_bracket_it():
    df, theta = _circling()
    prep = prepare(df, params=TABLE3, meta={"name": "circle"})
    _, info = candidates.build_problem(prep, 0.6)
    lat = info["lateral_dynamics"]
    dt = 1.0 / 120.0
    assert lat["sqrt"] and lat["scale"] == pytest.approx(band_peak_tilt(df["theta"].to_numpy(), dt))
    assert lat["scale"] == pytest.approx(band_peak_tilt(theta, dt), rel=0.05)       # the true tilt's
    lo, hi = lat["scale_range"]
    assert lo < lat["scale"] < hi
    assert lo > 0.7 * lat["scale"] and hi < 1.3 * lat["scale"]
    mk = band_peak_tilt(marker_tilt(df, np.unwrap(df["psi"].to_numpy())), dt)
    assert lo <= mk <= hi and mk == pytest.approx(band_peak_tilt(theta, dt), rel=0.02)


def test_the_interval_is_the_statistical_one_widened_by_the_scale_range():
    info = {"scale": 0.1, "offset": 0.0, "sqrt": True}
    cov = np.array([[0.05 ** 2]])
    est, ci, se = estimate_of(info, np.array([0.81]), cov, 1000.0)
    wide, ci_w, se_w = estimate_of({**info, "scale_range": [0.09, 0.12]}, np.array([0.81]), cov, 1000.0)
    assert est == wide == pytest.approx(0.09) and se == se_w
    q = 1.96
    assert ci == pytest.approx([0.1 * math.sqrt(0.81 - q * 0.05), 0.1 * math.sqrt(0.81 + q * 0.05)], rel=1e-3)
    assert ci_w == pytest.approx([0.09 * math.sqrt(0.81 - q * 0.05), 0.12 * math.sqrt(0.81 + q * 0.05)], rel=1e-3)

"""The rider's centre of gravity moving: shapes of h(t) and the ḣ forces."""

from __future__ import annotations

import numpy as np
import pytest

from euc_sim.model.parameters import TABLE3
from euc_sim.simulation import drift
from euc_sim.simulation.engine import simulate


@pytest.mark.parametrize("shape", [drift.DriftShape("ramp", 4.0, 3.0, -1.0), drift.DriftShape("dip", 5.0, 4.0, -1.0),
                                   drift.DriftShape("wander", seed=3), drift.DriftShape()])
def test_every_shape_changes_h_by_the_stated_peak_to_peak(shape):
    t = np.linspace(0.0, 15.0, 15001)
    h = drift.cog_height(0.6, 0.2, t, shape)
    assert np.ptp(h) == pytest.approx(0.2, rel=1e-3)
    h_d, h_dd = drift.drift_rates(h, t[1] - t[0])
    assert np.max(np.abs(h_d)) < 0.5 and np.all(np.isfinite(h_dd))     # a physical crouch, smooth


def test_a_ramp_starts_and_ends_where_it_says_and_stays():
    t = np.linspace(0.0, 15.0, 1501)
    h = drift.cog_height(0.6, 0.15, t, drift.DriftShape("ramp", 5.0, 4.0, -1.0))
    assert np.all(h[t <= 5.0] == 0.6)
    assert np.allclose(h[t >= 9.0], 0.45)
    dip = drift.cog_height(0.6, 0.15, t, drift.DriftShape("dip", 5.0, 4.0, -1.0))
    assert dip[np.argmin(np.abs(t - 7.0))] == pytest.approx(0.45) and dip[-1] == pytest.approx(0.6)


def test_parse_drift_shape_and_its_errors():
    assert drift.parse_drift_shape("ramp,start=5,length=4,sign=-1") == drift.DriftShape("ramp", 5.0, 4.0, -1.0)
    with pytest.raises(ValueError, match="kind must be one of"):
        drift.parse_drift_shape("zigzag")
    with pytest.raises(ValueError, match="length must be at least"):
        drift.parse_drift_shape("ramp,length=0.2")
    with pytest.raises(ValueError, match="expected start=, length="):
        drift.parse_drift_shape("ramp,speed=3")


def test_drift_forces_are_the_rheonomic_terms_of_the_point_mass_g():
    """m J_Gᵀ r̈_G (total, h(t) moving) minus its value with h frozen is −Q_drift."""
    p = TABLE3
    t = np.linspace(0.0, 2.0, 20001)
    dt = t[1] - t[0]
    x, gamma, phi = 0.8 * t + 0.1 * np.sin(2 * t), 0.05 * np.sin(3 * t), 0.2 * np.sin(1.7 * t + 0.3)
    h = 0.6 - 0.1 * np.sin(1.3 * t) ** 2
    q = np.column_stack([x, gamma, phi])
    d = lambda a: np.gradient(a, dt, axis=0)      # noqa: E731
    qd, qdd = d(q), d(d(q))
    h_d, h_dd = d(h), d(d(h))
    rG = np.column_stack([x - p.l0 * np.sin(gamma) + h * np.sin(phi), p.R - p.l0 * np.cos(gamma) + h * np.cos(phi)])
    a_total = d(d(rG))
    J = np.zeros((t.size, 2, 3))
    J[:, 0] = np.column_stack([np.ones_like(t), -p.l0 * np.cos(gamma), h * np.cos(phi)])
    J[:, 1] = np.column_stack([np.zeros_like(t), p.l0 * np.sin(gamma), -h * np.sin(phi)])
    # frozen h: r̈ = J q̈ + (J̇ at fixed h) q̇
    Jd = np.zeros_like(J)
    Jd[:, 0] = np.column_stack([np.zeros_like(t), p.l0 * np.sin(gamma) * qd[:, 1], -h * np.sin(phi) * qd[:, 2]])
    Jd[:, 1] = np.column_stack([np.zeros_like(t), p.l0 * np.cos(gamma) * qd[:, 1], -h * np.cos(phi) * qd[:, 2]])
    a_frozen = np.einsum("nij,nj->ni", J, qdd) + np.einsum("nij,nj->ni", Jd, qd)
    lhs = p.m * np.einsum("nij,ni->nj", J, a_total - a_frozen)
    Q = drift.drift_forces(p, q, qd, h, h_d, h_dd)
    s = slice(100, -100)
    np.testing.assert_allclose(-Q[s], lhs[s], atol=2e-3 * np.max(np.abs(Q[s])))
    row = drift.drift_force_row(p.m, p.l0, h[500], h_d[500], h_dd[500], gamma[500], phi[500], qd[500, 2])
    np.testing.assert_allclose(row, Q[500], rtol=1e-12)


@pytest.mark.parametrize("engine", ["analytic", "mujoco"])
def test_a_ramp_drift_is_simulated_with_its_shape(engine):
    shape = drift.DriftShape("ramp", 1.0, 2.0, -1.0)
    run = simulate("stop_and_go", 4.0, effects={"cog_height_drift": 0.2}, drift_shape=shape, engine=engine)
    np.testing.assert_allclose(run.h, drift.cog_height(0.6, 0.2, run.t, shape))
    assert run.h.iloc[-1] == pytest.approx(0.4)


def test_the_dh_terms_change_the_motion_only_while_h_moves():
    """Same ride with a fast dip: the ḣ forces move the rider during the dip (they are
    in the simulation) and the ride is the same before it."""
    shape = drift.DriftShape("dip", 1.5, 1.2, -1.0)
    a = simulate("stop_and_go", 3.0, effects={"cog_height_drift": 0.25}, drift_shape=shape, engine="analytic")
    b = simulate("stop_and_go", 3.0, engine="analytic")
    before = a.t < 1.5
    assert np.max(np.abs(a.phi[before] - b.phi[before])) < 1e-9
    assert np.max(np.abs(a.phi - b.phi)) > 1e-3

"""The bounded fits from Gram matrices (``normal.solve_grams``, ``normal.box_qp``) against scipy:
the same optimum as the trust-region solver from several starts, on random bounded problems."""

from __future__ import annotations

import numpy as np
import pytest

from euc_sim.rides.balance.normal import (bounds, box_qp, coefficients, scale, snap_to_bounds,
                                          solve_gram, solve_grams)

COLUMNS = ["inertia", "rolling", "drag", "copper"]
NAMES = [["rolling_resistance", "aerodynamic_drag", "copper_loss", "drivetrain_idle_loss", "current_lag"],
         ["copper_loss", "rolling_resistance", "current_lag", "aerodynamic_drag"],
         ["rolling_resistance", "drivetrain_idle_loss"], ["current_lag"], []]


def _root(G):
    """S with SᵀS = G (G symmetric positive semi-definite): the residual in few rows."""
    lam, U = np.linalg.eigh(0.5 * (G + G.T))
    return np.sqrt(np.clip(lam, 0.0, None))[:, None] * U.T


def _trf(G, names, x0):
    """scipy's bounded least_squares (trf) on the residual whose Gram matrix is ``G``, from ``x0``."""
    from scipy.optimize import least_squares

    S = _root(G)
    lo, hi = bounds(names)
    inset = 1e-3 * (hi - lo)
    res = least_squares(lambda th: S @ coefficients(COLUMNS, names, th)[0], np.clip(x0, lo + inset, hi - inset),
                        jac=lambda th: S @ coefficients(COLUMNS, names, th)[1], bounds=(lo, hi),
                        x_scale=scale(names), method="trf", xtol=1e-12, ftol=1e-12, gtol=1e-12)
    return snap_to_bounds(res.x, lo, hi, scale(names))


def _cost(G, names, x):
    v, _ = coefficients(COLUMNS, names, x)
    return 0.5 * float(v @ G @ v)


def _rounding(G, names, x):
    """What rounding leaves of a cost summed from terms this large."""
    v, _ = coefficients(COLUMNS, names, x)
    return 1e-12 * float(np.abs(v) @ np.abs(G) @ np.abs(v))


def _problem(rng, names):
    """A Gram matrix whose least-squares optimum has some parameters inside their bounds, some on
    them: the target is the model at random parameters (some beyond the bounds) plus noise."""
    n = 400
    lo, hi = bounds(names)
    theta = lo + (hi - lo) * rng.uniform(-0.3, 1.3, len(names))
    if "current_lag" in names:
        theta[names.index("current_lag")] = rng.uniform(0.0, 0.3)
    Z = np.cumsum(rng.normal(size=(n, 3 * len(COLUMNS) + 2)), axis=0) / 10.0   # smooth, like filtered signals
    Z[:, -2] = 1.0
    scaled = Z[:, :-1] * rng.uniform(0.5, 2.0, Z.shape[1] - 1) * 100.0
    Z[:, :-1] = scaled
    v, _ = coefficients(COLUMNS, names, theta)
    Z[:, -1] = 0.0
    Z[:, -1] = -(Z @ v) + rng.normal(scale=rng.uniform(1.0, 50.0), size=n)
    return Z.T @ Z


@pytest.mark.parametrize("names", NAMES, ids=lambda n: "+".join(n) or "none")
def test_solve_grams_finds_the_least_cost_of_scipy_from_several_starts(names):
    rng = np.random.default_rng(len(names))
    Gs = np.array([_problem(rng, names) for _ in range(8)])
    got = solve_grams(Gs, COLUMNS, names)
    lo, hi = bounds(names)
    for G, x in zip(Gs, got):
        assert np.all((x >= lo) & (x <= hi))
        if not names:
            continue
        starts = [x, lo + 0.5 * (hi - lo), lo] + [lo + (hi - lo) * rng.uniform(size=len(names)) for _ in range(2)]
        ref = min((_trf(G, names, x0) for x0 in starts), key=lambda r: _cost(G, names, r))
        assert _cost(G, names, x) <= _cost(G, names, ref) + _rounding(G, names, x)
        assert np.all(np.abs(x - ref) <= 1e-5 * np.abs(ref) + 1e-6 * scale(names)), (x, ref)
        one = solve_gram(G, COLUMNS, names)
        np.testing.assert_array_equal(one.x, x)
        assert one.cost == pytest.approx(_cost(G, names, x), rel=1e-12)


def test_the_lag_is_not_left_in_a_local_minimum_at_its_bound():
    """A profile cost with a local minimum on the lag's lower bound and a deeper one inside:
    scipy's trf started at zero lag stops on the bound; the fit finds the deeper one."""
    rng = np.random.default_rng(0)
    names = ["rolling_resistance", "aerodynamic_drag", "current_lag"]
    for _ in range(40):
        G = _problem(rng, names)
        stuck = _trf(G, names, np.zeros(3))
        x = solve_grams(G[None], COLUMNS, names)[0]
        if _cost(G, names, x) < _cost(G, names, stuck) - 1e3 * _rounding(G, names, x):
            break
    else:
        pytest.skip("no random problem here with a local minimum")
    assert stuck[2] != pytest.approx(x[2], abs=1e-3)


def test_box_qp_matches_bounded_least_squares():
    from scipy.optimize import lsq_linear

    rng = np.random.default_rng(3)
    for k in (1, 2, 4, 6):
        R = rng.normal(size=(40, 8 * k, k)) * np.logspace(0, 3, k)       # badly scaled columns
        y = rng.normal(size=(40, 8 * k)) * 30.0
        A, b = R.transpose(0, 2, 1) @ R, -np.einsum("nrk,nr->nk", R, y)
        lo, hi = -np.ones(k), np.ones(k)
        x, state = box_qp(A, b, lo, hi)
        for i in range(len(A)):
            ref = lsq_linear(R[i], y[i], bounds=(lo, hi), method="bvls", tol=1e-14).x
            np.testing.assert_allclose(x[i], ref, atol=1e-9)
        np.testing.assert_array_equal(state == -1, x == lo)
        np.testing.assert_array_equal(state == 1, x == hi)

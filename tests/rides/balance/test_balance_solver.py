"""The balance fit's fast path: the filter as a sparse matrix, the analytic Jacobian, and every
fit solved from the Gram matrix of the residual's basis against scipy's least_squares on the rows."""

from __future__ import annotations

import numpy as np
import pytest
from ridesynth import TRUTH, synth_log

from euc_sim.rides.balance.design import BOUNDS, _conv, balance_design, filter_matrices
from euc_sim.rides.balance.fit import _solve, fit_balance
from euc_sim.rides.balance.normal import bounds, coefficients, scale
from euc_sim.rides.grids.signals import ride_signals
from euc_sim.rides.source.logs import read_log


@pytest.fixture(scope="module")
def design(tmp_path_factory):
    path = synth_log(tmp_path_factory.mktemp("solver") / "fit.csv", seed=11)
    return balance_design(ride_signals(read_log(path, emit_warnings=False)))


def test_filter_matrix_is_the_segmentwise_convolution():
    rng = np.random.default_rng(0)
    segment = np.repeat([0, 1, 2, 3], [40, 7, 25, 60])          # segment 1 shorter than the kernel
    kernel = rng.normal(size=9)                                  # not symmetric: order matters
    x = rng.normal(size=segment.size)
    want = _conv(x, segment, kernel)
    rows = np.flatnonzero(np.isfinite(want))
    (K,), support = filter_matrices(segment, [kernel], rows)
    np.testing.assert_allclose(K @ x[support], want[rows], rtol=1e-13, atol=1e-13)
    assert not np.isin(np.flatnonzero(segment == 1), support).any()
    with pytest.raises(ValueError, match="inside their segment"):
        filter_matrices(segment, [kernel], np.array([0]))


def _basis_jacobian(design, names, theta):
    """∂ residual / ∂ parameter, rows × len(names), from the design's basis (what the solver uses)."""
    return design.basis.Z @ coefficients(design.basis.columns, names, theta)[1]


def _finite_differences(design, names, theta, steps):
    out = []
    for j, h in enumerate(steps):
        e = np.zeros_like(theta)
        e[j] = h
        out.append((design.residual(dict(zip(names, theta + e)))
                    - design.residual(dict(zip(names, theta - e)))) / (2 * h))
    return np.array(out).T


def _replicates(design, names, B, seed, scale=1.0):
    fit = fit_balance(design, names, n_boot=0)
    theta = np.array([fit.estimate[k] for k in names])
    fitted = design.predict(fit.estimate)
    rng = np.random.default_rng(seed)
    e = design.P - fitted
    targets = fitted[:, None] + scale * rng.permutation(np.tile(e, (B, 1)).T, axis=0)
    return theta, targets


def _on_rows(design, names, theta, P):
    """scipy's least_squares on the ride's rows (the residual and Jacobian of the design)."""
    from scipy.optimize import least_squares

    lo, hi = bounds(names)
    inset = np.where(np.isfinite(hi - lo), 1e-3 * (hi - lo), 1e-9)
    return least_squares(lambda th: design.residual(dict(zip(names, th)), P),
                         np.clip(theta, lo + inset, hi - inset),
                         jac=lambda th: _basis_jacobian(design, names, th),
                         bounds=(lo, hi), x_scale=scale(names), method="trf")


def _check_against_rows(design, names, theta, targets):
    out = []
    for i in range(targets.shape[1]):
        fit = _solve(design, names, P=targets[:, i])
        ref = _on_rows(design, names, theta, targets[:, i])
        cost = 0.5 * np.sum(design.residual(dict(zip(names, fit.x)), targets[:, i]) ** 2)
        assert cost <= ref.cost * (1 + 1e-8)               # no worse than scipy's own tolerance
        assert fit.cost == pytest.approx(cost, rel=1e-8)
        np.testing.assert_allclose(fit.x, ref.x, rtol=2e-3, atol=1e-3)
        out.append(fit.x)
    return np.array(out)


def test_basis_gives_the_residual_and_its_jacobian(design):
    names = ["copper_loss", "rolling_resistance", "aerodynamic_drag", "drivetrain_idle_loss",
             "current_lag"]
    theta = np.array([0.008, 0.02, 0.3, 15.0, 0.15])
    v, _ = coefficients(design.basis.columns, names, theta)
    r = design.residual(dict(zip(names, theta)))
    J = _basis_jacobian(design, names, theta)
    fd = _finite_differences(design, names, theta, 1e-6 * np.maximum(1.0, np.abs(theta)))
    np.testing.assert_allclose(design.basis.Z @ v, r, rtol=0, atol=1e-9 * np.abs(r).max())
    for j, name in enumerate(names):
        assert np.max(np.abs(fd[:, j] - J[:, j])) <= 1e-6 * np.max(np.abs(J[:, j])), name


def test_gram_solve_agrees_with_least_squares_on_the_rows(design):
    names = ["copper_loss", "rolling_resistance", "aerodynamic_drag", "drivetrain_idle_loss",
             "current_lag"]
    theta, targets = _replicates(design, names, B=6, seed=1)
    _check_against_rows(design, names, theta, targets)


def test_gram_solve_holds_a_bound(design):
    """A ride that asks for more rolling loss than a tyre gives: C_rr sits on its upper bound
    (as with scipy on the rows), snapped onto it."""
    names = ["rolling_resistance", "drivetrain_idle_loss"]
    hi = BOUNDS["rolling_resistance"][1]
    theta, targets = _replicates(design, names, B=4, seed=2)
    heavy = targets + 0.1 * design.operator.K @ design.operator.columns["rolling"][:, None]
    fit = _solve(design, names, P=heavy[:, 0])
    assert fit.x[0] == hi                           # snapped onto the bound, not 1e-30 inside
    batch = _check_against_rows(design, names, fit.x, heavy)
    np.testing.assert_allclose(batch[:, 0], hi, rtol=0, atol=1e-12)


def test_folds_from_grams_match_refits_on_the_rows(design):
    """The held-out score from fold Gram matrices is the refit on each fold's complement."""
    from euc_sim.rides.balance.crossride import HELDOUT_FOLDS, heldout_score
    from euc_sim.stats import time_blocks

    names = ["rolling_resistance", "aerodynamic_drag", "drivetrain_idle_loss"]
    label = time_blocks(design.t, HELDOUT_FOLDS)
    whole = _solve(design, names).x
    err = []
    for b in range(HELDOUT_FOLDS):
        train, test = design.rows(label != b), design.rows(label == b)
        th = _on_rows(train, names, whole, train.P).x
        err.append(test.residual(dict(zip(names, th))))
    want = float(np.sqrt(np.mean(np.concatenate(err) ** 2)))
    assert heldout_score(design, names) == pytest.approx(want, rel=1e-6)


def test_inertia_only_fits_nothing(design):
    """The nominal model has no parameter: its fit is the inertia's power through the filter."""
    fit = fit_balance(design, [], n_boot=20)
    assert fit.names == () and fit.estimate == {}
    want = design.P - design.operator.K @ design.operator.columns["inertia"]
    assert fit.rmse == pytest.approx(float(np.sqrt(np.mean(want ** 2))), rel=1e-12)


def test_bootstrap_interval_covers_truth_and_is_reproducible(design):
    fit = fit_balance(design, n_boot=60, seed=4)
    lo, hi = fit.ci95["aerodynamic_drag"]
    assert lo <= TRUTH["aerodynamic_drag"] <= hi
    assert fit_balance(design, n_boot=60, seed=4).ci95 == fit.ci95

"""The balance fit's fast path: the filter as a sparse matrix, the analytic Jacobian, and the
bootstrap's replicates solved together (Gauss-Newton) against scipy's least_squares one by one."""

from __future__ import annotations

import numpy as np
import pytest
from ridesynth import TRUTH, synth_log

from euc_sim.rides.balance.design import BOUNDS, _conv, balance_design, filter_matrix
from euc_sim.rides.balance.fit import _batch_solve, _solve, fit_balance
from euc_sim.rides.grids.signals import ride_signals


@pytest.fixture(scope="module")
def design(tmp_path_factory):
    path = synth_log(tmp_path_factory.mktemp("solver") / "fit.csv", seed=11)
    return balance_design(ride_signals(path))


def test_filter_matrix_is_the_segmentwise_convolution():
    rng = np.random.default_rng(0)
    segment = np.repeat([0, 1, 2, 3], [40, 7, 25, 60])          # segment 1 shorter than the kernel
    kernel = rng.normal(size=9)                                  # not symmetric: order matters
    x = rng.normal(size=segment.size)
    want = _conv(x, segment, kernel)
    rows = np.flatnonzero(np.isfinite(want))
    K, support = filter_matrix(segment, kernel, rows)
    np.testing.assert_allclose(K @ x[support], want[rows], rtol=1e-13, atol=1e-13)
    assert not np.isin(np.flatnonzero(segment == 1), support).any()
    with pytest.raises(ValueError, match="inside their segment"):
        filter_matrix(segment, kernel, np.array([0]))


def test_jacobian_matches_finite_differences(design):
    names = ["copper_loss", "rolling_resistance", "aerodynamic_drag", "drivetrain_idle_loss",
             "current_lag"]
    theta = np.array([0.008, 0.02, 0.3, 15.0, 0.15])
    J = design.jacobian_many(names, theta[:, None])[:, :, 0]
    for j in range(len(names)):
        h = 1e-6 * max(1.0, abs(theta[j]))
        up, dn = theta.copy(), theta.copy()
        up[j] += h
        dn[j] -= h
        fd = (design.residual(dict(zip(names, up))) - design.residual(dict(zip(names, dn)))) / (2 * h)
        assert np.max(np.abs(fd - J[:, j])) <= 1e-6 * np.max(np.abs(J[:, j])), names[j]


def _replicates(design, names, B, seed, scale=1.0):
    fit = fit_balance(design, names, n_boot=0)
    theta = np.array([fit.estimate[k] for k in names])
    fitted = design.predict(fit.estimate)
    rng = np.random.default_rng(seed)
    e = design.P - fitted
    targets = fitted[:, None] + scale * rng.permutation(np.tile(e, (B, 1)).T, axis=0)
    return theta, targets


def _check_against_scipy(design, names, theta, targets):
    batch, done = _batch_solve(design, names, theta, targets)
    assert done.all()
    for i in range(targets.shape[1]):
        ref = _solve(design, names, theta, P=targets[:, i])
        cost = 0.5 * np.sum(design.residual(dict(zip(names, batch[i])), targets[:, i]) ** 2)
        assert cost <= ref.cost * (1 + 1e-8)               # no worse than scipy's own tolerance
        np.testing.assert_allclose(batch[i], ref.x, rtol=2e-3, atol=1e-3)
    return batch


def test_batch_solve_agrees_with_least_squares(design):
    names = ["copper_loss", "rolling_resistance", "aerodynamic_drag", "drivetrain_idle_loss",
             "current_lag"]
    theta, targets = _replicates(design, names, B=6, seed=1)
    _check_against_scipy(design, names, theta, targets)


def test_batch_solve_holds_a_bound(design):
    """A ride that asks for more rolling loss than a tyre gives: C_rr sits on its upper bound
    (as with scipy), snapped onto it, and the replicates hold it there."""
    names = ["rolling_resistance", "drivetrain_idle_loss"]
    hi = BOUNDS["rolling_resistance"][1]
    theta, targets = _replicates(design, names, B=4, seed=2)
    heavy = targets + 0.1 * design.operator.K @ design.operator.columns["rolling"][:, None]
    fit = _solve(design, names, theta, P=heavy[:, 0])
    assert fit.x[0] > hi - 1e-6
    batch = _check_against_scipy(design, names, fit.x, heavy)
    assert fit.x[0] == hi                           # snapped onto the bound, not 1e-30 inside
    np.testing.assert_allclose(batch[:, 0], hi, rtol=0, atol=1e-12)


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

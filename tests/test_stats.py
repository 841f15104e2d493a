"""The shared resampling statistics (euc_sim.stats): the folds and intervals identification uses."""

from __future__ import annotations

import numpy as np
import pytest

from euc_sim.stats import basic_interval, interleaved_folds, percentile_interval, rms, span_blocks


def test_span_blocks_are_contiguous_and_of_equal_duration():
    t = np.concatenate([np.linspace(0.0, 9.9, 100), np.linspace(10.0, 19.99, 1000)])  # 10 Hz, then 100 Hz
    label = span_blocks(t, 4)
    assert np.all(np.diff(label) >= 0) and set(label) == {0, 1, 2, 3}
    assert np.all(label[t < 4.99] == 0) and np.all(label[t > 15.01] == 3)


def test_interleaved_folds_hold_out_every_sample_once_and_keep_the_guard():
    t = np.arange(0.0, 60.0, 0.1)
    folds = interleaved_folds(t, 5, block=2.0, guard=0.5)
    held = np.concatenate([test for _, test in folds])
    assert np.array_equal(np.sort(held), np.arange(t.size))
    for train, test in folds:
        assert np.intersect1d(train, test).size == 0
        gap = np.min(np.abs(t[train][:, None] - t[test][None, :]))
        assert gap > 0.5 - 1e-9
        # blocks dealt in turn: a fold's held-out rows span the whole record
        assert t[test].min() < 12.0 and t[test].max() > 48.0


def test_the_95_percent_interval_is_the_2_5_and_97_5_percentiles():
    x = np.random.default_rng(3).gamma(2.0, size=401)
    assert np.array_equal(percentile_interval(x), np.percentile(x, [2.5, 97.5]))


def test_the_basic_interval_reflects_a_skewed_spread_about_the_estimate():
    boot = np.random.default_rng(4).gamma(1.5, size=2000)      # long right tail
    lo, hi = basic_interval(boot, 1.0)
    q_lo, q_hi = np.percentile(boot, [2.5, 97.5])
    assert np.isclose(lo, 2.0 - q_hi) and np.isclose(hi, 2.0 - q_lo)
    assert (1.0 - lo) > (hi - 1.0)                              # the long tail now lies below


def test_jackknife_interval_is_the_t_interval_of_the_leave_one_out_spread():
    from scipy.stats import t as student_t

    from euc_sim.stats import jackknife_interval

    loo = np.array([1.0, 1.2, 0.8, 1.1, 0.9])
    se = np.sqrt(4 / 5 * np.sum((loo - loo.mean()) ** 2))
    lo, hi = jackknife_interval(1.0, loo)
    assert hi - 1.0 == pytest.approx(student_t.ppf(0.975, 4) * se, rel=1e-12)
    assert 1.0 - lo == pytest.approx(hi - 1.0, rel=1e-12)
    assert jackknife_interval(1.0, loo[:2]) is None
    assert jackknife_interval(1.0, np.full(4, 2.0)) == (1.0, 1.0)


def test_gram_lstsq_many_is_each_gram_lstsq_to_the_bit():
    from euc_sim.stats import gram_lstsq, gram_lstsq_many

    rng = np.random.default_rng(3)
    for p in (1, 2, 5):
        Z = rng.normal(size=(300, p + 1)) * rng.lognormal(0.0, 3.0, p + 1)
        Z[:, -2] = Z[:, 0] if p > 1 else Z[:, -2]              # rank-deficient: the minimum-norm beta
        G = np.stack([(Z * w[:, None]).T @ Z for w in rng.integers(0, 3, (6, 300)).astype(float)])
        many = gram_lstsq_many(G.reshape(2, 3, p + 1, p + 1))
        assert many.shape == (2, 3, p)
        assert np.array_equal(many.reshape(6, p), np.stack([gram_lstsq(g)[0] for g in G]))


def test_distinct_is_np_unique_in_order_or_not():
    from euc_sim.stats import distinct

    rng = np.random.default_rng(0)
    for a in (np.repeat([0, 0, 3, 7], [5, 1, 4, 2]), rng.integers(0, 9, 50), np.array([], int),
              np.array([2]), np.array([1.5, np.nan, 1.5, np.nan]), np.array([True, False, True])):
        got = distinct(a)
        assert got.dtype == np.unique(a).dtype and np.array_equal(got, np.unique(a), equal_nan=True)


def test_one_blas_thread_holds_blas_to_one_thread_and_gives_the_pool_back():
    from threadpoolctl import threadpool_info

    from euc_sim.stats import one_blas_thread

    blas = lambda: [p["num_threads"] for p in threadpool_info() if p["user_api"] == "blas"]   # noqa: E731
    before = blas()
    with one_blas_thread():
        assert blas() and set(blas()) == {1}
    assert blas() == before


def test_rms_is_over_the_finite_values_and_nan_without_any():
    assert rms(np.array([3.0, -4.0, np.nan, np.inf])) == pytest.approx(np.sqrt(12.5))
    assert np.isnan(rms(np.array([np.nan]))) and np.isnan(rms([]))

"""The parametric noise bootstrap of h (issue 22): noise estimate, replicate curves, the widened interval."""

from __future__ import annotations

import math

import numpy as np
import pytest

import idsim
from euc_sim.identification import noise_bootstrap as nb
from euc_sim.identification.h_fit import (Recording, identify_h, identify_recordings, residual_poly, with_full_block,
                                         with_noise)
from euc_sim.identification.processing import Smoothing, kinematics
from euc_sim.model.parameters import TABLE3


def test_split_noise_recovers_white_noise_sigma():
    dt = 1 / 120
    t = np.arange(0, 15, dt)
    smooth = 0.1 * np.sin(2 * np.pi * 1.0 * t) + 0.05 * np.sin(2 * np.pi * 0.3 * t)
    y = smooth + np.random.default_rng(3).normal(0, 0.0087, t.size)
    base, sigma = nb.split_noise(y, dt)
    assert sigma == pytest.approx(0.0087, rel=0.06)
    # the smooth part follows the 1 Hz motion and keeps little of the noise
    assert np.std((base - smooth)[60:-60]) < 0.5 * 0.0087
    assert nb.split_noise(smooth, dt)[1] < 0.01 * 0.0087          # no noise: (almost) none seen


def test_grid_minimum_finds_the_vertex_on_an_uneven_grid():
    grid = np.array([0.0, 0.1, 0.25, 0.3, 0.7, 1.0])
    J = np.stack([(grid - 0.27) ** 2 + 1, 2 * (grid - 0.62) ** 2])
    assert nb.grid_minimum(grid, J) == pytest.approx([0.27, 0.62], abs=1e-12)


def test_sum_squares_near_has_the_exact_minimiser():
    rp = residual_poly(kinematics(idsim.recording("deceleration", seed=1), TABLE3), TABLE3, "3dof")
    grid = nb.replicate_grid((0.1, 1.5))
    exact = nb.grid_minimum(grid, rp.sum_squares(grid))[0]
    approx = nb.grid_minimum(grid, nb.sum_squares_near(rp, grid, exact + 0.02))[0]
    assert approx == pytest.approx(exact, abs=2e-5)


def _fit(block_ci=(0.595, 0.605)):
    rp = residual_poly(kinematics(idsim.recording("deceleration", seed=1), TABLE3), TABLE3, "3dof")
    f = identify_h([rp], n_boot=100, seed=0)
    import dataclasses
    return dataclasses.replace(f, h_ci95=block_ci, h_ci95_block=block_ci, h=0.6)


def test_with_noise_takes_the_union_and_shifts_by_the_bias():
    f = _fit()
    spread = nb.NoiseSpread(h_smooth=0.6, boot=0.6 - 0.002 + 0.005 * np.array([-1.0, 0.0, 1.0]))
    w = with_noise(f, spread, n_boot=100, block=1.0, blocks=15)
    assert w.noise_sd == pytest.approx(0.005) and w.noise_bias == pytest.approx(-0.002)
    assert w.h_ci95 == pytest.approx((0.6 + 0.002 - 1.96 * 0.005, 0.6 + 0.002 + 1.96 * 0.005))
    assert w.h_ci95_block == (0.595, 0.605)
    wide = _fit((0.55, 0.65))
    assert with_noise(wide, spread, 100, 1.0, 15).h_ci95 == (0.55, 0.65)      # union keeps the wider
    assert with_noise(f, nb.NoiseSpread(0.6, np.array([])), 100, 1.0, 15).h_ci95 == f.h_ci95


def _rec(noise, seed=1):
    df = idsim.recording("deceleration", noise=noise, seed=seed)
    return Recording(name="r", df=df, meta={}, params=TABLE3, kin=kinematics(df, TABLE3, Smoothing()))


def test_replicates_see_the_noise_and_no_more():
    noisy = identify_recordings([_rec("paper")], n_boot=100, n_noise=20, seed=0)["pooled"]["3dof"]
    # 15 s deceleration, paper noise: ĥ scatters by ~5 mm over noise draws (studies/noise_ablation.py)
    assert 0.002 < noisy.noise_sd < 0.012
    assert noisy.h_ci95[0] <= noisy.h_ci95_block[0] and noisy.h_ci95[1] >= noisy.h_ci95_block[1]
    clean = identify_recordings([_rec("none")], n_boot=100, n_noise=20, seed=0)["pooled"]["3dof"]
    assert clean.noise_sd < 1e-4 and abs(clean.noise_bias) < 1e-4
    off = identify_recordings([_rec("paper")], n_boot=100, n_noise=0)["pooled"]["3dof"]
    assert off.h_ci95 == off.h_ci95_block and math.isnan(off.noise_sd)


def test_pooled_replicates_are_seeded_and_pooled():
    recs = [_rec("paper", 1), _rec("paper", 2)]
    a = identify_recordings(recs, n_boot=60, n_noise=10, seed=3)
    b = identify_recordings(recs, n_boot=60, n_noise=10, seed=3)
    assert a["pooled"]["2dof"].h_ci95 == b["pooled"]["2dof"].h_ci95
    # two recordings' worth of noise: the pooled spread is below the single ones'
    single = [f["3dof"].noise_sd for f in a["per_recording"]]
    assert a["pooled"]["3dof"].noise_sd < max(single)


def test_reduced_block_borrows_the_full_models_replicates():
    import dataclasses

    full = _fit()
    offsets = np.linspace(-0.01, 0.02, 101)                     # skewed: the basic interval reflects it
    full = dataclasses.replace(full, boot=0.6 + offsets)
    reduced = dataclasses.replace(full, model="2dof", h=0.65, boot=np.array([0.5, 0.8]))
    r = with_full_block(reduced, full, n_boot=100, block=1.0, blocks=15)
    assert r.boot == pytest.approx(0.65 + offsets)
    q_lo, q_hi = np.percentile(offsets, [2.5, 97.5])
    assert r.h_ci95 == pytest.approx((0.65 - q_hi, 0.65 - q_lo)) and r.h_ci95_block == r.h_ci95
    assert with_full_block(reduced, dataclasses.replace(full, boot=np.array([])), 100, 1.0, 15) is reduced


def test_reduced_block_does_not_resample_the_reductions_misfit():
    # Noise-free: the full model fits exactly, the reduced model leaves the reduction's
    # misfit, which is fixed by the trajectory.  Its own block bootstrap resamples that
    # misfit into an interval ~8 mm wide around its (noise-free, hence exact) h; borrowing
    # the full model's replicates leaves it as narrow as the full model's.
    rec = _rec("none")
    own = identify_h([residual_poly(rec.kin, TABLE3, "2dof")], n_boot=100, seed=0)
    fits = identify_recordings([rec], n_boot=100, n_noise=0, seed=0)["pooled"]
    assert own.h_ci95[1] - own.h_ci95[0] > 0.003
    new = fits["2dof"]
    assert new.h == pytest.approx(own.h) and new.h_ci95[0] <= new.h <= new.h_ci95[1]
    assert new.h_ci95[1] - new.h_ci95[0] < 1e-4
    assert fits["3dof"].h_ci95[1] - fits["3dof"].h_ci95[0] < 1e-4
    # with noise the reduced interval is the full model's, moved to the reduced h
    noisy = identify_recordings([_rec("paper")], n_boot=100, n_noise=0, seed=0)["pooled"]
    w3, w2 = (noisy[m].h_ci95[1] - noisy[m].h_ci95[0] for m in ("3dof", "2dof"))
    assert w2 == pytest.approx(w3, rel=1e-9)

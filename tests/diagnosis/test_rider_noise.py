"""The rider's motor-noise level read from the recorded M_h, the noisy twin that carries it,
and a 3-D ride with an out-of-catalog push still flagged ``unexplained`` (issue 22, item 2)."""

import json
import math
import warnings

import numpy as np
import pandas as pd
import pytest

from euc_sim.controllers.rider import motor_noise
from euc_sim.diagnosis.rider_noise import motor_noise_level, recording_seed


def test_the_level_of_a_pure_ou_noise_sampled_unevenly_is_recovered():
    """OU noise of 2.5 N·m at 1 kHz read at 120 Hz (held, as the recordings hold M_h)."""
    dt, tau = 1e-3, 0.05
    n = motor_noise(60_000, dt, 2.5, tau, seed=11)
    t = np.arange(0.0, 59.9, 1 / 120.0)
    k = np.floor(t / dt + 1e-9).astype(int)
    got = motor_noise_level(k * dt, n[k], tau)
    assert got == pytest.approx(2.5, rel=0.03)
    # a smooth command beside it adds nearly nothing
    assert motor_noise_level(k * dt, n[k] + 40.0 * np.sin(2 * np.pi * 0.4 * t), tau) == pytest.approx(got, rel=0.01)
    assert motor_noise_level(t, 5.0 + 0.0 * t, tau) == 0.0


def test_bad_arguments_are_named():
    with pytest.raises(ValueError, match="tau"):
        motor_noise_level(np.arange(5.0), np.zeros(5), 0.0)
    with pytest.raises(ValueError, match="length"):
        motor_noise_level(np.arange(5.0), np.zeros(4), 0.05)
    assert math.isnan(motor_noise_level(np.arange(2.0), np.zeros(2), 0.05))


@pytest.mark.parametrize("sigma", [0.0, 1.5, 3.0])
def test_the_level_is_recovered_from_a_3d_recording(tmp_path, sigma):
    """A 10 s slalom of the spatial model, the rider's noise known: the level read from its
    M_h within 6 % (+ 0.05 N·m).  Tuning twins (docs/coverage.md): 0.985–1.032 × σ."""
    from euc_sim.simulation.spatial import write_spatial

    path = write_spatial(tmp_path / "s.csv", "slalom", 10.0, seed=4, noise="paper", rider_noise=sigma, speed=1.8)
    df = pd.read_csv(path)
    got = motor_noise_level(df["t"].to_numpy(), df["M_h"].to_numpy(), 0.05)
    assert abs(got - sigma) <= 0.06 * sigma + 0.05


def test_the_noisy_twin_is_deterministic_and_its_draws_differ(tmp_path):
    from euc_sim.diagnosis.lateral_calibration import plan_of, twin_recording
    from euc_sim.diagnosis.prepare import prepare
    from euc_sim.simulation.spatial import write_spatial

    path = write_spatial(tmp_path / "c.csv", "circle", 6.0, seed=2, noise="none", rider_noise=3.0,
                         speed=2.0, radius=4.0)
    prep = prepare(path)
    s0, s1 = recording_seed(prep.raw, 0), recording_seed(prep.raw, 1)
    assert s0 == recording_seed(prepare(path).raw, 0) and s0 != s1
    other = prep.raw.assign(M_h=prep.raw["M_h"] + 1e-6)
    assert recording_seed(other, 0) != s0
    plan = plan_of(prep)
    a, _, _ = twin_recording(prep, plan, 0.6, noise_std=3.0, seed=s0)
    b, _, _ = twin_recording(prep, plan, 0.6, noise_std=3.0, seed=s0)
    c, _, _ = twin_recording(prep, plan, 0.6, noise_std=3.0, seed=s1)
    quiet, _, _ = twin_recording(prep, plan, 0.6)
    pd.testing.assert_frame_equal(a, b)
    assert not np.allclose(a["M_h"], c["M_h"])
    # the twin carries the level it was given, the plain twin none
    assert motor_noise_level(a["t"].to_numpy(), a["M_h"].to_numpy(), 0.05) == pytest.approx(3.0, rel=0.1)
    assert motor_noise_level(quiet["t"].to_numpy(), quiet["M_h"].to_numpy(), 0.05) < 0.05


def test_a_3d_ride_with_an_out_of_catalog_push_is_still_unexplained(tmp_path):
    """A noisy rider (3 N·m, no sensor noise) on a 12 s circle pushed at G by 5 N at 0.5 Hz:
    the twin carries his noise, and the push is still flagged (measured on 20 s: held-out
    4.8× the floor, generic gain 0.83); without the push nothing is flagged (0.56×)."""
    from euc_sim.diagnosis.pipeline import diagnose
    from euc_sim.simulation.effects import PeriodicPush
    from euc_sim.simulation.spatial import write_spatial

    path = write_spatial(tmp_path / "p.csv", "circle", 12.0, seed=5, noise="none", rider_noise=3.0,
                         speed=2.0, radius=4.0, external_force=PeriodicPush(5.0, 0.5))
    assert json.loads((tmp_path / "p.truth.json").read_text())["out_of_catalog"]["amplitude_N"] == 5.0
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        res = diagnose(path, resimulate=False)
    assert res["unexplained"] is True
    lc = res["lateral_calibration"]
    assert lc["done"] and lc["rider_noise"]["level"] == pytest.approx(3.0, rel=0.1)
    noisy = lc["rider_noise"]["heldout"]
    assert len(noisy) >= 1 and lc["unexplained_floor"] == pytest.approx(
        math.hypot(lc["noise_floor"], math.sqrt(np.mean(np.square(noisy)))))

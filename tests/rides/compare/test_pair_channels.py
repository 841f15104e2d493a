"""The pair fit's other channels (voltage sag, phase current, duty) beside battery power.

A twin pair whose battery power is too noisy to name a +40 kg mass: the phase
current (the motor's torque, read through the constants fitted on LOG) names
it; the same pair without a difference names nothing.
"""

from __future__ import annotations

import numpy as np
import pytest
from drivesynth import DRIVE, drive_log

from euc_sim.rides.compare.channels import CHANNELS, whitening
from euc_sim.rides.compare.differences_report import pair_differences
from euc_sim.report.ride.contract import differences_json
from euc_sim.rides.drive.drivetrain_report import ride_drivetrain
from euc_sim.rides.source.logs import read_log

#: Battery power noise of the twin pairs, W (AR(1), 0.3 s): a logger whose current reads coarsely.
NOISY = 600.0


def _pair(tmp_path, dm: float) -> tuple:
    a = drive_log(tmp_path / "a.csv", seed=5, duration=900.0, noise_w=NOISY, signed_phase=True)
    b = drive_log(tmp_path / "b.csv", seed=6, duration=900.0, noise_w=NOISY, signed_phase=True,
                  truth={**DRIVE, "mass": DRIVE["mass"] + dm})
    log, other = read_log(a, emit_warnings=False), read_log(b, emit_warnings=False)
    return (log, other, ride_drivetrain(log, other, n_boot=20))


def _differences(pair, **kw) -> dict:
    log, other, physics = pair
    return {d["name"]: d for d in differences_json(pair_differences(physics, log, other, n_boot=50, **kw))["differences"]}


@pytest.fixture(scope="module")
def heavier(tmp_path_factory):
    return _pair(tmp_path_factory.mktemp("heavier"), 40.0)


def test_a_mass_lost_in_battery_power_is_named_with_the_phase_current(heavier):
    power = _differences(heavier)["total_mass"]
    every = _differences(heavier, channels=CHANNELS)["total_mass"]
    assert not power["named"]
    assert every["named"], every["why"]
    lo, hi = every["ci95"]
    assert lo <= 40.0 <= hi or abs(every["estimate"] - 40.0) < 0.1 * 40.0
    assert every["resolvable"] < 0.7 * power["resolvable"]


def test_a_pair_without_a_difference_names_nothing_with_every_channel(tmp_path):
    by = _differences(_pair(tmp_path, 0.0), channels=CHANNELS)
    assert [n for n, d in by.items() if d["named"]] == []


def test_the_whitening_counts_a_shared_noise_once():
    """Two channels of one model reading one noise (the second with its own on top): whitened, their
    residuals have unit variance and no correlation."""
    rng = np.random.default_rng(0)
    t = np.arange(4000.0)
    x = rng.standard_normal(len(t))
    common, own = rng.standard_normal(len(t)), rng.standard_normal(len(t))
    Z = np.stack([np.column_stack([x, 2 * x + 3 * common]), np.column_stack([x, 2 * x + 3 * common + 0.5 * own])])
    W = whitening(t, Z)
    E = Z[:, :, 1] - 2 * x
    assert np.allclose(np.cov(W @ E), np.eye(2), atol=0.1)

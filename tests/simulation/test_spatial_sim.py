"""The spatial closed loop: straight running reproduces the planar model; the lateral
rider's design; paths; recordings for the Section 2 pipeline."""

import numpy as np
import pytest

from euc_sim.model.spatial import TyreContact
from euc_sim.simulation.engine import simulate
from euc_sim.simulation.errors import SimulationError
from euc_sim.simulation.maneuvers import make_maneuver
from euc_sim.simulation.spatial import PATHS, make_path, simulate_3d, spatial_recording

MAN = make_maneuver("deceleration", v0=4.0, v1=1.0, start=0.5, ramp=2.0)


@pytest.fixture(scope="module")
def planar():
    return simulate(MAN, 3.0)


def _gap(run, ref):
    return {c: float(np.max(np.abs(run[c].to_numpy() - ref[c].to_numpy())))
            for c in ("x", "gamma", "phi", "x_dot")}


def test_straight_deceleration_reproduces_the_planar_model(planar):
    """3-D deceleration (no lateral input) against euc_planar.xml's pure rolling.

    Both with RK4 at 1 ms.  Tolerance at contact timeconst 2 ms: 2 mm in x, 2.5 mm/s
    in speed, 0.2 mrad in γ, 0.4 mrad in φ over 3 s (measured 1.05 mm, 1.47 mm/s,
    0.076 and 0.20 mrad; at 8 ms 1.67 mm, 2.33 mm/s, 0.12 and 0.32 mrad): the gap is
    the soft contact's sinkage and creep, and it shrinks as the contact stiffens.
    (With the run's default ``implicitfast`` the gap is about 6 mm: the integrator's.)
    """
    soft = _gap(simulate_3d("straight", 3.0, maneuver=MAN, speed=4.0, integrator="RK4",
                            tyre=TyreContact(timeconst=0.008)), planar)
    stiff_run = simulate_3d("straight", 3.0, maneuver=MAN, speed=4.0, integrator="RK4",
                            tyre=TyreContact(timeconst=0.002))
    stiff = _gap(stiff_run, planar)
    assert stiff["x"] < 2e-3 and stiff["x_dot"] < 2.5e-3
    assert stiff["gamma"] < 2e-4 and stiff["phi"] < 4e-4
    assert all(stiff[c] < soft[c] for c in stiff)
    assert np.max(np.abs(stiff_run["theta"])) < 1e-9 and np.max(np.abs(stiff_run["e_y"])) < 1e-9


def test_lateral_design_is_stabilising_with_a_delay_margin():
    from euc_sim.controllers.lateral import design_lateral, lateral_plant

    lat = design_lateral(speed=2.5)
    Phi, Gam = lateral_plant(speed=2.5)
    assert np.max(np.abs(np.linalg.eigvals(Phi))) > 1.0               # open loop falls over
    assert np.max(np.abs(np.linalg.eigvals(Phi - Gam @ lat.K))) < 1.0
    assert lat.delay_margin > 0.0


def test_paths_have_the_stated_geometry():
    circle = make_path("circle", 40.0)
    tail = circle.s > 6.0
    assert np.allclose(circle.kappa[tail], 1 / 4.0)
    u = make_path("u_turn", 30.0)
    assert u.heading[-1] == pytest.approx(np.pi, abs=0.01 / 4.0)   # one 1 cm sample of κ = 1/4 m⁻¹
    lap = 2 * np.pi * 4.0
    eight = make_path("figure_eight", 2 + 2 * lap)
    mid1, mid2 = (np.searchsorted(eight.s, 2 + f * lap) for f in (0.5, 1.5))
    assert eight.kappa[mid1] == pytest.approx(1 / 4.0) and eight.kappa[mid2] == pytest.approx(-1 / 4.0)
    # the left lap undone by the right, to one 1 cm sample of κ = 1/4 m⁻¹ at either end
    assert eight.heading[mid2] == pytest.approx(eight.heading[mid1], abs=2 * 0.01 / 4.0)
    with pytest.raises(SimulationError, match="unknown path 'loop'"):
        make_path("loop", 10.0)
    assert set(PATHS) >= {"circle", "u_turn", "slalom", "figure_eight"}


def test_recording_carries_mocap_columns_for_section_2():
    run = simulate_3d("straight", 1.0, speed=3.0)
    rec = spatial_recording(run, noise="paper", seed=3)
    assert {"t", "psi", "theta", "gamma", "C_X", "E_Z", "G_Y", "M_d", "M_h"} <= set(rec.columns)
    assert "phi" not in rec.columns and "x" not in rec.columns
    assert len(rec) == 121
    again = spatial_recording(run, noise="paper", seed=3)
    assert rec.equals(again)


def test_bad_requests_are_named():
    with pytest.raises(SimulationError, match="duration"):
        simulate_3d("straight", -1.0)
    with pytest.raises(SimulationError, match="speed"):
        simulate_3d("straight", 1.0, speed=20.0)


def test_spatial_rides_are_drawn_from_the_seed_within_what_the_rider_follows():
    from euc_sim.simulation.spatial import (RIDEABLE_LATERAL_ACCEL, RIDEABLE_RADII, RIDEABLE_SPEEDS,
                                            TURNING_PATHS, draw_spatial_ride)
    rng_a, rng_b = np.random.default_rng(5), np.random.default_rng(5)
    a = [draw_spatial_ride(j, rng_a) for j in range(40)]
    assert a == [draw_spatial_ride(j, rng_b) for j in range(40)]
    assert [r["path"] for r in a] == [TURNING_PATHS[j % 4] for j in range(40)]
    assert all(RIDEABLE_SPEEDS[0] <= r["speed"] <= RIDEABLE_SPEEDS[1] for r in a)
    turns = [r for r in a if r["path"] != "slalom"]
    assert all(r["radius"] is None for r in a if r["path"] == "slalom")
    assert all(RIDEABLE_RADII[0] <= r["radius"] <= RIDEABLE_RADII[1] for r in turns)
    assert all(r["speed"] ** 2 / r["radius"] <= RIDEABLE_LATERAL_ACCEL[r["path"]] + 1e-3 for r in turns)
    assert len({r["radius"] for r in turns}) > 0.9 * len(turns)   # drawn, not fixed


def test_the_lateral_predictor_restores_the_undelayed_loop():
    """With the reaction delay predicted on the design plant, the sampled loop has the
    undelayed closed loop's poles (and zeros for the delay line); an extra
    unpredicted delay beyond the margin destabilises it."""
    from euc_sim.controllers.lateral import delayed_loop, design_lateral, lateral_plant, lateral_predictor_rows

    Phi, Gam = lateral_plant(speed=2.0)
    lat = design_lateral(speed=2.0)
    block = 10
    Pb = np.linalg.matrix_power(Phi, block)
    Gb = sum(np.linalg.matrix_power(Phi, i) for i in range(block)) @ Gam
    rho0 = np.max(np.abs(np.linalg.eigvals(Pb - Gb @ lat.K)))
    for S in (3, 8):
        K_pred, K_hist = lateral_predictor_rows(Pb, Gb, lat.K, S)
        rho = np.max(np.abs(np.linalg.eigvals(delayed_loop(Pb, Gb, K_pred, K_hist, S, 0))))
        assert rho == pytest.approx(rho0, abs=1e-6)
        assert np.max(np.abs(np.linalg.eigvals(delayed_loop(Pb, Gb, K_pred, K_hist, S, 10)))) > 1.0
    with pytest.raises(ValueError, match="lateral reaction delay"):
        design_lateral(speed=2.0, delay=-0.1)


def test_a_delayed_lateral_rider_with_predictor_rides_a_circle():
    run = simulate_3d("circle", 4.0, lateral_delay=0.05)
    assert run.attrs["lateral"]["delay"] == pytest.approx(0.05)
    assert np.max(np.abs(run["e_y"])) < 0.6
    with pytest.raises(SimulationError, match="turn radius"):
        make_path("circle", 10.0, radius=0.5)


def test_the_truth_file_holds_the_peak_tilt_of_the_couplings_band(tmp_path):
    import json

    from euc_sim.simulation.effects import band_peak_tilt
    from euc_sim.simulation.spatial import write_spatial
    path = write_spatial(tmp_path / "c.csv", "circle", 3.0, seed=2, speed=1.8)
    truth = json.loads((tmp_path / "c.truth.json").read_text())
    run = simulate_3d("circle", 3.0, speed=1.8, seed=2)
    assert path.exists()
    assert truth["peak_tilt_rad"] == pytest.approx(band_peak_tilt(run["theta"].to_numpy(), 1e-3), rel=1e-9)
    assert truth["peak_tilt_rad"] <= truth["peak_tilt_raw_rad"] == pytest.approx(np.max(np.abs(run["theta"])))

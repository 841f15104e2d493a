"""Experiment design for the catalog effects: Monte Carlo beside the diagnosis's covariance."""

from __future__ import annotations

import pytest

from euc_sim.diagnosis.design import effects_design, nominal_magnitude, parse_effects
from euc_sim.model.parameters import TABLE3


@pytest.fixture(scope="module")
def result():
    return effects_design(["constant_speed", "stop_and_go"], ["road_slope", "sensor_time_offset", "rider_mass"],
                          rides=6, duration=8.0, workers=1, progress=False, seed=2)


def test_covariance_prediction_tracks_the_monte_carlo(result):
    """The diagnosis's standard error predicts the spread of its estimates.  An sd from
    6 rides is itself uncertain (a 99.9 % range of 0.2-2.0 times the true one), so the
    cells are pooled: the geometric mean of sd_cov / sd over the 4 cells (20 degrees of
    freedom) within a factor 2, each cell within a factor 6.  (With 20 rides per cell
    the ratio is 0.84-1.54 on both maneuvers for drag, slope and time offset.)"""
    import numpy as np

    logs = []
    for m, cells in result["by_maneuver"].items():
        for e, c in cells.items():
            assert c["rides"] == 6 and c["sd"] > 0 and c["sd_cov"] > 0, (m, e)
            ratio = c["sd_cov"] / c["sd"]
            assert ratio > 1 / 6 and ratio < 6, (m, e, c)
            assert abs(c["bias"]) < 4 * c["sd_cov"] + 0.2 * result["effects"][e]["magnitude"], (m, e, c)
            logs.append(np.log(c["sd_cov"] / c["sd"]))
    assert len(logs) == 4 and 0.5 < float(np.exp(np.mean(logs))) < 2.0, logs


def test_speed_changes_time_the_rider_channel_better_than_constant_speed(result):
    """A time offset shows where φ changes: stop-and-go measures it more precisely."""
    by = result["by_maneuver"]
    assert by["stop_and_go"]["sensor_time_offset"]["sd"] < by["constant_speed"]["sensor_time_offset"]["sd"]
    assert result["best"]["sensor_time_offset"] == "stop_and_go"


def test_invisible_effects_are_named_with_the_reason(result):
    mass = result["effects"]["rider_mass"]
    assert not mass["visible"] and "needs column(s) M_d" in mass["reason"]
    assert all("rider_mass" not in cells for cells in result["by_maneuver"].values())
    assert mass["nominal"] == pytest.approx(TABLE3.m + (10.0 * 30.0) ** 0.5)


def test_same_seed_same_figures():
    a = effects_design(["stop_and_go"], ["road_slope"], rides=3, duration=6.0, workers=1, progress=False, seed=5)
    b = effects_design(["stop_and_go"], ["road_slope"], rides=3, duration=6.0, workers=1, progress=False, seed=5)
    assert a == b


def test_nominal_magnitudes_sit_in_the_plausible_range():
    assert nominal_magnitude("aerodynamic_drag") == pytest.approx((0.15 * 0.6) ** 0.5)
    assert 0.01 < nominal_magnitude("road_slope") < 0.06


@pytest.mark.parametrize("text, message", [
    ("drag", "--effect: unknown drag; valid: all, rolling_resistance"),
    ("road_slope,road_slope", "--effect: an effect is listed twice"),
    ("", "--effect: unknown (none given)"),
])
def test_parse_effects_names_the_option(text, message):
    with pytest.raises(ValueError, match=message.replace("(", r"\(").replace(")", r"\)")):
        parse_effects(text)
    assert parse_effects("all")[0] == "rolling_resistance"

"""The many-rides page's tiles (euc_sim.report.ride.history_page)."""

from __future__ import annotations

from euc_sim.report.ride.history_page import _key_figures
from tests.rides.typed_ride import history_of, ride_entry_of


def _history(speeds_kmh, slope, ci):
    rides = [ride_entry_of(f"/x/{i}.csv", f"2025-07-{10 + i}T08:00",
                           summary_fields={"distance_m": 10000.0, "energy_drawn_Wh": 400.0,
                                           "speed_mean_moving_mps": v / 3.6})
             for i, v in enumerate(speeds_kmh)]
    return history_of(rides, whkm_slope=slope, whkm_slope_ci95=tuple(ci))


def test_a_consumption_trend_the_rides_cannot_show_is_not_a_headline_number():
    """Blitz's three rides (average speeds 40.5-41.5 km/h) gave 'Consumption per 10 km/h faster
    -17.7 Wh/km, 95 % [-643.6, +608.2]'."""
    flat = {k.label: k for k in _key_figures(_history([40.5, 40.8, 41.5], -6.37, [-231.7, 218.95]))}
    tile = flat["Consumption per 10 km/h faster"]
    assert tile.value == "no trend shown"
    assert tile.note == "the rides' average speeds span 1.0 km/h; 95 % [-644, +608] Wh/km"
    steep = {k.label: k for k in _key_figures(_history([20.0, 30.0, 40.0], 0.18, [0.09, 0.27]))}
    assert steep["Consumption per 10 km/h faster"].value == "+0.5 Wh/km"

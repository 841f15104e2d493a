"""What the ride's page draws over time: the log's curves on the ride's grid, in people's units.

:class:`RideSeries` is built once from the grid the balance fit parsed and shared by every page
figure (:mod:`euc_sim.report.ride.page_html`, :mod:`euc_sim.report.ride.limits_page`).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Mapping

import numpy as np

from euc_sim.rides.source.gaps import GAP_POLICY

__all__ = ["RideSeries", "MOST_POINTS", "number", "max_pwm_mark"]

#: Most points per trace on the page (the page stays a few MB on an hour's ride).
MOST_POINTS = 6000


@dataclass(frozen=True)
class RideSeries:
    """What the page draws over time: the ride command's parsed log on its grid.

    Attributes
    ----------
    t : numpy.ndarray
        s from the log's start.
    gap_s : float
        A jump in ``t`` longer than this, s, is a gap (lines break there).
    channels : dict
        ``speed_kmh``, ``power_W``, ``pwm_pct``, ``voltage_V``, ``current_A``,
        ``temperature_C``, ``charge_pct`` (the battery reading), ``lat``, ``lon`` (deg),
        each present when logged.
    """

    t: np.ndarray
    gap_s: float
    channels: Mapping[str, np.ndarray]

    @classmethod
    def from_frame(cls, raw, rate: float) -> "RideSeries":
        """From :class:`euc_sim.rides.grids.signals.RideSignals`'s ``raw`` grid (``rate`` Hz)."""
        names = {"v": ("speed_kmh", 3.6), "P": ("power_W", 1.0), "pwm": ("pwm_pct", 1.0),
                 "voltage": ("voltage_V", 1.0), "current": ("current_A", 1.0),
                 "temperature": ("temperature_C", 1.0), "battery": ("charge_pct", 1.0),
                 "latitude": ("lat", 1.0),
                 "longitude": ("lon", 1.0)}
        ch = {}
        for col, (name, k) in names.items():
            if col in raw and np.isfinite(raw[col].to_numpy(float)).any():
                ch[name] = raw[col].to_numpy(float) * k
        return cls(t=raw["t"].to_numpy(float), gap_s=GAP_POLICY.plot_steps / rate, channels=ch)

    def at(self, name: str, t: float) -> float | None:
        """The channel at time ``t`` (s), nearest grid row; None when not logged."""
        y = self.channels.get(name)
        if y is None or self.t.size == 0:
            return None
        v = float(y[int(np.argmin(np.abs(self.t - t)))])
        return v if np.isfinite(v) else None


def number(x) -> float | None:
    """``x`` as a finite float, None where it is None or not a finite number."""
    return float(x) if isinstance(x, (int, float, np.integer, np.floating)) and np.isfinite(x) else None


def max_pwm_mark(s, series: RideSeries):
    """(t s, lat, lon) of the :class:`~euc_sim.rides.summary.summary.RideSummary` ``s``'s max PWM,
    lat/lon None without GPS; None without it."""
    at = number(s.pwm_max_at_s)
    if at is None:
        return None
    place = s.pwm_max_place or {}
    if number(place.get("lat")) is not None and number(place.get("lon")) is not None:
        return at, place["lat"], place["lon"]
    return at, series.at("lat", at), series.at("lon", at)

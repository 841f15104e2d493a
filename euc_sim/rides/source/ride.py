"""A ride log read once: its columns in SI units, its data-quality facts, the app's own
counters, and the grids built on it (:meth:`Ride.derived`, each built once per log).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import cached_property
from pathlib import Path
from typing import Mapping

import numpy as np
import pandas as pd

from euc_sim.io import to_jsonable
from euc_sim.rides.source.counters import LogCounters
from euc_sim.rides.source.gaps import GAP_POLICY

__all__ = ["Ride", "RideQuality", "CHANNEL_UNITS"]

#: Canonical channel -> SI unit (in :attr:`Ride.data`).
CHANNEL_UNITS: dict[str, str] = {
    "t": "s", "v": "m/s", "voltage": "V", "current": "A", "power": "W",
    "phase_current": "A", "torque": "N·m (as the wheel reports it; unverified)",
    "pwm": "%", "safety_margin": "%", "battery": "%", "distance": "m", "total_distance": "m",
    "temperature": "°C", "temperature2": "°C", "tilt": "rad", "roll": "rad",
    "latitude": "deg", "longitude": "deg", "gps_speed": "m/s", "gps_alt": "m",
    "gps_heading": "rad", "gps_distance": "m",
}


@dataclass(frozen=True)
class RideQuality:
    """What the log says about its own data: ``duration_s`` (s), ``rate_hz`` (median, Hz),
    ``gaps`` (``(t, length)`` s of each interval splitting the ride), ``zero_channels``
    (absent, zero or empty), ``notes`` (what the reader handled).
    """

    duration_s: float
    rate_hz: float
    gaps: tuple
    zero_channels: tuple
    notes: tuple


@dataclass(frozen=True, eq=False)
class Ride:
    """One ride log, parsed once, in SI units.

    Attributes
    ----------
    path, layout : str
        The file read; ``"wheellog"``, ``"eucworld"`` or ``"darknessbot"``.
    variant : str
        WheelLog ``"old"`` / ``"new"`` (GPS or phase-current columns), else ``""``.
    data : pandas.DataFrame
        One row per distinct time stamp, sorted: ``t`` (s from the first sample), ``v``
        (m/s) and the optional channels present (:data:`CHANNEL_UNITS`); empty cells NaN.
    start : pandas.Timestamp
        Wall-clock time of ``t = 0``, naive: UTC where the stamps carry a zone, else the
        phone's local time.
    absent : tuple of str
        Channels the file lacks, or has only as zeros or empty cells.
    warnings, repairs : tuple of str
        Every problem handled; those that changed the data.
    n_rows_read, n_rows_merged : int
        Data rows in the file; rows removed by averaging repeated stamps.
    counters : LogCounters
        The app's alarm flags and trip counters.
    utc_offset_s : float or None
        The first stamp's zone, s east of UTC, where the stamps carry one.
    """

    path: str
    layout: str
    variant: str
    data: pd.DataFrame = field(repr=False)
    start: pd.Timestamp
    absent: tuple[str, ...]
    warnings: tuple[str, ...] = field(repr=False)
    n_rows_read: int
    n_rows_merged: int
    units: Mapping[str, str] = field(default_factory=lambda: dict(CHANNEL_UNITS), repr=False)
    repairs: tuple[str, ...] = field(default=(), repr=False)
    counters: LogCounters = field(default_factory=LogCounters, repr=False)
    utc_offset_s: float | None = None
    _grids: dict = field(default_factory=dict, init=False, repr=False)

    def has(self, channel: str) -> bool:
        """True when ``channel`` is in :attr:`data` (present and not all zero)."""
        return channel in self.data.columns

    @property
    def name(self) -> str:
        """The file name (outputs never carry a machine path)."""
        return Path(self.path).name

    @property
    def duration(self) -> float:
        """Time from the first to the last sample, s."""
        return float(self.data["t"].iloc[-1]) if len(self.data) else 0.0

    @cached_property
    def quality(self) -> RideQuality:
        """The data-quality facts, gaps as :data:`~euc_sim.rides.source.gaps.GAP_POLICY` splits them."""
        t = self.data["t"].to_numpy(float)
        dt = np.diff(t)
        long = np.flatnonzero(GAP_POLICY.splits(dt))
        rate = float(1.0 / np.median(dt)) if dt.size and np.median(dt) > 0 else float("nan")
        return RideQuality(duration_s=float(t[-1] - t[0]) if t.size else 0.0, rate_hz=rate,
                           gaps=tuple((float(t[i]), float(dt[i])) for i in long),
                           zero_channels=tuple(self.absent), notes=tuple(self.warnings))

    def derived(self, key: tuple, build):
        """What ``build()`` returns, built the first time ``key`` is asked for and kept; do not modify it."""
        if key not in self._grids:
            self._grids[key] = build()
        return self._grids[key]

    def to_json(self) -> dict:
        """``path``, ``layout``, ``rows``, ``duration_s``, ``channels``, ``absent``, ``warnings``."""
        return to_jsonable({"path": self.path, "layout": self.layout, "rows": int(len(self.data)),
                            "duration_s": self.duration, "channels": list(self.data.columns),
                            "absent": list(self.absent), "warnings": list(self.warnings)})

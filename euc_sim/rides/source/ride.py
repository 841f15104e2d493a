"""A ride log read once: its columns in SI units, what the reader did, the app's own
counters, and the grids built on it (:meth:`Ride.derived`, each built once per log).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import pandas as pd

from euc_sim.rides.source.counters import LogCounters

__all__ = ["Ride", "CHANNEL_UNITS"]

#: Canonical channel -> SI unit (in :attr:`Ride.data`).
CHANNEL_UNITS: dict[str, str] = {
    "t": "s", "v": "m/s", "voltage": "V", "current": "A", "power": "W",
    "phase_current": "A", "torque": "N·m (as the wheel reports it; unverified)",
    "pwm": "%", "safety_margin": "%", "battery": "%", "distance": "m", "total_distance": "m",
    "temperature": "°C", "temperature2": "°C", "tilt": "rad", "roll": "rad",
    "latitude": "deg", "longitude": "deg", "gps_speed": "m/s", "gps_alt": "m",
    "gps_heading": "rad", "gps_distance": "m",
}


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

    def derived(self, key: tuple, build):
        """What ``build()`` returns, built the first time ``key`` is asked for and kept; do not modify it."""
        if key not in self._grids:
            self._grids[key] = build()
        return self._grids[key]

"""A ride log read once: its columns in SI units, its data-quality facts, the app's own
counters, and the grids built on it.

:func:`euc_sim.rides.source.logs.read_log` builds the one :class:`Ride` of a file; every
analysis, the summary and the API take the ride and none reads the file again.  The
grid of a ride (:func:`euc_sim.rides.grids.signals.ride_grid`) and the filtered signals
built on it are kept on the ride (:meth:`Ride.derived`): one run builds each once per log.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import cached_property
from pathlib import Path
from typing import Mapping

import numpy as np
import pandas as pd

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
    """What the log says about its own data.

    Attributes
    ----------
    duration_s : float
        First to last sample, s.
    rate_hz : float
        Median sampling rate, Hz.
    gaps : tuple of (float, float)
        ``(t, length)`` of every interval that splits the ride (longer than
        :attr:`~euc_sim.rides.source.gaps.GapPolicy.bridge`), s.
    zero_channels : tuple of str
        Channels absent, or present only as zeros or empty cells.
    notes : tuple of str
        What the reader handled (merged stamps, sorting, units suspected).
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
    path : str
        The file read.
    layout : str
        ``"wheellog"``, ``"eucworld"`` or ``"darknessbot"``; :attr:`variant` tells
        the WheelLog layouts apart.
    variant : str
        ``"old"`` / ``"new"`` for WheelLog (``"new"`` when GPS or phase-current
        columns are present), else ``""``.
    data : pandas.DataFrame
        One row per distinct time stamp, sorted, columns ``t`` (s from the first
        sample), ``v`` (wheel speed, m/s) and whichever optional channels are
        present (units in :attr:`units`); empty GPS cells are NaN.
    start : pandas.Timestamp
        Wall-clock time of ``t = 0``, naive: UTC where the log's stamps carry their zone
        (EUC World), else the phone's local time (WheelLog, DarknessBot).
    absent : tuple of str
        Canonical channels the file lacks, or has only as zeros or empty cells.
    warnings : tuple of str
        One line per problem handled.
    n_rows_read : int
        Data rows in the file.
    n_rows_merged : int
        Rows removed by averaging repeated time stamps.
    units : mapping
        Channel -> SI unit (:data:`CHANNEL_UNITS`).
    repairs : tuple of str
        The warnings that changed the data (rows merged, sorted, dropped, cells emptied,
        signs turned back), one line each.
    counters : LogCounters
        The app's alarm flags and own trip counters (:mod:`euc_sim.rides.source.counters`).
    utc_offset_s : float or None
        The zone of the log's first stamp, s east of UTC, where its stamps carry one; None
        where they do not (then :attr:`start` is the phone's local clock, its zone unknown).
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
        """What ``build()`` returns, built the first time ``key`` is asked for and kept.

        The grids and filtered signals of this ride are keyed by their kind and settings;
        callers must not modify what they get.
        """
        if key not in self._grids:
            self._grids[key] = build()
        return self._grids[key]

"""A ride log read once: its parsed columns with units, its data-quality facts, its grids.

:func:`read_ride` parses a log (:func:`euc_sim.rides.logs.read_log`) exactly once
into a :class:`Ride`; every analysis of ``euc-sim ride`` takes the ride (or its
``log``, a :class:`~euc_sim.rides.logs.RideLog`, which every reader of a path
also accepts) and none reads the file again.

Gap policy (one rule, two grids)
--------------------------------
Every grid is a uniform resampling of :attr:`Ride.log`'s rows: an interval up to
the grid's ``max_gap`` is bridged by linear interpolation, a longer one splits
the ride into pieces that no filter crosses.  The balance fit's grid
(:func:`euc_sim.rides.signals.ride_signals`, 10 Hz) bridges up to 1.0 s; the
mass and drivetrain grid (:func:`euc_sim.rides.power.power_signals`, 10 Hz)
up to :attr:`euc_sim.rides.power.MassSettings.max_gap` (2.5 s), because its
energy windows integrate across a short dropout where the balance's derivative
filter would not.  Both are listed in the ride's notes.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from euc_sim.rides.logs import RideLog, read_log

__all__ = ["Ride", "RideQuality", "read_ride", "as_ride", "ride_name"]


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
        ``(t, length)`` of every interval longer than 1 s, s.
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

    def as_json(self) -> dict:
        """``{"duration_s", "rate_hz", "gaps": [[t, length], ...], "zero_channels", "notes"}``."""
        return {"duration_s": self.duration_s, "rate_hz": self.rate_hz,
                "gaps": [list(g) for g in self.gaps], "zero_channels": list(self.zero_channels),
                "notes": list(self.notes)}


@dataclass(frozen=True)
class Ride:
    """One ride log, parsed once.

    Attributes
    ----------
    log : RideLog
        The columns in SI units (:data:`euc_sim.rides.logs.CHANNEL_UNITS`).
    quality : RideQuality
    """

    log: RideLog
    quality: RideQuality

    @property
    def path(self) -> str:
        return self.log.path

    @property
    def name(self) -> str:
        """The file name (outputs never carry a machine path)."""
        return Path(self.log.path).name


def _quality(log: RideLog, gap: float = 1.0) -> RideQuality:
    t = log.data["t"].to_numpy(float)
    dt = np.diff(t)
    long = np.flatnonzero(dt > gap)
    rate = float(1.0 / np.median(dt)) if dt.size and np.median(dt) > 0 else float("nan")
    return RideQuality(duration_s=float(t[-1] - t[0]) if t.size else 0.0, rate_hz=rate,
                       gaps=tuple((float(t[i]), float(dt[i])) for i in long),
                       zero_channels=tuple(log.absent), notes=tuple(log.warnings))


def read_ride(path) -> Ride:
    """Parse the log at ``path`` once (one-line errors naming the file, as :func:`read_log`)."""
    log = read_log(path, emit_warnings=False)
    return Ride(log=log, quality=_quality(log))


def as_ride(x) -> Ride:
    """A :class:`Ride` as it is, a :class:`RideLog` wrapped, or a path read (once)."""
    if isinstance(x, Ride):
        return x
    if isinstance(x, RideLog):
        return Ride(log=x, quality=_quality(x))
    return read_ride(x)


def ride_name(x) -> str:
    """File name of a ride, a log or a path."""
    if isinstance(x, Ride):
        return x.name
    if isinstance(x, RideLog):
        return Path(x.path).name
    return Path(x).name

"""A ride log read once: its parsed columns with units, its data-quality facts, its grids.

:func:`read_ride` parses a log (:func:`euc_sim.rides.source.logs.read_log`) exactly once
into a :class:`Ride`; every analysis of ``euc-sim ride`` takes the ride (or its
``log``, a :class:`~euc_sim.rides.source.logs.RideLog`, which every reader of a path
also accepts) and none reads the file again.

Gap policy (one rule for every grid)
------------------------------------
:data:`GAP_POLICY` (:class:`GapPolicy`) is the only place the rule lives:

- an interval between two rows of at most ``bridge`` (2.5 s) is bridged by
  linear interpolation on the ``rate`` (10 Hz) grid; a longer one splits the
  ride into pieces that no filter, derivative or integral crosses;
- a piece shorter than a filter's window gets no filtered value from that filter
  (the balance fit leaves it out and says so in its notes);
- the balance law keeps the log's own stamps (its central differences and
  Simpson weights are exact on them) and splits them at the same ``bridge``.

Why 2.5 s: the Bluetooth loggers drop out for 1-2.5 s hundreds of times a ride
(V9 rides 0-2: 187-326 times); split there, the rides fall into pieces shorter
than the mass's 8 s energy windows.  A derivative across a bridged gap sees the
straight line between its ends.  The same threshold lists the gaps of
:class:`RideQuality`.  docs/ride_model.md ("One gap policy") has the stricter
1.0 s rule measured beside it.

The grid of a ride (:func:`euc_sim.rides.grids.signals.ride_grid`) and the filtered
signals built on it (:func:`euc_sim.rides.grids.signals.ride_signals`,
:func:`euc_sim.rides.grids.power.power_signals`) are kept on the :class:`Ride`
(:meth:`Ride.derived`): one ``euc-sim ride`` run builds each once per log.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from euc_sim.rides.source.logs import RideLog, read_log

__all__ = ["Ride", "RideQuality", "GapPolicy", "GAP_POLICY", "read_ride", "as_ride", "ride_name"]


@dataclass(frozen=True)
class GapPolicy:
    """How every grid of a ride treats the intervals between its rows (module docstring).

    Attributes
    ----------
    bridge : float
        Longest interval bridged by linear interpolation, s; a longer one splits
        the ride into pieces.
    rate : float
        Grid rate, Hz: points at multiples of 1/rate s.
    """

    bridge: float = 2.5
    rate: float = 10.0

    def splits(self, dt: np.ndarray) -> np.ndarray:
        """True for each interval (s) that splits the ride (longer than :attr:`bridge`)."""
        return np.asarray(dt, float) > self.bridge

    def pieces(self, t: np.ndarray) -> np.ndarray:
        """Piece label (0, 1, ...) of each row with stamps ``t`` (s): a new piece after each split."""
        t = np.asarray(t, float)
        return np.r_[0, np.cumsum(self.splits(np.diff(t)))] if t.size else np.zeros(0, int)


#: The one gap policy of every grid (module docstring: why 2.5 s).
GAP_POLICY = GapPolicy()


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
        :attr:`GapPolicy.bridge`), s.
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
        The columns in SI units (:data:`euc_sim.rides.source.logs.CHANNEL_UNITS`).
    quality : RideQuality
    """

    log: RideLog
    quality: RideQuality
    _derived: dict = field(default_factory=dict, init=False, repr=False, compare=False)

    def derived(self, key: tuple, build):
        """What ``build()`` returns, built the first time ``key`` is asked for and kept.

        The grids and filtered signals of this ride (:func:`euc_sim.rides.grids.signals.ride_grid`,
        :func:`euc_sim.rides.grids.signals.ride_signals`, :func:`euc_sim.rides.grids.power.power_signals`)
        are keyed by their kind and settings; callers must not modify what they get.
        """
        if key not in self._derived:
            self._derived[key] = build()
        return self._derived[key]

    @property
    def path(self) -> str:
        return self.log.path

    @property
    def name(self) -> str:
        """The file name (outputs never carry a machine path)."""
        return Path(self.log.path).name


def _quality(log: RideLog, policy: GapPolicy = GAP_POLICY) -> RideQuality:
    t = log.data["t"].to_numpy(float)
    dt = np.diff(t)
    long = np.flatnonzero(policy.splits(dt))
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

"""The one gap policy of the ride side: every interval threshold between a log's rows.

A ride log's rows arrive every 0.1-0.5 s, with dropouts of the phone's Bluetooth link
(1-2.5 s, hundreds a ride), pauses of the logging and, now and then, a log left running
for hours.  What each part of the ride side does across an interval between two rows
is decided here, in :data:`GAP_POLICY`, and nowhere else: every user reads its number
from this object.

The grids (the balance fit's, the mass fit's, the law's rows, the free-spin search)
bridge an interval of at most :attr:`GapPolicy.bridge` by linear interpolation on the
:attr:`GapPolicy.rate` grid; a longer one splits the ride into pieces that no filter,
derivative or integral crosses; a piece shorter than a filter's window gets no filtered
value.  Why 2.5 s: split at 1 s, the V9 rides fall into pieces shorter than the mass's
8 s energy windows (docs/ride_model.md, "One gap policy").
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

__all__ = ["GapPolicy", "GAP_POLICY"]


@dataclass(frozen=True)
class GapPolicy:
    """Every gap number of the ride side, s unless said (module docstring).

    Attributes
    ----------
    bridge : float
        Longest interval bridged by linear interpolation on a grid, or integrated across
        (the summary's energy and distance, the free-spin search); a longer one splits the
        ride: the loggers' Bluetooth dropouts (1-2.5 s) are bridged, a stop of the logging is not.
    rate : float
        Grid rate, Hz: the rows' own rate (2-10 Hz) without inventing detail between them.
    gap : float
        An interval the data-quality facts count as a gap (the reader's sampling warning, the
        summary's ``gaps``): longer than the slowest fixed logging interval (WheelLog 1 Hz).
    app_gap : tuple of (str, float)
        ``(layout, s)``: apps whose normal writing is slower than :attr:`gap`: EUC World writes
        when the wheel's frames arrive, in bursts up to 1.7 s apart (docs/summary.md).
    distance : float
        Longest interval the wheel's speed is integrated across for the ride's distance where
        the log has no usable counter: on the one shared log with longer gaps and a trip counter
        (WheelLog, InMotion V9), the speed integrated over its 33 gaps of 2.5-60 s is 1 % above
        the counter's increase, over its 8 gaps of 60-300 s 28 % above (docs/summary.md).
    pause : float
        An interval this long is a pause of the log, left out of the ride's duration: the app
        stopped writing, no rows were lost while riding.
    charge : float
        Longest interval the battery's drawn charge is integrated across (the battery fit, the
        two rides' voltage design, the concealed sag): a longer one adds no charge, as the
        current across it is unknown and the fits need it row by row.
    profile : float
        Longest interval bridged in the speed profile the simulator rides: every one (the
        profile is one continuous run; :attr:`simulate` refuses the logs it cannot ride).
    simulate : float
        Longest interval the simulation bridges; a log with a longer one (the app left running
        for hours) is not simulated: bridging would be hours of 1 kHz simulation.
    rider : float
        Longest interval bridged in the rider's channels (the rider fit): its planner needs the
        rows' own detail, so only the 1 Hz logging is bridged.
    gps_pair : float
        Longest interval between two GPS fixes whose distance is compared with the wheel's
        (the speed scale's track): a fix a second or two late still pairs, a lost fix does not.
    gps_hop : float
        Longest interval between GPS fixes whose hop counts in the ride's GPS distance; a longer
        hop is filled with the wheel's distance (the phone lost the sky for a while).
    odometer : float
        Longest interval over which the speed is checked against the wheel's odometer: the
        odometer counts whole metres, so only short intervals compare row by row.
    plot_steps : float
        A line on a figure breaks at an interval over this many median intervals (a missing row).
    """

    bridge: float = 2.5
    rate: float = 10.0
    gap: float = 1.0
    app_gap: tuple = (("eucworld", 2.0),)
    distance: float = 60.0
    pause: float = 300.0
    charge: float = 1.0
    profile: float = math.inf
    simulate: float = 120.0
    rider: float = 1.0
    gps_pair: float = 3.0
    gps_hop: float = 5.0
    odometer: float = 2.0
    plot_steps: float = 1.5

    def splits(self, dt: np.ndarray) -> np.ndarray:
        """True for each interval (s) that splits the ride (longer than :attr:`bridge`)."""
        return np.asarray(dt, float) > self.bridge

    def pieces(self, t: np.ndarray) -> np.ndarray:
        """Piece label (0, 1, ...) of each row with stamps ``t`` (s): a new piece after each split."""
        t = np.asarray(t, float)
        return np.r_[0, np.cumsum(self.splits(np.diff(t)))] if t.size else np.zeros(0, int)

    def gap_of(self, layout: str | None) -> float:
        """The interval beyond which a log of this app (reader's layout name) has a gap, s."""
        return dict(self.app_gap).get(str(layout), self.gap)

    def plot_breaks(self, t: np.ndarray) -> np.ndarray:
        """Indices ``i`` where a plotted line through rows ``t`` (s) breaks between ``i`` and ``i + 1``."""
        dt = np.diff(np.asarray(t, float))
        return np.flatnonzero(dt > self.plot_steps * np.median(dt)) if dt.size else np.zeros(0, int)


#: The one gap policy of the ride side.
GAP_POLICY = GapPolicy()

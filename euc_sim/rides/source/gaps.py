"""The one gap policy of the ride side: every interval threshold between a log's rows.

Grids bridge an interval up to :attr:`GapPolicy.bridge` by linear interpolation on the
:attr:`GapPolicy.rate` grid; a longer one splits the ride into pieces no filter,
derivative or integral crosses.  See docs/ride_model.md ("One gap policy").
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

__all__ = ["GapPolicy", "GAP_POLICY"]


@dataclass(frozen=True)
class GapPolicy:
    """Every gap number of the ride side, s unless said.

    Attributes
    ----------
    bridge : float
        Longest interval interpolated or integrated across; longer splits the ride.
    rate : float
        Grid rate, Hz.
    gap : float
        An interval the data-quality facts count as a gap (WheelLog logs at 1 Hz).
    app_gap : tuple of (str, float)
        ``(layout, s)`` for apps writing slower than :attr:`gap` (EUC World, docs/summary.md).
    distance : float
        Longest interval the speed is integrated across for the distance (docs/summary.md).
    pause : float
        An interval this long is a pause, left out of the duration.
    charge : float
        Longest interval the drawn charge is integrated across.
    profile : float
        Longest interval bridged in the simulator's speed profile.
    simulate : float
        Longest interval the simulation bridges; a log with a longer one is not simulated.
    rider : float
        Longest interval bridged in the rider fit's channels.
    gps_pair, gps_hop : float
        Longest interval between GPS fixes compared with the wheel's distance / counted in
        the GPS distance.
    odometer : float
        Longest interval over which speed is checked against the odometer (whole metres).
    plot_steps : float
        A plotted line breaks at an interval over this many median intervals.
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

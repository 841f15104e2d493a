"""The road's grade from GPS altitude read over the distance ridden.

:func:`distance_along` gives each grid row's distance along the ride, m;
:func:`gps_grade` the road's grade sin α at each row, from GPS altitude read over
distance (not time), where the log has altitude.
"""

from __future__ import annotations

import numpy as np
import pandas as pd

__all__ = ["distance_along", "gps_grade", "GRADE_LENGTH_M", "GRADE_STEP_M", "MAX_GRADE"]

#: Length of road over which GPS altitude gives one grade, m: a consumer fix errs by metres,
#: so a slope read over 100 m errs by about ±0.02 (docs/ride_model.md, "The road's grade").
GRADE_LENGTH_M = 100.0
#: Spacing of the distance grid the altitude is read on, m.
GRADE_STEP_M = 5.0
#: Steepest grade a road has (the steepest public streets, about 35 %): a slope beyond it
#: over :data:`GRADE_LENGTH_M` is the GPS fix settling or jumping, not the road.
MAX_GRADE = 0.35


def distance_along(t: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Distance ridden from the first row, m: ∫|v| dt by the trapezoid rule.

    ``t`` in s, ``v`` in m/s (NaN read as 0); a gap between rows is bridged at the
    mean of the speeds either side.
    """
    v = np.abs(np.nan_to_num(np.asarray(v, float)))
    step = 0.5 * (v[1:] + v[:-1]) * np.diff(np.asarray(t, float))
    return np.concatenate([[0.0], np.cumsum(step)])


def gps_grade(raw: pd.DataFrame) -> np.ndarray:
    """The road's grade sin α at each grid row, from GPS altitude read over distance (not time).

    The altitude is put on a :data:`GRADE_STEP_M` grid along the distance ridden
    (:func:`distance_along`) and its slope dh/ds read by a straight-line fit over
    :data:`GRADE_LENGTH_M` of road (a Savitzky–Golay derivative).  Where the slope exceeds
    :data:`MAX_GRADE` (a fix settling, a jump) the grade there and that length either side is
    unknown, read as 0.  Read over time, GPS noise would dominate the climb rate
    (docs/ride_model.md).

    ``raw``: a ride's grid with ``t`` (s), ``v`` (m/s), ``gps_alt`` (m).  Returns sin α per
    row: 0 where unknown or under two grid steps, one slope under that length.  ValueError
    without ``gps_alt`` or under two finite altitudes.
    """
    from scipy.signal import savgol_filter

    if "gps_alt" not in raw:
        raise ValueError("gps_grade needs a gps_alt column")
    s = distance_along(raw["t"].to_numpy(float), raw["v"].to_numpy(float))
    h = raw["gps_alt"].to_numpy(float)
    fix = np.isfinite(h)
    if fix.sum() < 2:
        raise ValueError(f"gps_grade needs two finite altitudes, got {int(fix.sum())}")
    if s[-1] < 2 * GRADE_STEP_M:
        return np.zeros(len(s))
    at, where = np.unique(s[fix], return_inverse=True)
    h_at = np.bincount(where, h[fix]) / np.bincount(where)
    grid = np.linspace(0.0, s[-1], int(np.ceil(s[-1] / GRADE_STEP_M)) + 1)
    step = grid[1]
    h_grid = np.interp(grid, at, h_at)
    n = int(round(GRADE_LENGTH_M / step)) // 2 * 2 + 1
    if len(grid) < n:
        slope = np.full(len(grid), np.polyfit(grid, h_grid, 1)[0])
    else:
        slope = savgol_filter(h_grid, n, 1, deriv=1, delta=step, mode="interp")
    bad = (np.abs(slope) > MAX_GRADE).astype(float)           # and GRADE_LENGTH_M either side:
    wrong = np.convolve(bad, np.ones(2 * n - 1))[n - 1:n - 1 + len(bad)] > 0
    return np.interp(s, grid, np.where(wrong, 0.0, slope))

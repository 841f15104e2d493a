"""Two rides of one route: where each row lies along it, and where one ride lies on the other's.

Without GPS altitude a grade that varies along the road is a function of
position; a second ride of the same route can carry it
(:mod:`euc_sim.rides.balance.route_grade`, docs/route_grade.md).  Pure functions:

1. :func:`route_position`: each grid row's distance along the ride, m, and its
   GPS position in local metres when the log has one;
2. :func:`gps_grade`: the road's grade sin α at each row, from GPS altitude read
   over distance (not time), where the log has altitude;
3. :func:`match_routes`: where the test ride lies on the fit ride's route, by GPS
   track (nearest point, same road heading) or, without GPS on either, by distance
   along the ride with the offset found from the *speed* per 25 m (never from
   power: the test ride's power stays held out); a :class:`RouteMatch` or None.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pandas as pd

from euc_sim.geo import local_metres

__all__ = ["RoutePosition", "RouteMatch", "route_position", "match_routes", "match_by_gps",
           "match_by_speed", "BIN_M", "MIN_SHARED_M", "MIN_SPEED_CORR", "GPS_RADIUS_M",
           "MIN_HEADING_COS", "MAX_OFFSET_M", "distance_along", "gps_grade", "GRADE_LENGTH_M", "MAX_GRADE"]

#: Length of route over which one grade is read, m.
BIN_M = 25.0
#: Least route the two rides must share for a grade to be carried, m.
MIN_SHARED_M = 500.0
#: Without GPS: least correlation of the two rides' speeds per :data:`BIN_M` of route at the
#: best offset (the rider slows at the same corners and hills on the same road).
MIN_SPEED_CORR = 0.6
#: Without GPS: offsets of the test ride's distance origin searched, ± m.
MAX_OFFSET_M = 500.0
#: With GPS: a test point lies on the fit ride's route within this distance of it, m
#: (two consumer GPS fixes of one lane differ by 5-15 m).
GPS_RADIUS_M = 20.0
#: With GPS: headings within this angle (cos 45°) count as the same road, not a crossing.
MIN_HEADING_COS = 0.7
#: Length of road over which GPS altitude gives one grade, m: a consumer fix errs by metres,
#: so a slope read over 100 m errs by about ±0.02 (docs/ride_model.md, "The road's grade").
GRADE_LENGTH_M = 100.0
#: Spacing of the distance grid the altitude is read on, m.
GRADE_STEP_M = 5.0
#: Steepest grade a road has (the steepest public streets, about 35 %): a slope beyond it
#: over :data:`GRADE_LENGTH_M` is the GPS fix settling or jumping, not the road.
MAX_GRADE = 0.35


@dataclass(frozen=True)
class RoutePosition:
    """Where each row of a ride's grid lies along its route.

    Attributes
    ----------
    s : numpy.ndarray
        Distance along the ride from its first row, m (∫|v| dt; a gap is bridged at
        the mean of the speeds either side).
    xy : numpy.ndarray or None
        GPS position, m east and north of ``origin`` (rows × 2, NaN without a fix);
        None when the log has no GPS track (fewer than half the rows with a fix).
    v : numpy.ndarray
        Wheel speed, m/s.
    origin : tuple of float or None
        (latitude, longitude) of the local frame, degrees.
    """

    s: np.ndarray
    xy: np.ndarray | None
    v: np.ndarray
    origin: tuple[float, float] | None = None

    @property
    def length(self) -> float:
        """Distance ridden, m."""
        return float(self.s[-1] - self.s[0]) if len(self.s) else 0.0


@dataclass(frozen=True)
class RouteMatch:
    """Where the test ride's rows lie on the fit ride's route.

    Attributes
    ----------
    method : str
        ``"gps"`` (nearest point of the fit ride's track) or ``"speed"`` (distance
        along the ride, offset from the speed profiles).
    s_fit : numpy.ndarray
        For each test row, its distance along the fit ride, m (NaN: off the route).
    direction : numpy.ndarray
        +1 where the test ride runs the fit ride's way, −1 the other way, 0 off it.
    shared_m : float
        Distance of the test ride on the fit ride's route, m.
    share : float
        ``shared_m`` over the test ride's distance.
    quality : float
        ``"speed"``: the speeds' correlation per :data:`BIN_M` at the offset;
        ``"gps"``: the median distance of matched test points to the track, m.
    offset_m : float
        Median of s_fit − s_test over the matched rows, m.
    """

    method: str
    s_fit: np.ndarray
    direction: np.ndarray
    shared_m: float
    share: float
    quality: float
    offset_m: float


def route_position(raw: pd.DataFrame, origin: tuple[float, float] | None = None) -> RoutePosition:
    """Distance along the ride and local GPS position of each grid row.

    Parameters
    ----------
    raw : pandas.DataFrame
        A ride's grid (:attr:`RideSignals.raw`): ``t`` (s), ``v`` (m/s), and
        ``latitude``, ``longitude`` (degrees) when the log has GPS.
    origin : (float, float), optional
        (latitude, longitude) of the local frame; the ride's first fix if None.

    Returns
    -------
    RoutePosition
    """
    t, v = raw["t"].to_numpy(float), np.nan_to_num(raw["v"].to_numpy(float))
    s = distance_along(t, v)
    xy = None
    if {"latitude", "longitude"} <= set(raw.columns):
        lat, lon = raw["latitude"].to_numpy(float), raw["longitude"].to_numpy(float)
        fix = np.isfinite(lat) & np.isfinite(lon) & (np.abs(lat) + np.abs(lon) > 0)
        if fix.mean() >= 0.5:
            if origin is None:
                origin = (float(lat[fix][0]), float(lon[fix][0]))
            xy = np.full((len(t), 2), np.nan)
            xy[fix] = local_metres(lat[fix], lon[fix], origin)
    return RoutePosition(s=s, xy=xy, v=v, origin=origin if xy is not None else None)


def distance_along(t: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Distance ridden from the first row, m: ∫|v| dt by the trapezoid rule.

    ``t`` in s, ``v`` in m/s (NaN read as 0); a gap between rows is bridged at the
    mean of the speeds either side.
    """
    v = np.abs(np.nan_to_num(np.asarray(v, float)))
    step = 0.5 * (v[1:] + v[:-1]) * np.diff(np.asarray(t, float))
    return np.concatenate([[0.0], np.cumsum(step)])


def gps_grade(raw: pd.DataFrame, length: float = GRADE_LENGTH_M) -> np.ndarray:
    """The road's grade sin α at each grid row, from GPS altitude over distance.

    The altitude is placed on a grid of :data:`GRADE_STEP_M` along the distance
    ridden (:func:`distance_along`; rows at one place are averaged, rows without a
    fix interpolated) and its slope dh/ds read by a local straight-line fit over
    ``length`` of road (scipy's Savitzky–Golay derivative).  Where that slope
exceeds :data:`MAX_GRADE` (a fix settling at the start of a ride, a jump), the
altitude is not the road's: the grade there, and over ``length`` either side,
is unknown and read as 0.  Read over time
    instead, the metres of GPS error become climb rates of the order of the true
    ones and a fitted gain on them falls to 0.2–0.3 (docs/ride_model.md).

    Parameters
    ----------
    raw : pandas.DataFrame
        A ride's grid (:attr:`RideSignals.raw`): ``t`` (s), ``v`` (m/s), ``gps_alt`` (m).
    length : float
        Road over which one slope is read, m.

    Returns
    -------
    numpy.ndarray
        sin α (dh/ds, 1), one per row; 0 where it is unknown (above) or the ride
        covers less than two grid steps, a single straight-line slope where it
        covers less than ``length``.

    Raises
    ------
    ValueError
        if ``raw`` has no ``gps_alt`` column, or fewer than two finite altitudes, or
        ``length`` is not positive.
    """
    from scipy.signal import savgol_filter

    if not length > 0:
        raise ValueError(f"length must be positive (m), got {length!r}")
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
    n = int(round(length / step)) // 2 * 2 + 1
    if len(grid) < n:
        slope = np.full(len(grid), np.polyfit(grid, h_grid, 1)[0])
    else:
        slope = savgol_filter(h_grid, n, 1, deriv=1, delta=step, mode="interp")
    bad = (np.abs(slope) > MAX_GRADE).astype(float)           # and ``length`` either side:
    wrong = np.convolve(bad, np.ones(2 * n - 1))[n - 1:n - 1 + len(bad)] > 0
    return np.interp(s, grid, np.where(wrong, 0.0, slope))


def match_routes(fit: RoutePosition, test: RoutePosition) -> RouteMatch | None:
    """Where the test ride lies on the fit ride's route; None when they share too little.

    By GPS track when both rides have one (:func:`match_by_gps`), else by distance
    along the ride with the offset the speed profiles give (:func:`match_by_speed`).
    A match needs :data:`MIN_SHARED_M` of shared route.
    """
    if fit.xy is not None and test.xy is not None:
        m = match_by_gps(fit, test)
    else:
        m = match_by_speed(fit, test)
    return m if m is not None and m.shared_m >= MIN_SHARED_M else None


def _heading(xy: np.ndarray, s: np.ndarray, span_m: float = 15.0) -> np.ndarray:
    """Unit direction of travel at each row, from the positions ±``span_m`` along the ride."""
    lo = np.clip(np.searchsorted(s, s - span_m), 0, len(s) - 1)
    hi = np.clip(np.searchsorted(s, s + span_m), 0, len(s) - 1)
    d = xy[hi] - xy[lo]
    n = np.hypot(d[:, 0], d[:, 1])
    with np.errstate(invalid="ignore", divide="ignore"):
        return d / n[:, None]


def match_by_gps(fit: RoutePosition, test: RoutePosition) -> RouteMatch | None:
    """Match by GPS track: each test row's nearest fit-ride point, within
    :data:`GPS_RADIUS_M` and heading along the same road (|cos| ≥ :data:`MIN_HEADING_COS`).

    Both positions must be in one local frame (``route_position(test, fit.origin)``).
    """
    from scipy.spatial import cKDTree

    ok_f = np.isfinite(fit.xy).all(axis=1)
    ok_t = np.isfinite(test.xy).all(axis=1)
    if ok_f.sum() < 2 or ok_t.sum() < 2:
        return None
    idx_f = np.flatnonzero(ok_f)
    dist, k = cKDTree(fit.xy[ok_f]).query(np.where(ok_t[:, None], test.xy, 0.0))
    j = idx_f[k]
    cos = np.sum(_heading(test.xy, test.s) * _heading(fit.xy, fit.s)[j], axis=1)
    on = ok_t & (dist <= GPS_RADIUS_M) & (np.abs(np.nan_to_num(cos)) >= MIN_HEADING_COS)
    on &= np.abs(test.v) > 0.5
    s_fit = np.where(on, fit.s[j], np.nan)
    direction = np.where(on, np.sign(np.nan_to_num(cos)), 0.0)
    return _match("gps", test, s_fit, direction,
                  float(np.median(dist[on])) if on.any() else np.inf)


def _match(method: str, test: RoutePosition, s_fit: np.ndarray, direction: np.ndarray,
           quality: float) -> RouteMatch:
    """The :class:`RouteMatch` of mapped rows: shared distance from the test ride's steps."""
    on = np.isfinite(s_fit)
    ds = np.diff(test.s, prepend=test.s[0])
    shared = float(ds[on].sum())
    return RouteMatch(method=method, s_fit=s_fit, direction=direction, shared_m=shared,
                      share=shared / test.length if test.length > 0 else 0.0, quality=quality,
                      offset_m=float(np.median(s_fit[on] - test.s[on])) if on.any() else 0.0)


def _binned_speed(pos: RoutePosition, n: int) -> np.ndarray:
    """Mean speed per :data:`BIN_M` of distance, first ``n`` bins (NaN: no row there)."""
    b = np.floor(pos.s / BIN_M).astype(int)
    keep = b < n
    total = np.bincount(b[keep], np.abs(pos.v[keep]), n)
    count = np.bincount(b[keep], None, n)
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(count > 0, total / count, np.nan)


def match_by_speed(fit: RoutePosition, test: RoutePosition,
                   min_overlap_m: float = MIN_SHARED_M) -> RouteMatch | None:
    """Match by distance along the ride, the offset from the speed profiles per :data:`BIN_M`.

    The test ride's distance plus an offset (multiples of :data:`BIN_M` within
    ±:data:`MAX_OFFSET_M`) is its distance along the fit ride; the offset is where
    the two rides' mean speeds per bin correlate best over at least
    ``min_overlap_m`` of route, and the match needs that correlation to reach
    :data:`MIN_SPEED_CORR`.  Only the speed is read: the test ride's power stays held out.
    """
    nf, nt = int(fit.length // BIN_M) + 1, int(test.length // BIN_M) + 1
    vf, vt = _binned_speed(fit, nf), _binned_speed(test, nt)
    shift = int(MAX_OFFSET_M // BIN_M)
    need = int(np.ceil(min_overlap_m / BIN_M))
    best = (-np.inf, 0)
    for k in range(-shift, shift + 1):       # fit bin i + k  <->  test bin i
        i = np.arange(max(0, -k), min(nt, nf - k))
        if len(i) < need:
            continue
        a, b = vf[i + k], vt[i]
        ok = np.isfinite(a) & np.isfinite(b)
        if ok.sum() < need or np.std(a[ok]) == 0 or np.std(b[ok]) == 0:
            continue
        r = float(np.corrcoef(a[ok], b[ok])[0, 1])
        if r > best[0]:
            best = (r, k)
    r, k = best
    if r < MIN_SPEED_CORR:
        return None
    s_fit = test.s + k * BIN_M
    on = (s_fit >= 0) & (s_fit <= fit.length)
    return _match("speed", test, np.where(on, s_fit, np.nan), on.astype(float), r)

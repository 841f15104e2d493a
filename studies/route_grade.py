#!/usr/bin/env python
"""The grade along a shared route: read on one ride, carried to another (docs/route_grade.md).

    nice python studies/route_grade.py [--only SUBSTR] [--out docs/route_grade.md]

Reads ``../shared/data`` (read-only).  For the WheelLog pair both ways (a tuning
figure: its residual correlation per 25 m of route motivated the idea) and every
ordered pair of euc_core rides of one wheel (the untuned check), each run as
``euc-sim ride LOG --compare OTHER`` fits it (energy-balance mass, bootstrap-free
balance fit): the route match (:func:`match_routes`), the decision to carry (:func:`carry_decision`),
and the test ride's held-out error of the selected model without and with the fit
ride's grade profile carried.  Progress on the terminal (stderr); the table to
stdout and into ``--out`` (atomically): between its ``<!-- table -->`` and
``<!-- /table -->`` lines when the page has them (the prose around it is kept),
else as a new page.

Without GPS altitude a grade that varies along the road is a function of position: one
ride cannot validate it (each position is seen once), but a second ride of the same
route can carry it.  :func:`route_position` places each grid row along its ride (and by
GPS in local metres); :func:`match_routes` finds where the test ride lies on the fit
ride's route, by GPS track (nearest point, same road heading) or, without GPS on either,
by distance with the offset found from the *speed* per 25 m (never from power: the test
ride's power stays held out).  Then :func:`grade_profile` reads sin α per 25 m of the
fit ride's route from its residual under its selected balance model (bounded,
smoothed), :func:`carry_decision` decides from the fit ride and the match only, and
:func:`carry_grade` puts the carried grade's power m·g·v·sin α in the test ride's known
demand (gain 1, nothing fitted on the test ride).
"""
from __future__ import annotations

import argparse
import csv
import dataclasses
import sys
import warnings
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Mapping

import numpy as np
import pandas as pd

from euc_sim.geo import local_metres
from euc_sim.io import atomic_write
from euc_sim.rides.balance.design import PLAUSIBLE, PRE_WINDOW, Design
from euc_sim.rides.grids.route import distance_along
from euc_sim.rides.grids.signals import RideSignals, sg
from euc_sim.rides.pipeline import balance_on_mass
from euc_sim.rides.source.logs import read_log
from euc_sim.rides.source.spec import read_spec

SHARED = Path(__file__).resolve().parents[2] / "shared" / "data"
COMMAND = "nice python studies/route_grade.py --out docs/route_grade.md"
BEGIN, END = "<!-- table -->", "<!-- /table -->"
WHEELS = ("v9", "blitz", "master_pro_V2", "mten4", "lynx")

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


#: Length over which a road's grade changes (a vertical curve), m: the smoothing of the profile.
SMOOTH_M = 50.0
#: The bound of the grade read: the plausible range of a constant grade.
GRADE_LIMIT = float(PLAUSIBLE["road_slope"][1])
#: Greatest share of the profile's bins on ±:data:`GRADE_LIMIT` for it to be carried.
MAX_ON_BOUND = 0.2


@dataclass(frozen=True)
class GradeProfile:
    """sin α per :data:`BIN_M` of the fit ride's route.

    Attributes
    ----------
    edges : numpy.ndarray
        Bin edges along the fit ride, m (length n + 1).
    sin_alpha : numpy.ndarray
        Grade of each bin, within ±:data:`GRADE_LIMIT` (NaN: too little riding there).
    on_bound : float
        Share of the read bins on ±:data:`GRADE_LIMIT`.
    rmse_before, rmse_after : float
        The fit ride's RMS residual without and with the profile, W (in sample).
    """

    edges: np.ndarray
    sin_alpha: np.ndarray
    on_bound: float
    rmse_before: float
    rmse_after: float

    def at(self, s: np.ndarray) -> np.ndarray:
        """sin α at distances ``s`` along the fit ride, m (0 outside the read bins)."""
        s = np.asarray(s, float)
        i = np.floor((s - self.edges[0]) / BIN_M)
        ok = np.isfinite(i) & (i >= 0) & (i < len(self.sin_alpha))
        out = np.zeros(s.shape)
        out[ok] = np.nan_to_num(self.sin_alpha[i[ok].astype(int)])
        return out



def _on_support(design: Design, x_full: np.ndarray) -> np.ndarray:
    """``x_full`` (one value per grid row) on the rows the design's operator reads."""
    return x_full[design.operator.support]


def _grade_power(sig: RideSignals, sin_alpha_full: np.ndarray) -> np.ndarray:
    """m·g·v·sin α on the grid, through the balance's short pre-filter L₁, W."""
    A = sig.assumptions
    seg = sig.raw["segment"].to_numpy()
    x = A.total_mass * A.g * sig.raw["v"].to_numpy(float) * sin_alpha_full
    return np.nan_to_num(sg(x, seg, sig.rate, PRE_WINDOW, min(2, sig.polyorder)))


def _filter(design: Design, estimate: Mapping[str, float]):
    """The long filter the model's prediction passes, with the current's lag when fitted."""
    op = design.operator
    tau = float(estimate.get("current_lag", 0.0))
    return op.K - tau * op.Kd + tau ** 2 * op.Kdd if tau else op.K


def grade_profile(sig: RideSignals, design: Design, estimate: Mapping[str, float],
                  pos: RoutePosition) -> GradeProfile:
    """sin α per :data:`BIN_M` of route from the fit ride's residual under ``estimate``.

    The residual r = P − P̂ of the selected model is fitted, by bounded linear least
    squares (scipy's ``lsq_linear``, |sin α| ≤ :data:`GRADE_LIMIT`), by the battery
    power a grade per bin would draw: the grade's power m·g·v·sin α (added to
    the demand as every other term, no efficiency) through the balance's filters.  A first-difference penalty of weight
    (:data:`SMOOTH_M`/:data:`BIN_M`)² × the mean diagonal of the normal matrix
    smooths it over about :data:`SMOOTH_M` (a road's grade changes over a
    vertical curve, not per bin).  Bins with less than 2 s of riding are NaN.

    Parameters
    ----------
    sig : RideSignals
        The fit ride (its grid gives m·g·v).
    design : Design
        Its balance design; ``estimate`` its selected model's fit.
    estimate : mapping
    pos : RoutePosition
        :func:`route_position` of ``sig.raw``.
    """
    from scipy import sparse
    from scipy.optimize import lsq_linear

    s_sup = _on_support(design, pos.s)
    n = int(pos.length // BIN_M) + 1
    col = _on_support(design, _grade_power(sig, np.ones(len(pos.s))))
    onehot = sparse.csr_matrix((col, (np.arange(len(col)), np.floor(s_sup / BIN_M).astype(int))),
                               shape=(len(col), n))
    w = design.weight
    A = sparse.diags(w) @ (_filter(design, estimate) @ onehot)
    r = design.residual(estimate)
    rows_per_bin = np.bincount(np.floor(_design_s(design, pos) / BIN_M).astype(int), None, n)
    seen = rows_per_bin >= 2.0 * sig.rate
    A = sparse.csr_matrix(A)[:, seen]
    diag = np.asarray(A.multiply(A).sum(axis=0)).ravel()
    lam = (SMOOTH_M / BIN_M) ** 2 * float(np.mean(diag))
    k = int(seen.sum())
    Dm = sparse.diags([np.ones(k - 1), -np.ones(k - 1)], [0, 1], shape=(k - 1, k))
    sol = lsq_linear(sparse.vstack([A, np.sqrt(lam) * Dm]).tocsr(),
                     np.concatenate([r, np.zeros(k - 1)]), bounds=(-GRADE_LIMIT, GRADE_LIMIT),
                     lsmr_tol="auto", method="trf")
    sin_alpha = np.full(n, np.nan)
    sin_alpha[seen] = sol.x
    after = r - A @ sol.x
    bound = np.abs(sol.x) >= GRADE_LIMIT * (1 - 1e-3)
    return GradeProfile(edges=np.arange(n + 1) * BIN_M, sin_alpha=sin_alpha,
                        on_bound=float(bound.mean()) if k else 0.0,
                        rmse_before=float(np.sqrt(np.mean(r ** 2))),
                        rmse_after=float(np.sqrt(np.mean(after ** 2))))


def _design_s(design: Design, pos: RoutePosition) -> np.ndarray:
    """Distance along the ride of the design's rows in use, m."""
    return pos.s[design.use]


def carried_grade(profile: GradeProfile, match: RouteMatch) -> np.ndarray:
    """sin α at each test row: the fit ride's grade where the test ride rides its
    route, its sign turned where it rides it the other way; 0 off the route."""
    s = np.where(np.isfinite(match.s_fit), match.s_fit, -1.0)
    return profile.at(s) * match.direction


def carry_grade(sig: RideSignals, design: Design, sin_alpha: np.ndarray) -> Design:
    """The test ride's design with the grade's power in its known demand (gain 1).

    m·g·v·sin α (through the pre-filter L₁, as every column) joins the design's
    known column (m_eq·a·v), so it passes the regime switch and the long filter
    as any demanded power does; nothing is fitted on the test ride.
    """
    cols = design.columns_full.copy()
    cols["inertia"] = cols["inertia"].to_numpy() + _grade_power(sig, sin_alpha)
    return replace(design, columns_full=cols)


@dataclass(frozen=True)
class CarryDecision:
    """Whether a grade read on the fit ride is carried to the test ride, and why not."""

    carry: bool
    why: str


def carry_decision(profile: GradeProfile, match: RouteMatch | None,
                   revisit: RevisitCheck | None = None) -> CarryDecision:
    """Carry the grade when the rides share :data:`MIN_SHARED_M` of route, at most
    :data:`MAX_ON_BOUND` of the profile sits on ±:data:`GRADE_LIMIT` (a residual asking
    for steeper grades than roads have is not a grade) and, where the fit ride passes a
    stretch twice (:func:`revisit_check`), the grade read on its first pass lowers the
    error of its second.  Reads the fit ride and the match only."""
    if match is None:
        return CarryDecision(False, "the rides do not share a route")
    if profile.on_bound > MAX_ON_BOUND:
        return CarryDecision(False, f"{100 * profile.on_bound:.0f} % of the grade read on the fit "
                                    f"ride sits on ±{GRADE_LIMIT:g}: not a road's grade")
    if revisit is not None and revisit.after >= revisit.before:
        return CarryDecision(False, f"on the {revisit.shared_m / 1000:.1f} km the fit ride passes "
                                    f"twice, its grade does not hold ({revisit.before:.0f} → "
                                    f"{revisit.after:.0f} W)")
    return CarryDecision(True, f"the rides share {match.shared_m / 1000:.1f} km of route "
                               f"(matched by {match.method})")


@dataclass(frozen=True)
class RevisitCheck:
    """The fit ride's own test of its grade: read on its first half, carried to its second.

    Attributes
    ----------
    shared_m : float
        Distance of the second half on the first half's route, m.
    before, after : float
        RMS residual of the second half's rows on that route without and with the
        grade read on the first half, W.
    """

    shared_m: float
    before: float
    after: float


def revisit_check(sig: RideSignals, design: Design, estimate: Mapping[str, float],
                  pos: RoutePosition) -> RevisitCheck | None:
    """Where a ride passes a stretch twice (by GPS), read the grade on the first pass and test it
    on the second; None without GPS or with less than :data:`MIN_SHARED_M` ridden twice.

    The ride is cut at the median time of its rows in use; the second half is matched to the
    first (:func:`match_by_gps`), the grade read on the first
    half's rows alone (:func:`grade_profile`) and carried to the second.  Each position of the
    second half is held out from the grade it is tested on.
    """
    if pos.xy is None:
        return None
    t_mid = float(np.median(design.t))
    late = design.t_full >= t_mid
    first = replace(pos, xy=np.where(late[:, None], np.nan, pos.xy))
    second = replace(pos, xy=np.where(late[:, None], pos.xy, np.nan))
    match = match_by_gps(first, second)
    if match is None or match.shared_m < MIN_SHARED_M:
        return None
    prof = grade_profile(sig, design.rows(design.t < t_mid), estimate, pos)
    test = design.rows(design.t >= t_mid)
    on = np.isfinite(match.s_fit)[test.use]
    carried = carry_grade(sig, test, carried_grade(prof, match))
    rms = lambda d: float(np.sqrt(np.mean(d.residual(estimate)[on] ** 2)))  # noqa: E731
    return RevisitCheck(shared_m=match.shared_m, before=rms(test), after=rms(carried))


# --- the study -------------------------------------------------------------------
def pairs(root: Path = SHARED) -> list[tuple[str, Path, Path, Path | None]]:
    """(label, fit log, test log, spec) for the WheelLog pair and every same-wheel euc_core pair."""
    wl = root / "wheellog"
    a, b = wl / "2020_05_16_08_02_06.csv", wl / "2020_05_28_07_52_00.csv"
    out = [(f"wheellog {x.stem[5:10]} -> {y.stem[5:10]}", x, y, None) for x, y in ((a, b), (b, a))]
    by_wheel: dict[str, list[Path]] = {}
    for meta in sorted((root / "euc_core").glob("trips/*/*/*/meta.csv")):
        with open(meta, newline="") as fh:
            wheel = next(csv.DictReader(fh))["wheel"]
        by_wheel.setdefault(wheel, []).append(meta.parent / f"{meta.parent.name}.csv")
    for wheel in WHEELS:
        spec = root / "euc_core" / "specs" / f"{wheel}.csv"
        for x in by_wheel.get(wheel, []):
            for y in by_wheel[wheel]:
                if x != y:
                    out.append((f"{wheel}/{x.stem} -> {y.stem}", x, y,
                                spec if spec.exists() else None))
    return out


def one(label: str, fit: Path, test: Path, spec_path: Path | None,
        shifts: tuple = ()) -> dict:
    """Match, decide and carry for one ordered pair; the row of the table."""
    spec = read_spec(spec_path) if spec_path else None
    an = balance_on_mass(read_log(fit), read_log(test), spec, n_boot=0, n_boot_mass=10, seed=0).analysis
    cr = an.cross
    pf = route_position(an.sig_fit.raw)
    pt = route_position(an.sig_test.raw, pf.origin)
    match = match_routes(pf, pt)
    by_speed = match_by_speed(pf, pt)
    row = {"label": label, "inertia_only": cr.heldout_nominal, "selected": cr.heldout_augmented,
           "ratio": cr.ratio, "accepted": list(cr.accepted),
           "gps": pf.xy is not None and pt.xy is not None,
           "match": None if match is None else match.method,
           "shared_m": 0.0 if match is None else match.shared_m,
           "share": 0.0 if match is None else match.share,
           "quality": None if match is None else match.quality,
           "offset_m": None if match is None else match.offset_m,
           "speed_match": None if by_speed is None else (by_speed.quality, by_speed.offset_m),
           "carried": False, "why": "the rides do not share a route",
           "with_grade": None, "ratio_with": None, "grade_range": None, "shared_rows": None,
           "revisit": None}
    if match is None:
        return row
    prof = grade_profile(an.sig_fit, cr.fit_design, cr.augmented.estimate, pf)
    rv = revisit_check(an.sig_fit, cr.fit_design, cr.augmented.estimate, pf)
    row["revisit"] = None if rv is None else (rv.shared_m, rv.before, rv.after)
    dec = carry_decision(prof, match, rv)
    carried = carry_grade(an.sig_test, cr.test_design, carried_grade(prof, match))
    with_grade = cr.augmented.rmse_on(carried)
    on = np.isfinite(match.s_fit)[cr.test_design.use]
    rms = lambda r: float(np.sqrt(np.mean(r[on] ** 2)))  # noqa: E731
    row["shared_rows"] = (rms(cr.test_design.residual(cr.nominal.estimate)),
                          rms(cr.test_design.residual(cr.augmented.estimate)),
                          rms(carried.residual(cr.augmented.estimate)))
    row["shifted"] = {}
    for sh in shifts:       # the profile misplaced by sh m along the route (alignment check)
        moved = dataclasses.replace(match, s_fit=match.s_fit + sh * match.direction)
        r = carry_grade(an.sig_test, cr.test_design,
                        carried_grade(prof, moved)).residual(cr.augmented.estimate)
        row["shifted"][sh] = float(np.sqrt(np.mean(r[on] ** 2)))
    row.update(carried=dec.carry, why=dec.why, with_grade=with_grade,
               ratio_with=with_grade / cr.heldout_nominal,
               grade_range=(float(np.nanmin(prof.sin_alpha)), float(np.nanmax(prof.sin_alpha))),
               fit_insample=(prof.rmse_before, prof.rmse_after), on_bound=prof.on_bound)
    return row


def _f(x, fmt: str) -> str:
    return "—" if x is None else format(x, fmt)


def table(rows: list[dict]) -> str:
    """Markdown table of the rows that share a route, then one line naming the others with
    their held-out ratio (nothing is carried there)."""
    apart = [r for r in rows if r["match"] is None]
    rows = [r for r in rows if r["match"] is not None]
    out = ["| pair | GPS on both | match | shared km (share of test ride) | match quality | "
           "offset m | carried | inertia-only W | selected W | ratio | with the carried grade W "
           "| ratio with | on the shared route: inertia-only → selected → with grade W | "
           "sin α range "
           "| fit ride passed twice: km, second pass without → with the first's grade W |",
           "|" + "---|" * 15]
    for r in rows:
        q = ("—" if r["quality"] is None else
             f"r = {r['quality']:.2f}" if r["match"] == "speed" else f"{r['quality']:.1f} m")
        g = ("—" if r["grade_range"] is None else
             f"{r['grade_range'][0]:+.3f} to {r['grade_range'][1]:+.3f}")
        sh = ("—" if r["shared_rows"] is None else
              " → ".join(f"{x:.1f}" for x in r["shared_rows"]))
        rv = ("—" if r["revisit"] is None else
              f"{r['revisit'][0] / 1000:.2f}: {r['revisit'][1]:.1f} → {r['revisit'][2]:.1f}")
        out.append(f"| {r['label']} | {'yes' if r['gps'] else 'no'} | {r['match'] or 'none'} | "
                   f"{r['shared_m'] / 1000:.2f} ({100 * r['share']:.0f} %) | {q} | "
                   f"{_f(r['offset_m'], '.0f')} | "
                   f"{'yes' if r['carried'] else 'no: ' + r['why']} | "
                   f"{r['inertia_only']:.1f} | {r['selected']:.1f} | {r['ratio']:.3f} | "
                   f"{_f(r['with_grade'], '.1f')} | {_f(r['ratio_with'], '.3f')} | {sh} | {g} "
                   f"| {rv} |")
    if apart:
        out += ["", "Pairs that share no route (nothing carried; selected / inertia-only held out): "
                + ", ".join(f"{r['label']} {r['ratio']:.3f}" for r in apart) + "."]
    return "\n".join(out)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--only", default="", help="only the pairs whose label contains this")
    ap.add_argument("--out", type=Path, default=None, help="write the Markdown table here")
    ap.add_argument("--shifts", action="store_true",
                    help="also print each matched pair's shared-route error with the carried "
                         "profile moved -75 ... +75 m along the route")
    args = ap.parse_args(argv)
    if not SHARED.is_dir():
        print(f"{SHARED}: the shared rides are not there", file=sys.stderr)
        return 2
    rows = []
    todo = [p for p in pairs() if args.only in p[0]]
    for k, p in enumerate(todo, 1):
        print(f"[{k}/{len(todo)}] {p[0]}", file=sys.stderr, flush=True)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            rows.append(one(*p, shifts=(-75, -50, -25, 0, 25, 50, 75) if args.shifts else ()))
        r = rows[-1]
        print(f"    match {r['match']}, shared {r['shared_m']:.0f} m, speed match "
              f"{r['speed_match']}, ratio {r['ratio']:.3f} -> {_f(r['ratio_with'], '.3f')} "
              f"({'carried' if r['carried'] else r['why']}); shared rows {r['shared_rows']}, "
              f"revisit {r['revisit']}", file=sys.stderr, flush=True)
        for sh, e in r.get("shifted", {}).items():
            print(f"    profile moved {sh:+d} m: shared-route error {e:.1f} W", file=sys.stderr)
    text = table(rows)
    print(text)
    if args.out is not None:
        page = _page(args.out.read_text() if args.out.exists() else "", text)
        atomic_write(args.out, lambda path: Path(path).write_text(page))
    return 0


def _page(old: str, text: str) -> str:
    """``old`` with the block between :data:`BEGIN` and :data:`END` replaced by the table."""
    block = f"{BEGIN}\n`{COMMAND}`\n\n{text}\n{END}"
    if BEGIN in old and END in old:
        head, rest = old.split(BEGIN, 1)
        return head + block + rest.split(END, 1)[1]
    return f"# The road's grade along a shared route\n\n{block}\n"


if __name__ == "__main__":
    raise SystemExit(main())

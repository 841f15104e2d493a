"""The road's grade along a route two rides share: read on the fit ride, carried to the test ride.

Without GPS altitude a grade that varies along the road is a function of
position: one ride cannot validate it (each position is seen once), but a second
ride of the same route can carry it (docs/route_grade.md).  With the rides
matched (:func:`euc_sim.rides.grids.route.match_routes`):

1. :func:`grade_profile`: sin α per 25 m of the fit ride's route from its residual
   under its selected balance model (bounded, smoothed);
2. :func:`carry_decision`: whether to carry it, from the fit ride and the match only;
3. :func:`carry_grade`: the test ride's design with the carried grade's power
   m·g·v·sin α in its known demand (gain 1, nothing fitted on the test ride).
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Mapping

import numpy as np

from euc_sim.rides.balance.design import PLAUSIBLE, PRE_WINDOW, Design
from euc_sim.rides.grids.route import BIN_M, MIN_SHARED_M, RouteMatch, RoutePosition
from euc_sim.rides.grids.signals import RideSignals, sg

__all__ = ["GradeProfile", "CarryDecision", "RevisitCheck", "grade_profile", "carried_grade",
           "carry_grade", "revisit_check",
           "carry_decision", "SMOOTH_M", "GRADE_LIMIT", "MAX_ON_BOUND"]

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
    first (:func:`~euc_sim.rides.grids.route.match_by_gps`), the grade read on the first
    half's rows alone (:func:`grade_profile`) and carried to the second.  Each position of the
    second half is held out from the grade it is tested on.
    """
    from euc_sim.rides.grids.route import match_by_gps

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

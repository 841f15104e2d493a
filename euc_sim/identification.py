"""Torques and parameters from a recording: the paper's Section 4, and beyond it.

* :func:`torques` — M_d,1 (eq. 9), M_d,2 (eq. 10), M_h (row 3 of eq. 5) of the 3-DoF
  model and M̄_d,1, M̄_d,2 (eq. 13) of the reduced model, all from
  :mod:`euc_sim.analytic`, with the consistent term filter applied.
* :func:`identify_h` — h minimising RMSE(M_d,1 − M_d,2), both models, per recording
  or pooled, with the whole RMSE(h) curve, a block-bootstrap 95 % interval and an
  identifiability verdict.
* :func:`identify_base_parameters` — where M_d is known, the base-parameter groups
  by linear least squares on the regressor form of eqs. (5)–(8).
* :func:`identify_controller` — M_d ≈ K_p γ + K_d γ̇ (+ more terms) fitted to M_d,2,
  which needs no torque measurement.
* :func:`identify_rider_delay` — a delayed PD law fitted to the estimated M_h.

Why the RMSE curve is cheap: for a fixed recording M_d,1 is affine in h and
M_d,1 − M_d,2 = P(h)/D(h) with P quadratic and D = m_11 R + m_21 + m_31 affine in h
(see :func:`euc_sim.analytic.driving_torque_2`).  :func:`residual_poly` recovers
P's and D's coefficients per sample exactly from three evaluations of the
analytic torques, so RMSE(h) on a whole grid of h is a few array operations.

Consistent filtering: the numerator P is a linear combination, with constant
coefficients, of the terms of the angular-momentum balance about the contact point
(NOTES.md, item 1).  The same Gaussian low-pass is applied to P's three coefficient
series (and hence to every term) while D, which varies by < 1 % along a ride, scales
the filtered balance back to N·m.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
import pandas as pd
from scipy.optimize import minimize_scalar

from euc_sim import analytic
from euc_sim.parameters import Params, TABLE3
from euc_sim.processing import DEFAULT_SMOOTHING, Kinematics, Smoothing, kinematics, term_filter

__all__ = [
    "MODELS", "TORQUE_COLUMNS", "torques_raw", "torques", "ResidualPoly", "residual_poly",
    "HFit", "identify_h", "rmse_curve", "Recording", "load", "identify_recordings",
    "base_regressor", "BASE_GROUPS", "base_groups", "BaseFit", "identify_base_parameters",
    "ControllerFit", "identify_controller", "RiderFit", "identify_rider_delay", "fit_delayed_law",
]

#: The two models: the paper's 3-DoF model and the reduced 2-DoF model (Section 3.2).
MODELS = ("3dof", "2dof")
#: Columns of ``euc-sim torques``' output (CONTRACT.md).
TORQUE_COLUMNS = ("t", "M_d1", "M_d2", "M_h", "M_d1_2dof", "M_d2_2dof")
#: Values of h at which the analytic torques are evaluated to recover their
#: polynomial coefficients in h, m (any three distinct positive values).
_H_NODES = np.array([0.5, 1.0, 1.5])


# --- torques ----------------------------------------------------------------------------
def torques_raw(p: Params, q, qd, qdd) -> dict[str, np.ndarray]:
    """The five torque estimates at ``p.h``, unfiltered, N·m.

    Parameters
    ----------
    p : Params
    q, qd, qdd : array_like, shape (..., 3)

    Returns
    -------
    dict
        ``M_d1`` (eq. 9), ``M_d2`` (eq. 10), ``M_h`` (row 3 of eq. 5), ``M_d1_2dof``,
        ``M_d2_2dof`` (eq. 13).
    """
    return {
        "M_d1": analytic.driving_torque_1(p, q, qd, qdd),
        "M_d2": analytic.driving_torque_2(p, q, qd, qdd),
        "M_h": analytic.rider_torque(p, q, qd, qdd),
        "M_d1_2dof": analytic.reduced_driving_torque_1(p, q, qd, qdd),
        "M_d2_2dof": analytic.reduced_driving_torque_2(p, q, qd, qdd),
    }


def torques(kin: Kinematics, p: Params) -> pd.DataFrame:
    """The torque estimates of a recording, each with the consistent term filter.

    Parameters
    ----------
    kin : Kinematics
        From :func:`euc_sim.processing.kinematics`.
    p : Params
        Parameters, ``p.h`` the rider's height used.

    Returns
    -------
    DataFrame
        Columns :data:`TORQUE_COLUMNS`, N·m; every row of the recording (the first and
        last ``kin.smoothing.edge`` rows have less filter support).
    """
    sig = kin.smoothing.sigma_samples(kin.dt)
    raw = torques_raw(p, kin.q, kin.qd, kin.qdd)
    out = {"t": kin.t}
    out.update({k: term_filter(v, sig) for k, v in raw.items()})
    return pd.DataFrame(out, columns=list(TORQUE_COLUMNS))


# --- the residual as a rational function of h ---------------------------------------------
def _model_functions(model: str):
    if model == "3dof":
        return analytic.driving_torque_1, analytic.driving_torque_2, lambda p: p
    if model == "2dof":
        return (analytic.reduced_driving_torque_1, analytic.reduced_driving_torque_2,
                lambda p: p.reduced())
    raise ValueError(f"model must be one of {', '.join(MODELS)}, got {model!r}")


@dataclass(frozen=True)
class ResidualPoly:
    """M_d,1 − M_d,2 of one recording as P(h)/D(h), filtered, interior samples only.

    Attributes
    ----------
    model : str
    P : ndarray, shape (3, N)
        Coefficients of h⁰, h¹, h² of the numerator (M_d,1 − M_d,2)·D, term-filtered,
        N·m·kg·m per power of h.
    D : ndarray, shape (2, N)
        Coefficients of h⁰, h¹ of D = m_11 R + m_21 + m_31, kg·m.
    t : ndarray, shape (N,)
    """

    model: str
    P: np.ndarray
    D: np.ndarray
    t: np.ndarray

    def residual(self, h) -> np.ndarray:
        """M_d,1 − M_d,2 (filtered) for scalar h → (N,) or h of shape (K,) → (K, N), N·m."""
        h = np.asarray(h, dtype=float)[..., None]
        return (self.P[0] + h * (self.P[1] + h * self.P[2])) / (self.D[0] + h * self.D[1])

    def sum_squares(self, h) -> np.ndarray:
        """Σ_t residual², N²·m², for scalar or (K,) h."""
        return np.sum(self.residual(h) ** 2, axis=-1)

    @property
    def n(self) -> int:
        """Number of samples."""
        return self.P.shape[1]


def _lagrange_coefficients(nodes: np.ndarray, values: np.ndarray) -> np.ndarray:
    """Coefficients (c0, c1, c2, ...) of the polynomial through (nodes, values), per column."""
    V = np.vander(nodes, len(nodes), increasing=True)
    return np.linalg.solve(V, values.reshape(len(nodes), -1)).reshape(values.shape)


def residual_poly(kin: Kinematics, p: Params, model: str = "3dof") -> ResidualPoly:
    """The exact polynomial form in h of M_d,1 − M_d,2 for one recording.

    Evaluates the analytic torques (eqs. 9, 10 or 13) at three values of h, recovers
    the coefficients of the numerator P(h) = (M_d,1 − M_d,2)·D(h) and of the
    denominator D(h) = m_11 R + m_21 + m_31 (reduced: m_21 = 0), filters P's
    coefficients with the term filter, and keeps the interior samples.

    Parameters
    ----------
    kin : Kinematics
    p : Params
        Every parameter but h is used.
    model : {"3dof", "2dof"}

    Returns
    -------
    ResidualPoly
    """
    md1, md2, mass_params = _model_functions(model)
    num, den = [], []
    for h in _H_NODES:
        ph = p.replace(h=float(h))
        M = analytic.mass_matrix(mass_params(ph), kin.q)
        D = M[..., 0, 0] * ph.R + M[..., 1, 0] + M[..., 2, 0]
        num.append((md1(ph, kin.q, kin.qd, kin.qdd) - md2(ph, kin.q, kin.qd, kin.qdd)) * D)
        den.append(D)
    P = _lagrange_coefficients(_H_NODES, np.array(num))
    D1 = (den[1] - den[0]) / (_H_NODES[1] - _H_NODES[0])
    D = np.array([den[0] - _H_NODES[0] * D1, D1])
    P = term_filter(P, kin.smoothing.sigma_samples(kin.dt), axis=-1)
    sl = kin.interior
    return ResidualPoly(model=model, P=P[:, sl], D=D[:, sl], t=kin.t[sl])


# --- identifying h ---------------------------------------------------------------------------
@dataclass
class HFit:
    """h identified from one or several recordings, one model.

    Attributes
    ----------
    model : str
    h : float
        Minimiser of RMSE(M_d,1 − M_d,2), m.
    rmse : float
        RMSE at the minimum, N·m.
    h_ci95 : tuple of float
        95 % moving-block bootstrap interval (basic, i.e. reverse percentile), m,
        clipped to the search bounds (NaN without bootstrap).
    identifiable : bool
        False when the curve is flat: the minimum lies at a search bound, the
        interval touches a bound or is wider than ``max_ci_width``, or the RMSE rises
        by less than ``min_rise`` within ±0.1 m.
    flatness : float
        RMSE(h ± 0.1 m)/RMSE(h) − 1, the smaller side: how much the curve rises.
    h_grid, rmse_grid : ndarray
        The RMSE(h) curve, m and N·m.
    boot : ndarray
        Bootstrap minimisers, m.
    n_samples : int
    reason : str
        One sentence on the verdict.
    """

    model: str
    h: float
    rmse: float
    h_ci95: tuple
    identifiable: bool
    flatness: float
    h_grid: np.ndarray
    rmse_grid: np.ndarray
    boot: np.ndarray = field(repr=False)
    n_samples: int = 0
    reason: str = ""

    def as_json(self, curve: bool = True) -> dict:
        """The CONTRACT form (``h, h_ci95, rmse, identifiable``) plus extras."""
        out = {"h": self.h, "h_ci95": list(self.h_ci95), "rmse": self.rmse,
               "identifiable": bool(self.identifiable), "flatness": self.flatness,
               "n_samples": self.n_samples, "reason": self.reason}
        if curve:
            out["curve"] = {"h": self.h_grid, "rmse": self.rmse_grid}
        return out


def rmse_curve(polys: list[ResidualPoly], h_grid: np.ndarray) -> np.ndarray:
    """Pooled RMSE(M_d,1 − M_d,2) on a grid of h, N·m."""
    ss = sum(rp.sum_squares(h_grid) for rp in polys)
    return np.sqrt(ss / sum(rp.n for rp in polys))


def _parabolic_min(grid: np.ndarray, J: np.ndarray) -> np.ndarray:
    """Grid minimiser along the last axis refined by a parabola through 3 points."""
    k = np.clip(np.argmin(J, axis=-1), 1, J.shape[-1] - 2)
    idx = np.arange(J.shape[0]) if J.ndim == 2 else None
    if J.ndim == 1:
        j0, j1, j2 = J[k - 1], J[k], J[k + 1]
    else:
        j0, j1, j2 = J[idx, k - 1], J[idx, k], J[idx, k + 1]
    den = j0 - 2 * j1 + j2
    step = grid[1] - grid[0]
    off = np.where(den > 0, 0.5 * (j0 - j2) / np.where(den > 0, den, 1.0), 0.0)
    return grid[k] + np.clip(off, -1.0, 1.0) * step


#: Moving-block bootstrap block, s.  The residual of the consistently filtered torques is
#: correlated over about three term-filter σ (0.3 s), i.e. ~1 s; longer blocks are fewer
#: per ride and, when a ride's information sits in one braking event, make the interval
#: too narrow.  On 100 noise seeds not used to choose it (scripts/coverage_study.py
#: --first-seed 50 --seeds 100) 1 s blocks cover the true h in 91 % (deceleration) and
#: 93 % (acceleration) of rides, 2 s blocks in 88 % and 91 %.
BOOTSTRAP_BLOCK = 1.0


def _block_sums(x: np.ndarray, L: int, starts: np.ndarray) -> np.ndarray:
    """Sums of x (K, N) over the drawn blocks [s, s + L) of each replicate → (n_boot, K).

    Only the ratio to the total drawn length matters for the minimiser, and every
    recording contributes ceil(N/L) blocks of L samples, so sums are not normalised.
    """
    cs = np.concatenate([np.zeros((x.shape[0], 1)), np.cumsum(x, axis=1)], axis=1)
    return (cs[:, starts + L] - cs[:, starts]).sum(axis=2).T


def identify_h(polys: list[ResidualPoly], bounds=(0.1, 1.5), grid_step: float = 0.02,
               n_boot: int = 400, block: float = BOOTSTRAP_BLOCK, seed: int = 0,
               max_ci_width: float = 0.15, min_rise: float = 0.2) -> HFit:
    """Minimise the pooled RMSE(M_d,1 − M_d,2) over h in ``bounds``.

    A grid search (``grid_step``) keeps the whole curve; a bounded Brent search
    (``scipy.optimize.minimize_scalar``) in the bracket around the grid minimum
    refines it.  The 95 % interval is a moving-block bootstrap over time: per
    recording, blocks of ``block`` seconds are drawn with replacement (seeded), the
    minimiser is recomputed on the grid (parabolic refinement), and the basic
    (reverse-percentile) interval [2ĥ − q97.5, 2ĥ − q2.5] is reported.

    Parameters
    ----------
    polys : list of ResidualPoly
        One per recording, same model.
    bounds : (float, float)
        Search interval for h, m.
    grid_step : float
        Grid spacing, m.
    n_boot : int
        Bootstrap replicates (0: no interval, verdict from the curve only).
    block : float
        Block length, s.
    seed : int
        Seed of the bootstrap draws.
    max_ci_width : float
        Widest 95 % interval still called identifiable, m.
    min_rise : float
        Smallest relative rise of the RMSE within ±0.1 m of the minimum still called
        identifiable (a flatter curve lets the noise pick h: on a simulated
        constant-speed ride with 1.5° of sway h came out 0.54-0.61 m with rises of
        5-10 %; braking and accelerating rides rise by 100-300 %).

    Returns
    -------
    HFit
    """
    lo, hi = map(float, bounds)
    if not (0 < lo < hi):
        raise ValueError(f"h bounds must satisfy 0 < lo < hi, got {bounds!r}")
    if not polys:
        raise ValueError("no recordings to identify h from")
    model = polys[0].model
    grid = np.linspace(lo, hi, int(round((hi - lo) / grid_step)) + 1)
    n_tot = sum(rp.n for rp in polys)
    rng = np.random.default_rng(seed)
    draws = []                                     # bootstrap block starts per recording
    ss = np.zeros(len(grid))
    boot_tot = np.zeros((n_boot, len(grid)))
    for rp in polys:                               # one recording at a time: (K, N_i) arrays
        x = rp.residual(grid) ** 2
        ss += x.sum(axis=1)
        if n_boot > 0:
            dt = float(rp.t[1] - rp.t[0]) if rp.n > 1 else 1.0
            L = int(min(max(1, round(block / dt)), rp.n))
            starts = rng.integers(0, rp.n - L + 1, size=(n_boot, int(math.ceil(rp.n / L))))
            draws.append((L, starts))
            boot_tot += _block_sums(x, L, starts)
    J = ss / n_tot
    k = int(np.argmin(J))
    a, b = grid[max(k - 1, 0)], grid[min(k + 1, len(grid) - 1)]
    f = lambda h: float(sum(rp.sum_squares(h) for rp in polys)) / n_tot      # noqa: E731
    res = minimize_scalar(f, bounds=(a, b), method="bounded", options={"xatol": 1e-10})
    h_opt = float(res.x) if res.fun <= J[k] else float(grid[k])
    rmse = math.sqrt(min(res.fun, J[k]))

    boot = np.array([])
    ci = (math.nan, math.nan)
    if n_boot > 0:
        boot = _parabolic_min(grid, boot_tot)
        # refine twice on finer grids spanning the replicates' minima (the same draws)
        step = grid[1] - grid[0]
        for _ in range(2):
            fine = np.linspace(max(lo, boot.min() - step), min(hi, boot.max() + step), 41)
            fine_tot = np.zeros((n_boot, len(fine)))
            for rp, (L, starts) in zip(polys, draws):
                fine_tot += _block_sums(rp.residual(fine) ** 2, L, starts)
            boot = _parabolic_min(fine, fine_tot)
            step = 2 * (fine[1] - fine[0])
        # basic (reverse-percentile) interval: the replicates' spread reflected about
        # h_opt.  Resampling blocks of a ride whose information sits in one maneuver
        # skews the replicates; the plain percentile interval then covered the true h
        # in only 74-80 % of 50 noise seeds, the basic one in 90-94 %
        # (scripts/coverage_study.py).
        q_lo, q_hi = np.percentile(boot, [2.5, 97.5])
        ci = (float(max(lo, 2 * h_opt - q_hi)), float(min(hi, 2 * h_opt - q_lo)))

    curve = np.sqrt(J)
    side = [np.interp(h_opt + d, grid, curve) for d in (-0.1, 0.1) if lo <= h_opt + d <= hi]
    flatness = float(min(side) / rmse - 1.0) if side and rmse > 0 else math.inf
    margin = 2 * grid_step
    if h_opt < lo + margin or h_opt > hi - margin:
        ok, why = False, f"the minimum lies at the search bound ({h_opt:.3f} m in [{lo}, {hi}] m)"
    elif n_boot > 0 and (ci[0] < lo + margin or ci[1] > hi - margin):
        ok, why = False, (f"the 95% interval [{ci[0]:.3f}, {ci[1]:.3f}] m reaches the search "
                          f"bound: the RMSE curve is flat")
    elif n_boot > 0 and ci[1] - ci[0] > max_ci_width:
        ok, why = False, (f"the 95% interval is {ci[1] - ci[0]:.3f} m wide (> {max_ci_width} m): "
                          f"the RMSE curve is flat")
    elif flatness < min_rise:
        ok, why = False, (f"the RMSE rises only {100 * flatness:.1f}% within ±0.1 m of the minimum "
                          f"(< {100 * min_rise:.0f}%): the curve is flat and h is at the mercy "
                          f"of the noise")
    else:
        ok, why = True, (f"interior minimum, RMSE rises {100 * flatness:.1f}% within ±0.1 m"
                         + (f", 95% interval {ci[1] - ci[0]:.3f} m wide" if n_boot > 0 else ""))
    return HFit(model=model, h=h_opt, rmse=rmse, h_ci95=ci, identifiable=ok, flatness=flatness,
                h_grid=grid, rmse_grid=curve, boot=boot, n_samples=n_tot, reason=why)


# --- recordings, end to end ------------------------------------------------------------------
@dataclass
class Recording:
    """A loaded recording: its data, metadata, parameters and kinematics."""

    name: str
    df: pd.DataFrame
    meta: dict
    params: Params
    kin: Kinematics


def load(path, smoothing: Smoothing = DEFAULT_SMOOTHING, params: Params | None = None,
         d_CE: float | None = None, phi_from: str = "A", source: str = "auto") -> Recording:
    """Read, validate and differentiate one recording.

    Parameters
    ----------
    path : path
    smoothing : Smoothing
    params : Params, optional
        Overrides the sidecar's parameters (else Table 3 with the sidecar's entries).
    d_CE : float, optional
        C–E distance for motion-capture files, m (else the sidecar's ``"d_CE"``).
    phi_from : {"A", "C"}
        The exact rider pitch (default) or eq. (3), motion-capture files only.
    source : {"auto", "state", "mocap"}
        See :func:`euc_sim.processing.kinematics`.

    Raises
    ------
    euc_sim.recordings.RecordingError, FileNotFoundError
    """
    from euc_sim.recordings import params_from_meta, read_recording

    df, meta = read_recording(path)
    p = params if params is not None else params_from_meta(meta, path)
    if d_CE is None and meta.get("d_CE") is not None:
        d_CE = float(meta["d_CE"])
    kin = kinematics(df, p, smoothing, d_CE=d_CE, phi_from=phi_from, name=str(path), source=source)
    return Recording(name=str(path), df=df, meta=meta, params=p, kin=kin)


def identify_recordings(recs: list[Recording], bounds=(0.1, 1.5), grid_step: float = 0.02,
                        n_boot: int = 400, block: float = BOOTSTRAP_BLOCK, seed: int = 0,
                        max_ci_width: float = 0.15) -> dict:
    """Per-recording and pooled h for both models.

    Returns
    -------
    dict
        ``{"pooled": {model: HFit}, "per_recording": [{model: HFit}, ...],
        "polys": [{model: ResidualPoly}, ...]}``.
    """
    kw = dict(bounds=bounds, grid_step=grid_step, n_boot=n_boot, block=block,
              max_ci_width=max_ci_width)
    polys = [{m: residual_poly(r.kin, r.params, m) for m in MODELS} for r in recs]
    per = [{m: identify_h([pp[m]], seed=seed + i, **kw) for m in MODELS}
           for i, pp in enumerate(polys)]
    pooled = ({m: identify_h([pp[m] for pp in polys], seed=seed, **kw) for m in MODELS}
              if len(recs) > 1 else per[0])
    return {"pooled": pooled, "per_recording": per, "polys": polys}


# --- beyond the paper: base parameters where M_d is known ------------------------------------
#: The base-parameter groups of eqs. (5)-(8) and how each follows from Table 3.
BASE_GROUPS = {
    "m_11": "m + m0 + mw + Jw/R²",
    "m0h0 - ml0": "m0·h0 − m·l0",
    "mh": "m·h",
    "J0 + m0h0² + ml0²": "J0 + m0·h0² + m·l0²",
    "mhl0": "m·h·l0",
    "J + mh²": "J + m·h²",
}


def base_groups(p: Params) -> np.ndarray:
    """The values of :data:`BASE_GROUPS` for a parameter set (SI)."""
    return np.array([p.m_eq, p.m0 * p.h0 - p.m * p.l0, p.m * p.h,
                     p.J0 + p.m0 * p.h0**2 + p.m * p.l0**2, p.m * p.h * p.l0, p.J + p.m * p.h**2])


def base_regressor(q, qd, qdd, g: float = TABLE3.g) -> np.ndarray:
    """Regressor Y with inverse_dynamics(p, q, q̇, q̈) = Y(q, q̇, q̈) · base_groups(p).

    Eqs. (5)-(8) are linear in the six groups of :data:`BASE_GROUPS`; column k holds
    ∂(M q̈ + h − Q_gravity)/∂θ_k.  ``tests/test_identification.py`` checks the
    identity against :func:`euc_sim.analytic.inverse_dynamics` for random parameters.

    Returns
    -------
    ndarray, shape (..., 3, 6)
    """
    q, qd, qdd = (np.asarray(a, dtype=float) for a in (q, qd, qdd))
    _, ga, ph = q[..., 0], q[..., 1], q[..., 2]
    _, gd, pd_ = qd[..., 0], qd[..., 1], qd[..., 2]
    xdd, gdd, pdd = qdd[..., 0], qdd[..., 1], qdd[..., 2]
    Y = np.zeros(ga.shape + (3, 6))
    c_pg, s_pg = np.cos(ph - ga), np.sin(ph - ga)
    # row 1 (x): m11 ẍ + m12 γ̈ + m13 φ̈ + h1, eqs. (6)-(7)
    Y[..., 0, 0] = xdd
    Y[..., 0, 1] = np.cos(ga) * gdd - gd**2 * np.sin(ga)
    Y[..., 0, 2] = np.cos(ph) * pdd - pd_**2 * np.sin(ph)
    # row 2 (γ): m21 ẍ + m22 γ̈ + m23 φ̈ + h2 − Q2_gravity, eq. (8)
    Y[..., 1, 1] = np.cos(ga) * xdd - g * np.sin(ga)
    Y[..., 1, 3] = gdd
    Y[..., 1, 4] = -c_pg * pdd + pd_**2 * s_pg
    # row 3 (φ)
    Y[..., 2, 2] = np.cos(ph) * xdd - g * np.sin(ph)
    Y[..., 2, 4] = -c_pg * gdd - gd**2 * s_pg
    Y[..., 2, 5] = pdd
    return Y


@dataclass
class BaseFit:
    """Base-parameter groups from a recording with known torques.

    Attributes
    ----------
    names : list of str
    estimate, std_error : ndarray
        SI units of each group.
    nominal : ndarray
        The groups from the parameters the recording was processed with.
    identifiable : ndarray of bool
        Relative standard error below ``rel_tol``, sensitivity above
        ``min_sensitivity`` and the column outside the numerical null space.
    condition_number : float
        Of the column-normalised regressor.
    rows : str
        Which equations were used.
    rmse : float
        Residual of the fit, N·m (row 1 is scaled by R).
    sensitivity : ndarray
        Relative RMS change of the fitted torques for a 10 % error in each group,
        the others compensating.
    """

    names: list
    estimate: np.ndarray
    std_error: np.ndarray
    nominal: np.ndarray
    identifiable: np.ndarray
    condition_number: float
    rows: str
    rmse: float
    sensitivity: np.ndarray = None

    def as_json(self) -> dict:
        return {"condition_number": self.condition_number, "rows": self.rows, "rmse": self.rmse,
                "groups": [{"name": n, "formula": BASE_GROUPS[n], "estimate": e, "std_error": s,
                            "nominal": v, "identifiable": bool(i), "sensitivity": z}
                           for n, e, s, v, i, z in zip(self.names, self.estimate, self.std_error,
                                                       self.nominal, self.identifiable,
                                                       self.sensitivity)]}


def identify_base_parameters(kin: Kinematics, M_d, M_h=None, p: Params = TABLE3,
                             rel_tol: float = 0.1, min_sensitivity: float = 1e-4) -> BaseFit:
    """All base-parameter groups by linear least squares where M_d is known.

    Uses R·row 1 = M_d and row 2 + row 3 = −M_d (M_h cancels), plus rows 2 and 3
    separately when M_h is known too.  Every regressor column and the torques get
    the same term filter (consistent filtering); edge samples are dropped.

    Parameters
    ----------
    kin : Kinematics
    M_d : array_like, shape (N,)
        Known driving torque, N·m.
    M_h : array_like, optional
        Known ankle torque, N·m.
    p : Params
        Supplies g and the nominal values reported beside the estimates.
    rel_tol : float
        Largest relative standard error of an identifiable group (standard errors
        allow for the residual's correlation over the filter's length).
    min_sensitivity : float
        Smallest relative change of the fitted torques (RMS, as a fraction of the
        torques' RMS) that a 10 % error in the group causes after the other groups
        compensate; below it the group is called not identifiable.

    Returns
    -------
    BaseFit
    """
    sig = kin.smoothing.sigma_samples(kin.dt)
    sl = kin.interior
    Y = base_regressor(kin.q, kin.qd, kin.qdd, p.g)                 # (N, 3, 6)
    M_d = np.asarray(M_d, dtype=float)
    blocks_A = [p.R * Y[:, 0, :], Y[:, 1, :] + Y[:, 2, :]]
    blocks_b = [M_d, -M_d]
    rows = "R·row1 = M_d; row2 + row3 = −M_d"
    if M_h is not None:
        M_h = np.asarray(M_h, dtype=float)
        blocks_A = [p.R * Y[:, 0, :], Y[:, 1, :], Y[:, 2, :]]
        blocks_b = [M_d, M_h - M_d, -M_h]
        rows = "R·row1 = M_d; row2 = M_h − M_d; row3 = −M_h"
    A = np.concatenate([term_filter(a, sig, axis=0)[sl] for a in blocks_A])
    b = np.concatenate([term_filter(v, sig)[sl] for v in blocks_b])
    scale = np.linalg.norm(A, axis=0)
    scale[scale == 0] = 1.0
    As = A / scale
    U, s, Vt = np.linalg.svd(As, full_matrices=False)
    tol = s[0] * max(As.shape) * np.finfo(float).eps * 1e3
    rank = int((s > tol).sum())
    s_inv = np.where(s > tol, 1.0 / np.where(s > tol, s, 1.0), 0.0)
    theta_s = Vt.T @ (s_inv * (U.T @ b))
    resid = b - As @ theta_s
    dof = max(len(b) - rank, 1)
    # the filtered residual is correlated over ~2√π σ samples (Gaussian term filter) or
    # a window (paper's recipe): inflate the white-noise variance by that length
    corr = 2 * math.sqrt(math.pi) * sig if sig > 0 else kin.smoothing.samples(kin.dt)
    sigma2 = float(resid @ resid) / dof * max(1.0, corr)
    cov_s = (Vt.T * s_inv**2) @ Vt * sigma2
    est = theta_s / scale
    se = np.sqrt(np.diag(cov_s)) / scale
    null = np.abs(Vt[rank:]).max(axis=0) > 1e-6 if rank < len(s) else np.zeros(len(s), bool)
    # sensitivity: RMS change of the fitted torques when a group is off by 10 % and the
    # others re-fit to compensate, relative to the torques' RMS; independent of the
    # residual, which on clean data is derivative error rather than white noise
    inv_diag = np.diag((Vt.T * s_inv**2) @ Vt) / scale**2
    with np.errstate(divide="ignore", invalid="ignore"):
        rel = se / np.abs(est)
        sens = (0.1 * np.abs(est) / np.sqrt(inv_diag * len(b))) / np.sqrt(np.mean(b**2))
    ident = (~null) & (rel < rel_tol) & (sens > min_sensitivity)
    cond = float(s[0] / s[-1]) if s[-1] > 0 else math.inf
    return BaseFit(names=list(BASE_GROUPS), estimate=est, std_error=se, nominal=base_groups(p),
                   identifiable=ident, condition_number=cond, rows=rows,
                   rmse=float(np.sqrt(np.mean(resid**2))), sensitivity=sens)


# --- beyond the paper: the EUC's controller and the rider's law ------------------------------
#: Regressors available to the controller and rider fits.
_TERMS = {
    "gamma": lambda kin: kin.q[:, 1], "gamma_d": lambda kin: kin.qd[:, 1],
    "phi": lambda kin: kin.q[:, 2], "phi_d": lambda kin: kin.qd[:, 2],
    "x_d": lambda kin: kin.qd[:, 0], "x_dd": lambda kin: kin.qdd[:, 0],
    "const": lambda kin: np.ones(len(kin.t)),
}
_UNITS = {"gamma": "N·m/rad", "gamma_d": "N·m·s/rad", "phi": "N·m/rad", "phi_d": "N·m·s/rad",
          "x_d": "N·s", "x_dd": "N·s²", "const": "N·m"}
_PAPER_NAMES = {"gamma": "K_p", "gamma_d": "K_d"}


@dataclass
class ControllerFit:
    """A linear law torque ≈ Σ gain_k · term_k fitted by least squares.

    Attributes
    ----------
    gains : dict of str to float
        Per term (``gamma`` → K_p, ``gamma_d`` → K_d, ...), SI (see ``units``).
    units : dict of str to str
    r2 : float
        Coefficient of determination.
    rmse : float
        N·m.
    delay : float
        Delay of the regressors, s (0 for the motor law).
    """

    gains: dict
    units: dict
    r2: float
    rmse: float
    delay: float = 0.0

    def as_json(self) -> dict:
        return {"gains": self.gains, "units": self.units, "r2": self.r2, "rmse": self.rmse,
                "delay": self.delay}


def _lstsq_fit(y: np.ndarray, X: np.ndarray) -> tuple[np.ndarray, float, float]:
    coef, *_ = np.linalg.lstsq(X, y, rcond=None)
    res = y - X @ coef
    ss = float(np.sum((y - y.mean()) ** 2))
    r2 = 1.0 - float(res @ res) / ss if ss > 0 else math.nan
    return coef, r2, float(np.sqrt(np.mean(res**2)))


def _check_terms(terms, what: str) -> None:
    unknown = [t for t in terms if t not in _TERMS]
    if unknown:
        raise ValueError(f"unknown {what} term {unknown[0]!r}; expected {', '.join(_TERMS)}")


def _filtered_rows(kin: Kinematics, y: np.ndarray, terms) -> tuple[np.ndarray, np.ndarray]:
    """Target y and the named regressors through the same term filter, interior samples."""
    sig = kin.smoothing.sigma_samples(kin.dt)
    sl = kin.interior
    X = np.column_stack([term_filter(_TERMS[t](kin), sig)[sl] for t in terms])
    return term_filter(y, sig)[sl], X


def _controller_rows(kin: Kinematics, p: Params, terms) -> tuple[np.ndarray, np.ndarray]:
    """Filtered M_d,2 and regressors of one recording, interior samples."""
    return _filtered_rows(kin, analytic.driving_torque_2(p, kin.q, kin.qd, kin.qdd), terms)


def identify_controller(kin, p, terms=("gamma", "gamma_d")) -> ControllerFit:
    """The EUC's controller: M_d,2 ≈ Σ K_k · term_k (default K_p γ + K_d γ̇).

    M_d,2 (eq. 10) needs no torque measurement and no ẍ.  Target and regressors get
    the same term filter, which a linear law passes through unchanged.

    Parameters
    ----------
    kin : Kinematics or list of Kinematics
        One recording, or several pooled into one least-squares fit.
    p : Params or list of Params
        With the rider height h to use (identified or known); one per recording.
    terms : sequence of str
        From ``gamma, gamma_d, x_d, x_dd, phi, phi_d, const``.

    Returns
    -------
    ControllerFit
    """
    _check_terms(terms, "controller")
    kins = kin if isinstance(kin, (list, tuple)) else [kin]
    ps = p if isinstance(p, (list, tuple)) else [p] * len(kins)
    rows = [_controller_rows(k, pp, terms) for k, pp in zip(kins, ps)]
    y = np.concatenate([r[0] for r in rows])
    X = np.concatenate([r[1] for r in rows])
    coef, r2, rmse = _lstsq_fit(y, X)
    return ControllerFit(gains={t: float(c) for t, c in zip(terms, coef)},
                         units={t: _UNITS[t] for t in terms}, r2=r2, rmse=rmse)


@dataclass
class RiderFit(ControllerFit):
    """The rider's delayed law; ``delay_curve`` holds (delays, rmse)."""

    delay_curve: tuple = ()

    def as_json(self) -> dict:
        out = super().as_json()
        out["delay_curve"] = {"delay": self.delay_curve[0], "rmse": self.delay_curve[1]}
        return out


def identify_rider_delay(kin: Kinematics, p: Params, terms=("phi", "phi_d", "const"),
                         max_delay: float = 0.5) -> RiderFit:
    """M_h(t) ≈ Σ k_j · term_j(t − τ): a delayed PD law, τ by a search over samples.

    M_h is row 3 of eq. (5) (:func:`euc_sim.analytic.rider_torque`); for each delay
    from 0 to ``max_delay`` the gains are a least-squares fit, and the delay with the
    smallest residual is reported.

    Parameters
    ----------
    kin : Kinematics
    p : Params
    terms : sequence of str
    max_delay : float
        Longest delay tried, s.

    Returns
    -------
    RiderFit
    """
    _check_terms(terms, "rider")
    y, X = _filtered_rows(kin, analytic.rider_torque(p, kin.q, kin.qd, kin.qdd), terms)
    fit = fit_delayed_law(y, X, kin.dt, max_delay)
    coef = fit.pop("coef")
    return RiderFit(gains={t: float(c) for t, c in zip(terms, coef)},
                    units={t: _UNITS[t] for t in terms}, **fit)


def fit_delayed_law(y: np.ndarray, X: np.ndarray, dt: float, max_delay: float) -> dict:
    """y(t) ≈ X(t − τ) · coef, τ a whole number of samples in [0, max_delay].

    For each delay the coefficients are a least-squares fit on the overlapping
    samples; the delay with the smallest residual RMSE wins.

    Parameters
    ----------
    y : ndarray, shape (N,)
    X : ndarray, shape (N, k)
    dt : float
        Sample period, s.
    max_delay : float
        Longest delay tried, s.

    Returns
    -------
    dict
        ``coef``, ``r2``, ``rmse``, ``delay`` (s) and ``delay_curve`` (delays s, rmse).
    """
    n_max = int(min(round(max_delay / dt), len(y) // 2))
    fits = [_lstsq_fit(y[n:], X[: len(X) - n]) for n in range(n_max + 1)]
    rm = np.array([f[2] for f in fits])
    best = int(np.argmin(rm))
    coef, r2, rmse = fits[best]
    return {"coef": coef, "r2": r2, "rmse": rmse, "delay": round(best * dt, 9),
            "delay_curve": (np.arange(n_max + 1) * dt, rm)}

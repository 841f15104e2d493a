"""Missing physics: locate the mismatch, name what the nominal model left out, model it.

The pipeline (docs/diagnosis.md has the derivation):

1. Filter the recording with one linear filter applied consistently to q, q̇, q̈
   (and to M_d where recorded): :mod:`euc_sim.identification.processing` (NOTES fact 4).
2. The observable residual.  Without torques: r = M_d,1 − M_d,2 (eqs. 9-10)
   = κ(q)·(moment about the contact point P of whatever the model leaves out);
   with M_d recorded, also the wheel row r_w = M_d,1 − M_d = R·Q_e,x.
   r depends on the nuisance h as κ(h)·(e₀ + e₁h + e₂h²) (eq. 6: m_13 ∝ h,
   m_33 = J + m h²), so it is evaluated for any h in closed form.
3. Candidate terms, one per catalog effect, from its physics: κ·(R Q_e,x + Q_e,γ +
   Q_e,φ) with Q_e from :func:`euc_sim.simulation.effects.generalized_force` (virtual power, the
   paper's Appendix A), or a finite-difference sensitivity of the residual for
   parameter and measurement effects (rider mass, h drift, time offset).
4. Selection (:mod:`euc_sim.identification.selection`): forward stepwise, blocked held-out RMSE,
   BIC with an effective sample count, jointly with h; aliases; a generic
   periodic basis and the noise floor decide ``unexplained``.
5. Localisation: windows where the squared residual concentrates; correlations
   with speed, acceleration, lean, tilt and yaw rate.
6. Model it: the accepted effects injected into the simulator (analytic or
   MuJoCo, :func:`euc_sim.simulation.engine.simulate`), the maneuver re-simulated with the
   same controllers, recording vs nominal vs augmented.

Public API: :func:`diagnose`, :func:`json_view`, :func:`prepare`,
:func:`residual_model`, :func:`build_problem`, :func:`localise`,
:func:`noise_floor`, :func:`visibility`, :func:`resimulate_recording`,
:data:`THRESHOLDS`; the terminal summary and the report are in
:mod:`euc_sim.diagnosis.report`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any, Callable, Mapping

import numpy as np
import pandas as pd

from euc_sim.identification import selection as sel
from euc_sim.model import analytic
from euc_sim.model.parameters import Params
from euc_sim.simulation import effects

__all__ = ["DiagnosisError", "Thresholds", "THRESHOLDS", "Prepared", "prepare",
           "ResidualModel", "residual_model", "build_problem", "localise", "noise_floor",
           "diagnose", "json_view", "visibility", "resimulate_recording"]


class DiagnosisError(ValueError):
    """Invalid input to the diagnosis; the message names the argument."""


@dataclass(frozen=True)
class Thresholds:
    """Decision thresholds of the diagnosis (dimensionless unless stated).

    The acceptance thresholds were set a priori; ``generic_gain`` and ``floor_ratio``
    from null recordings only (``scripts/blind_study.py --calibrate``, seed 1000, a
    different stream from the study's): over 12 nulls with the paper's noise and a
    swaying rider the largest generic gain was 0.17 and the largest floor ratio 1.06;
    the thresholds sit well above both.  Never tuned on the blind-study cases.
    Rechecked on 24 nulls (``--calibrate --nulls 24``): largest generic gain 0.17,
    floor ratio 1.29, BIC drop of the best candidate 2.3 (threshold 10).  On nulls the
    best candidate's held-out gain reached 0.17 and its |θ|/se 6.3 (a two-column h
    drift; 14 before selection.covariance was raised to the autocorrelation-scaled
    variance): those two tests do not separate nulls on their own; the BIC does.
    All at the default term filter (0.3 s); a heavier filter widens the null
    distribution (at 0.5 s: floor ratio 1.76, generic gain 0.26, BIC drop 4.8), so
    these values belong to it (docs/diagnosis.md, "The term filter").

    Attributes
    ----------
    min_bic_drop : float
        BIC (with n_eff) must drop at least this much to accept a term.
    min_cv_gain : float
        Held-out RMSE must drop at least this fraction.
    min_t : float
        |estimate| / standard error (cluster sandwich) of an accepted term.
    max_h_halfwidth : float
        h is identifiable when its 95% half-width is at most this, m; otherwise the
        recording cannot decide (a constant force and a wrong h are aliases).
    generic_gain : float
        A generic periodic basis beating the final model by this fraction of held-out
        RMSE means structure is left that no catalogued effect explains.
    floor_ratio : float
        Final held-out RMSE above this multiple of the noise floor, with a generic
        basis also helping by half of ``generic_gain``, means the same.
    unexplained_keep : float
        With structure left unexplained, an accepted effect is named only when it cut
        the held-out RMSE to at most this fraction; otherwise it is listed under
        ``tentative``.
    alias_bic : float
        Another candidate swapped in within this BIC of the accepted set is an alias.
    alias_cosine : float
        |cosine| between two single-column terms above which they are aliases.
    """

    min_bic_drop: float = 10.0
    min_cv_gain: float = 0.08
    min_t: float = 4.0
    max_h_halfwidth: float = 0.15
    generic_gain: float = 0.25
    floor_ratio: float = 2.0
    unexplained_keep: float = 0.5
    alias_bic: float = 10.0
    alias_cosine: float = 0.95


THRESHOLDS = Thresholds()

#: Residual samples kept per second for selection (the filtered residual is smooth).
SELECT_RATE = 30.0
#: Savitzky–Golay window for the tilt and yaw channels, s.
LATERAL_WINDOW = 1.0
#: Rebuilds of the candidate columns at the augmented h (at most), and the change of
#: h, m, below which they stop.
COLUMN_ITERATIONS = 3
COLUMN_H_TOL = 0.01
#: Search interval of h, m.
H_BOUNDS = (0.25, 1.2)
#: Period of the catalog's h drift law, s (effects.cog_height).
DRIFT_PERIOD = 12.0


# --- visibility -------------------------------------------------------------------------
def visibility(columns) -> dict[str, dict]:
    """Which catalog effects a recording with these columns can reveal, and why not.

    Parameters
    ----------
    columns : iterable of str
        The recording's columns.

    Returns
    -------
    dict
        ``{effect: {"visible": bool, "through": str, "reason": str}}``.
    """
    cols = set(columns)
    out = {}
    for name, e in effects.CATALOG.items():
        missing = [c for c in e.needs if c not in cols]
        if missing:
            reason = f"needs column(s) {', '.join(missing)}; {e.hidden_because or 'not in this recording'}"
            out[name] = {"visible": False, "through": "", "reason": reason}
        elif not e.kinematic_visible:
            out[name] = {"visible": True, "through": "wheel row (M_d recorded)",
                         "reason": f"hidden from M_d,1 − M_d,2 ({e.hidden_because}) but not from M_d,1 − M_d"}
        else:
            through = "M_d,1 − M_d,2" + (" and wheel row" if "M_d" in cols else "")
            out[name] = {"visible": True, "through": through, "reason": ""}
    return out


# --- preparing the signals ----------------------------------------------------------------
@dataclass(frozen=True)
class Prepared:
    """A recording differentiated and ready for the residual.

    Attributes
    ----------
    kin : processing.Kinematics
        Short Savitzky–Golay (q, q̇, q̈) of every sample; the consistent term filter
        is still to be applied to each torque term (:func:`processing.term_filter`).
    sigma : float
        The term filter's standard deviation, samples.
    M_d : numpy.ndarray or None
        (N,) recorded driving torque (unfiltered), N·m.
    lateral : dict or None
        Where ``psi`` and ``theta`` are recorded: the smoothed inputs of the lateral
        term, keys :data:`euc_sim.simulation.effects.LATERAL_INPUTS` ((N,) arrays: rad, rad/s,
        rad/s, rad/s²).
    keep : numpy.ndarray
        Absolute indices of the residual samples used (interior of the filters,
        decimated to :data:`SELECT_RATE`).
    params : Params
        Nominal parameters (Table 3 overridden by the sidecar; h is identified).
    meta : dict
        Sidecar metadata.
    name : str
        Recording name.
    noise_sd : dict
        Estimated white-noise standard deviation per channel (m or rad).
    raw : pandas.DataFrame
        The validated recording (not modified).
    """

    kin: Any
    sigma: float
    M_d: np.ndarray | None
    lateral: dict | None
    keep: np.ndarray
    params: Params
    meta: dict
    name: str
    noise_sd: dict
    raw: pd.DataFrame

    @property
    def t(self) -> np.ndarray:
        return self.kin.t

    @property
    def q(self) -> np.ndarray:
        return self.kin.q

    @property
    def qd(self) -> np.ndarray:
        return self.kin.qd

    @property
    def qdd(self) -> np.ndarray:
        return self.kin.qdd

    def shifted(self, tau: float) -> "Prepared":
        """The rider channel advanced by τ s: φ(t + τ), φ̇, φ̈ likewise (undoes a lag τ)."""
        k = self.kin
        arrs = []
        for a in (k.q, k.qd, k.qdd):
            b = a.copy()
            b[:, 2] = np.interp(k.t + tau, k.t, a[:, 2])
            arrs.append(b)
        return replace(self, kin=replace(k, q=arrs[0], qd=arrs[1], qdd=arrs[2]))

    def with_kin(self, q, qd, qdd) -> "Prepared":
        """The same recording with other (q, q̇, q̈) (for noise propagation)."""
        return replace(self, kin=replace(self.kin, q=q, qd=qd, qdd=qdd))

    def filtered(self, y: np.ndarray, sigma: float | None = None) -> np.ndarray:
        """The consistent term filter applied along the last axis, at the kept samples."""
        from euc_sim.identification.processing import term_filter
        return term_filter(y, self.sigma if sigma is None else sigma, axis=-1)[..., self.keep]


def _read(source, meta: Mapping | None):
    from euc_sim.identification import recordings
    if isinstance(source, pd.DataFrame):
        name = str(dict(meta or {}).get("name", "<DataFrame>"))
        df = recordings.validate_recording(source.copy(), name)
        return df, dict(meta or {}), name
    path = Path(source)
    df, file_meta = recordings.read_recording(path)
    return df, {**file_meta, **dict(meta or {})}, path.name


def prepare(source, params: Params | Mapping | None = None, meta: Mapping | None = None,
            smoothing=None, rate: float = SELECT_RATE) -> Prepared:
    """Read, validate and differentiate a recording (processing.py's consistent recipe).

    Parameters
    ----------
    source : path or pandas.DataFrame
        A CONTRACT recording (CSV/Parquet with its sidecar, state or motion-capture
        columns) or its table.
    params : Params or mapping, optional
        Nominal parameters; default: the sidecar's, else Table 3.
    meta : mapping, optional
        Metadata for a DataFrame source (the sidecar's content).
    smoothing : processing.Smoothing, optional
        Default: ``processing.DEFAULT_SMOOTHING`` (consistent filtering, NOTES fact 4).
    rate : float
        Residual samples kept per second, Hz.

    Returns
    -------
    Prepared

    Raises
    ------
    DiagnosisError
        for a recording too short for the filters.
    """
    from euc_sim.identification import processing, recordings
    df, meta, name = _read(source, meta)
    if isinstance(params, Params):
        p = params
    elif params is not None:
        p = Params.from_mapping({k: v for k, v in dict(params).items() if k != "h"})
    else:
        p = recordings.params_from_meta(meta, name)
    sm = smoothing or processing.DEFAULT_SMOOTHING
    if sm.method != "consistent" or sm.term_sigma <= 0:
        raise DiagnosisError(f"smoothing must be the consistent recipe with a term filter, got {sm.describe()}")
    kin = processing.kinematics(df, p, sm, name=name)
    t = kin.t
    dt = kin.dt
    edge = sm.edge(dt)
    if t.size < 2 * edge + int(2.0 / dt):
        raise DiagnosisError(f"recording {name}: duration {t[-1] - t[0]:.2f} s too short; expected at "
                             f"least {(2 * edge) * dt + 2.0:.1f} s for the filters")
    M_d = df["M_d"].to_numpy(float) if "M_d" in df.columns else None
    lateral = None
    if "theta" in df.columns and "psi" in df.columns:
        # tilt and yaw are inputs of the lateral term, not terms of the balance: a longer
        # fit (LATERAL_WINDOW) keeps their noise out of the column (errors in variables)
        w = int(round(LATERAL_WINDOW / dt)) | 1
        o = 3
        theta, theta_d, _ = processing.savgol_derivatives(df["theta"].to_numpy(float), dt, w, o)
        _, psi_d, psi_dd = processing.savgol_derivatives(np.unwrap(df["psi"].to_numpy(float)), dt, w, o)
        lateral = {"theta": theta, "theta_d": theta_d, "psi_d": psi_d, "psi_dd": psi_dd}
    step = max(1, int(round(1.0 / (dt * rate))))
    keep = np.arange(edge, t.size - edge, step)
    noise = {c: _noise_sd(ch) for c, ch in _raw_channels(df).items()}
    return Prepared(kin, sm.sigma_samples(dt), M_d, lateral, keep, p, meta, name, noise, df)


def _raw_channels(df: pd.DataFrame) -> dict[str, np.ndarray]:
    """Unsmoothed x, γ, φ (or their motion-capture stand-ins) for the noise estimate.

    A motion-capture file has no x or φ column: φ is taken as the lean of C→G (E→G)
    in the heading plane, atan2((G − C)·(cos ψ, sin ψ), G_Z − C_Z), and x's noise as
    that of C_X (E_X).  Only their sample-to-sample noise matters here.
    """
    out = {}
    base = "C" if {"C_X", "C_Y", "C_Z"} <= set(df.columns) else "E"
    if "x" in df.columns:
        out["x"] = df["x"].to_numpy(float)
    else:
        out["x"] = df[f"{base}_X"].to_numpy(float)
    out["gamma"] = df["gamma"].to_numpy(float)
    if "phi" in df.columns:
        out["phi"] = df["phi"].to_numpy(float)
    else:
        psi = np.unwrap(df["psi"].to_numpy(float))
        dx = df["G_X"].to_numpy(float) - df[f"{base}_X"].to_numpy(float)
        dy = df["G_Y"].to_numpy(float) - df[f"{base}_Y"].to_numpy(float)
        dz = df["G_Z"].to_numpy(float) - df[f"{base}_Z"].to_numpy(float)
        out["phi"] = np.arctan2(dx * np.cos(psi) + dy * np.sin(psi), dz)
    return out


def _noise_sd(y: np.ndarray) -> float:
    """White-noise level of a channel from its third differences (robust, MAD).

    For white noise of sd σ, Δ³y has sd σ·√20; smooth motion at 120 Hz contributes
    little to Δ³.
    """
    d3 = np.diff(np.asarray(y, float), 3)
    return float(1.4826 * np.median(np.abs(d3 - np.median(d3))) / math.sqrt(20.0))


# --- the residual --------------------------------------------------------------------------
@dataclass(frozen=True)
class ResidualModel:
    """Residual of the nominal model as a closed-form function of h, kept samples.

    Kinematic row (identification.residual_poly): r(h) = P(h)/D(h) = M_d,1 − M_d,2,
    P's coefficients term-filtered.  With M_d recorded the wheel row
    r_w(h) = M_d,1(h) − M_d = w₀ + w₁ h (both term-filtered) is stacked below.
    """

    P: np.ndarray                # (3, n)
    D: np.ndarray                # (2, n)
    W: np.ndarray | None         # (2, n)

    def kinematic(self, h: float) -> np.ndarray:
        return (self.P[0] + h * (self.P[1] + h * self.P[2])) / (self.D[0] + h * self.D[1])

    def wheel(self, h: float) -> np.ndarray | None:
        return None if self.W is None else self.W[0] + h * self.W[1]

    def kappa(self, h: float, R: float, m11: float) -> np.ndarray:
        """κ = R m_11 / D(h), the gain of analytic.residual_gain."""
        return R * m11 / (self.D[0] + h * self.D[1])

    def __call__(self, h: float) -> np.ndarray:
        r = self.kinematic(h)
        w = self.wheel(h)
        return r if w is None else np.concatenate([r, w])


_H_NODES = np.array([0.5, 1.0, 1.5])


def residual_model(prep: Prepared, p: Params | None = None, sigma: float | None = None) -> ResidualModel:
    """Build r(h) (and r_w(h) with M_d recorded) on the kept samples.

    The kinematic row is :func:`euc_sim.identification.h_fit.residual_poly` when the
    default filter is used; its samples are the interior ones, of which ``keep`` is a
    subset.  With another ``sigma`` (a different term filter, samples)
    the same polynomial is built here on the full length.
    """
    from euc_sim.identification import h_fit as ident
    p = prep.params if p is None else p
    kin = prep.kin
    if sigma is None:
        rp = ident.residual_poly(kin, p)
        start = kin.interior.start
        idx = prep.keep - start
        P, D = rp.P[:, idx], rp.D[:, idx]
    else:
        num, den = [], []
        for h in _H_NODES:
            ph = p.replace(h=float(h))
            M = analytic.mass_matrix(ph, kin.q)
            Dh = M[..., 0, 0] * ph.R + M[..., 1, 0] + M[..., 2, 0]
            num.append((analytic.driving_torque_1(ph, kin.q, kin.qd, kin.qdd)
                        - analytic.driving_torque_2(ph, kin.q, kin.qd, kin.qdd)) * Dh)
            den.append(Dh)
        V = np.vander(_H_NODES, 3, increasing=True)
        P = prep.filtered(np.linalg.solve(V, np.array(num)), sigma)
        D1 = (den[1] - den[0]) / (_H_NODES[1] - _H_NODES[0])
        D = np.array([den[0] - _H_NODES[0] * D1, D1])[:, prep.keep]
    W = None
    if prep.M_d is not None:
        w = [analytic.driving_torque_1(p.replace(h=float(h)), kin.q, kin.qd, kin.qdd) - prep.M_d
             for h in _H_NODES[:2]]
        w1 = (w[1] - w[0]) / (_H_NODES[1] - _H_NODES[0])
        W = prep.filtered(np.array([w[0] - _H_NODES[0] * w1, w1]), sigma)
    return ResidualModel(P, D, W)


# --- the candidate library ---------------------------------------------------------------
#: Reference magnitude for each force effect's unit column (linear ones are exact).
_REF = {"rolling_resistance": 1.0, "aerodynamic_drag": 1.0, "road_slope": 1e-3,
        "wheel_bearing_friction": 1.0, "lateral_dynamics": 1.0}


def _force_columns(name: str, prep: Prepared, p: Params, h: float) -> tuple[np.ndarray, np.ndarray]:
    """(kinematic, wheel-row) columns of a force effect per unit of its estimate.

    κ(q) · F[R Q_e,x + Q_e,γ + Q_e,φ] and F[R Q_e,x], F the term filter: the same
    filter as every term of the residual (NOTES fact 4).
    """
    ph = p.replace(h=h)
    kin = prep.kin
    extra = None
    if name == "lateral_dynamics":
        extra = prep.lateral
    Q = effects.generalized_force(name, _REF[name], ph, kin.q, kin.qd, extra) / _REF[name]
    kappa = analytic.residual_gain(ph, kin.q[prep.keep])
    return kappa * prep.filtered(analytic.moment_about_contact(ph, Q)), p.R * prep.filtered(Q[:, 0])


#: Term filter of the h-drift columns, as a multiple of the default (1: the same
#: filter; a heavier one was tried and biased the drift estimate by +20 to +30 %).
DRIFT_FILTER = 1.0


def _sensitivity(prep: Prepared, p: Params, h: float, vary: Callable[[float], tuple],
                 sigma: float | None) -> np.ndarray:
    """Central difference of the stacked residual for a perturbed (params, prep)."""
    pa, pra = vary(-1.0)
    pb, prb = vary(1.0)
    return (residual_model(prb, pb, sigma)(h) - residual_model(pra, pa, sigma)(h)) / 2.0


def build_problem(prep: Prepared, h0: float, p: Params | None = None) -> tuple[sel.Problem, dict]:
    """The selection problem: residual r(h), candidate columns and validity rules.

    Parameters
    ----------
    prep : Prepared
    h0 : float
        h at which the candidate columns are evaluated, m (the nominal estimate).
    p : Params, optional
        Nominal parameters (``prep.params`` by default).

    Returns
    -------
    problem : selection.Problem
    info : dict
        Per candidate: how its coefficient maps to CONTRACT's estimate
        (``{"scale": s, "offset": o}``: estimate = o + s·θ; ``"amplitude"`` for the
        two-column h drift, whose estimate is |θ|).

    Notes
    -----
    The rider-mass term is the wheel row's only (it needs M_d): in the kinematic row
    the residual's sensitivity to m is mostly the noise's own (m scales the noisy
    rider terms), and a regression on it would "explain" noise by a rider mass near
    zero (NOTES fact 2).
    """
    p = prep.params if p is None else p
    model = residual_model(prep, p)
    k = prep.keep
    has_w = model.W is not None
    t = prep.t[k]
    time = np.concatenate([t, t]) if has_w else t
    vis = visibility(prep.raw.columns)
    cands: dict[str, np.ndarray] = {}
    info: dict[str, dict] = {}

    def stack(kin, wh):
        return np.concatenate([kin, wh]) if has_w else kin

    for name in ("rolling_resistance", "aerodynamic_drag", "road_slope",
                 "lateral_dynamics", "wheel_bearing_friction"):
        if not vis[name]["visible"]:
            continue
        kin, wh = _force_columns(name, prep, p, h0)
        col = stack(kin, wh)
        if not np.any(np.abs(col) > 1e-9):
            continue
        cands[name] = col
        if name == "lateral_dynamics":
            # every term of effects.lateral_forces is of second order in the turn
            # (ϑψ̈, ψ̇ϑ̇, ψ̇², ẋψ̇ϑ, ϑ² with ψ̇ ∝ tan ϑ): a fitted coupling strength s
            # means an effective peak tilt √s · max|ϑ| (CONTRACT: peak tilt)
            info[name] = {"scale": float(np.max(np.abs(prep.lateral["theta"][k]))), "offset": 0.0, "sqrt": True}
        else:
            info[name] = {"scale": 1.0, "offset": 0.0}
    # rider mass: r(m_nom) ≈ −∂r/∂m · Δm  ⇒  column −∂r/∂m, θ = Δm (kg)
    dm = 5.0

    def vary_m(s):
        return effects.apply_to_params(p, "rider_mass", p.m + s * dm), prep

    if vis["rider_mass"]["visible"]:
        # visible only with M_d (see visibility): the wheel row sees m_11 ẍ plainly; the
        # kinematic row's sensitivity to m is mostly the noise's (NOTES fact 2), so the
        # term is the wheel row's alone
        col = -_sensitivity(prep, p, h0, vary_m, None) / dm
        col[:k.size] = 0.0
        cands["rider_mass"] = col
        info["rider_mass"] = {"scale": 1.0, "offset": p.m}
    # time offset of the rider channel: φ_rec(t) = φ(t − τ) ⇒ r(0) ≈ −∂r/∂τ · τ
    # (the plain filter here: a shift does not scale the noise)
    dtau = 0.005

    def vary_tau(s):
        return p, prep.shifted(s * dtau)

    cands["sensor_time_offset"] = -_sensitivity(prep, p, h0, vary_tau, None) / dtau
    info["sensor_time_offset"] = {"scale": 1.0, "offset": 0.0}
    # h drift, the catalog's law h(t) = h + (Δh/2) sin(2π t/T): −∂r/∂h · (½ sin, ½ cos)
    dh = 1e-4
    model_s = residual_model(prep, p, prep.sigma * DRIFT_FILTER)
    drdh = (model_s(h0 + dh) - model_s(h0 - dh)) / (2 * dh)
    ph = 2 * np.pi * time / DRIFT_PERIOD
    cands["cog_height_drift"] = np.column_stack([-drdh * 0.5 * np.sin(ph), -drdh * 0.5 * np.cos(ph)])
    info["cog_height_drift"] = {"scale": 1.0, "offset": 0.0, "amplitude": True}

    def positive(lo, hi, unit):
        def check(theta):
            v = float(theta[0])
            if v <= 0:
                return f"estimate {v:.3g} {unit} has the wrong sign for this physics"
            if v > hi:
                return f"estimate {v:.3g} {unit} is beyond physical range (> {hi:g})"
            return None
        return check

    def bounded(lo, hi, unit, offset=0.0):
        def check(theta):
            v = offset + float(theta[0])
            if not lo <= v <= hi:
                return f"estimate {v:.3g} {unit} is outside the physical range [{lo:g}, {hi:g}]"
            return None
        return check

    def drift(theta):
        a = float(np.hypot(*theta))
        return None if a <= 0.6 else f"h drift {a:.2f} m is beyond physical range (> 0.6 m)"

    validity = {
        "rolling_resistance": positive(0, 0.2, ""),
        "aerodynamic_drag": positive(0, 3.0, "kg/m"),
        "wheel_bearing_friction": positive(0, 30.0, "N·m·s/rad"),
        "road_slope": bounded(-0.3, 0.3, "rad"),
        "lateral_dynamics": bounded(0.5, 2.0, "(coupling scale)"),
        "rider_mass": bounded(30.0, 200.0, "kg", offset=p.m),
        "sensor_time_offset": bounded(-0.3, 0.3, "s"),
        "cog_height_drift": drift,
    }
    problem = sel.Problem(target=model, candidates=cands, time=time, bounds=H_BOUNDS,
                          validity={c: v for c, v in validity.items() if c in cands})
    return problem, info


# --- noise floor ---------------------------------------------------------------------------
def noise_floor(prep: Prepared, h: float, seed: int = 0) -> dict:
    """The residual that the recording's own sensor noise produces through the filter.

    White noise with the level estimated from each channel (:func:`_noise_sd`) is
    filtered like the data and propagated to the residual (linearised about the
    filtered motion).  Its RMS is the floor below which nothing can be named; its
    correlation time gives the effective sample count n_eff of the BIC.

    Parameters
    ----------
    prep : Prepared
    h : float
        m.
    seed : int
        Seed of the noise draw.

    Returns
    -------
    dict
        ``rms`` (N·m, kinematic residual), ``rms_stacked`` (all rows), ``tau_int``
        (kept samples), ``noise``: the residual samples (stacked).
    """
    from euc_sim.identification import processing
    rng = np.random.default_rng(seed)
    n = prep.t.size
    sm = prep.kin.smoothing
    dt = prep.kin.dt
    Z = np.column_stack([rng.normal(0.0, prep.noise_sd[c], n) for c in ("x", "gamma", "phi")])
    dq, dqd, dqdd = processing.savgol_derivatives(Z, dt, sm.samples(dt), sm.order, axis=0)
    base = residual_model(prep)(h)
    pert = residual_model(prep.with_kin(prep.q + dq, prep.qd + dqd, prep.qdd + dqdd))(h)
    r = pert - base
    nk = prep.keep.size
    return {"rms": float(np.sqrt(np.mean(r[:nk] ** 2))), "rms_stacked": float(np.sqrt(np.mean(r ** 2))),
            "tau_int": sel.correlation_time(r[:nk]), "noise": r}


# --- localisation --------------------------------------------------------------------------
def localise(t: np.ndarray, r: np.ndarray, signals: Mapping[str, np.ndarray],
             smooth: float = 1.0, factor: float = 2.0, min_len: float = 0.5) -> dict:
    """Where the residual concentrates and what it moves with.

    Parameters
    ----------
    t, r : numpy.ndarray
        Time (s) and residual (N·m), same length, uniformly sampled.
    signals : mapping of str to numpy.ndarray
        Signals to correlate with (speed, acceleration, lean, ...), same length.
    smooth : float
        Moving-average length for the residual's power, s.
    factor : float
        A window is where the smoothed power exceeds ``factor`` × its median.
    min_len : float
        Shortest window, s.

    Returns
    -------
    dict
        ``windows``: list of [t0, t1] (s); ``share``: fraction of the residual's energy
        inside them; ``correlations``: Pearson correlation with each signal.
    """
    t = np.asarray(t, float)
    r = np.asarray(r, float)
    if t.size != r.size or t.size < 4:
        raise DiagnosisError(f"t and r must have the same length ≥ 4, got {t.size} and {r.size}")
    dt = float(np.median(np.diff(t)))
    w = max(1, int(round(smooth / dt)))
    power = np.convolve(r ** 2, np.ones(w) / w, mode="same")
    thr = factor * max(float(np.median(power)), 1e-12)
    hot = power > thr
    windows = []
    i = 0
    while i < hot.size:
        if hot[i]:
            j = i
            while j + 1 < hot.size and hot[j + 1]:
                j += 1
            if t[j] - t[i] >= min_len:
                windows.append([float(t[i]), float(t[j])])
            i = j + 1
        else:
            i += 1
    inside = np.zeros(t.size, bool)
    for a, b in windows:
        inside |= (t >= a) & (t <= b)
    energy = float(np.sum(r ** 2))
    corr = {}
    for name, s in signals.items():
        s = np.asarray(s, float)
        if s.size != r.size or np.std(s) < 1e-12 or np.std(r) < 1e-12:
            continue
        corr[name] = float(np.corrcoef(s, r)[0, 1])
    return {"windows": windows, "share": float(np.sum(r[inside] ** 2) / energy) if energy > 0 else 0.0,
            "correlations": corr}


def _signals(prep: Prepared) -> dict[str, np.ndarray]:
    k = prep.keep
    out = {"speed": prep.qd[k, 0], "acceleration": prep.qdd[k, 0], "lean_phi": prep.q[k, 2],
           "pitch_gamma": prep.q[k, 1]}
    if prep.lateral is not None:
        out["tilt_theta"] = prep.lateral["theta"][k]
        out["yaw_rate"] = prep.lateral["psi_d"][k]
    return out


# --- the pipeline --------------------------------------------------------------------------
#: Magnitudes against which detection limits are judged: the catalog's plausible range,
#: except the rider mass (a deviation from the nominal mass, kg).
def _plausible(name: str) -> tuple[float, float]:
    if name == "rider_mass":
        return (10.0, 30.0)
    lo, hi = effects.get(name).plausible
    if name == "road_slope":
        return (0.01, max(abs(lo), abs(hi)))
    return (lo, hi)


def _estimate(info: dict, theta: np.ndarray, cov: np.ndarray, dof: float) -> tuple[float, list[float], float]:
    """CONTRACT estimate, its 95% interval and standard error from θ and its covariance."""
    from scipy.stats import t as student
    q = float(student.ppf(0.975, max(dof, 1.0)))
    if info.get("amplitude"):
        a = float(np.hypot(*theta))
        g = theta / a if a > 0 else np.zeros_like(theta)
        se = float(np.sqrt(max(g @ cov @ g, 0.0)))
        return a, [max(a - q * se, 0.0), a + q * se], se
    if info.get("sqrt"):      # estimate = scale·√θ, interval mapped through the same law
        s, se_s = float(theta[0]), float(np.sqrt(max(cov[0, 0], 0.0)))
        lo, hi = max(s - q * se_s, 0.0), max(s + q * se_s, 0.0)
        est = info["scale"] * math.sqrt(max(s, 0.0))
        se = info["scale"] * se_s / (2.0 * math.sqrt(s)) if s > 0 else float("inf")
        return est, [info["scale"] * math.sqrt(lo), info["scale"] * math.sqrt(hi)], se
    est = info["offset"] + info["scale"] * float(theta[0])
    se = abs(info["scale"]) * float(np.sqrt(max(cov[0, 0], 0.0)))
    return est, [est - q * se, est + q * se], se


def _sub_cov(problem: sel.Problem, names, cov: np.ndarray, name: str) -> np.ndarray:
    i = 0
    for c in names:
        k = problem.candidates[c].shape[1]
        if c == name:
            return cov[i:i + k, i:i + k]
        i += k
    raise KeyError(name)


#: Nonlinear effects refined by a 1-D search, with their search intervals.
_NONLINEAR = {"sensor_time_offset": (-0.3, 0.3), "rider_mass": (30.0, 200.0)}


def _refine(prep: Prepared, problem: sel.Problem, selected, estimates: dict,
            h: float):
    """Estimate nonlinear effects (time offset, rider mass) by a 1-D search each.

    Their columns are linearisations; the estimate is refined by minimising the
    residual's RSS over the effect's value itself (re-aligned rider channel, rider
    mass changed), with h and the linear effects profiled out.  Returns the state
    ``{name: value}``, the rebuilt (problem, info), the fit, and the slope dθ/dv of
    each linearised coefficient (to convert its standard error).
    """
    from scipy.optimize import minimize_scalar

    p = prep.params
    nonlin = [c for c in selected if c in _NONLINEAR]
    linear = tuple(c for c in selected if c not in _NONLINEAR)
    state = {"sensor_time_offset": 0.0, "rider_mass": p.m}
    state.update({c: estimates[c] for c in nonlin})
    lin_cols = {c: problem.candidates[c] for c in linear}

    def residual_of(st):
        pr = prep.shifted(st["sensor_time_offset"]) if st["sensor_time_offset"] else prep
        pp = effects.apply_to_params(p, "rider_mass", st["rider_mass"]) if st["rider_mass"] != p.m else p
        return pr, pp

    def rss(c, v):
        st = {**state, c: v}
        pr, pp = residual_of(st)
        prob = sel.Problem(residual_model(pr, pp), lin_cols, problem.time, problem.bounds)
        return sel.fit_set(prob, linear).rss

    for _ in range(2 if len(nonlin) > 1 else 1):
        for c in nonlin:
            lo, hi = _NONLINEAR[c]
            v0 = state[c]
            w = 0.05 if c == "sensor_time_offset" else 25.0
            res = minimize_scalar(lambda v: rss(c, v), bounds=(max(lo, v0 - w), min(hi, v0 + w)),
                                  method="bounded", options={"xatol": 1e-4 if c != "rider_mass" else 0.05})
            state[c] = float(res.x)

    def build(st):
        pr, pp = residual_of(st)
        return build_problem(pr, h, pp)

    prob, info = build(state)
    f = sel.fit_set(prob, selected)
    slopes = {}
    for c in nonlin:
        d = 0.005 if c == "sensor_time_offset" else 2.0
        pa, _ = build({**state, c: state[c] - d})
        pb, _ = build({**state, c: state[c] + d})
        ta = sel.fit_set(pa, selected).theta[c][0]
        tb = sel.fit_set(pb, selected).theta[c][0]
        slopes[c] = float((tb - ta) / (2 * d))
        info[c] = {**info[c], "offset": state[c], "scale": 0.0}
    return state, prob, info, f, slopes


def _is_plausible(name: str, est: float, p: Params) -> bool:
    """Whether an estimate lies in the catalog's plausible range (|α| for the slope)."""
    lo, hi = effects.get(name).plausible
    if name == "road_slope":
        return abs(est) <= max(abs(lo), abs(hi))
    if name == "rider_mass":
        return lo <= est <= hi
    return lo * 0.5 <= est <= hi * 1.5


def _plausible_alias(problem: sel.Problem, selected, name: str, aliases, info, p: Params, dof: float):
    """The best-fitting alias whose swapped-in estimate is plausible, or None."""
    without = tuple(c for c in selected if c != name)
    best = None
    for a in aliases:
        f = sel.fit_set(problem, without + (a,))
        if info[a].get("amplitude") or a in _NONLINEAR:
            continue
        cov, _ = sel.covariance(problem, f, cluster=2.0)
        C = _sub_cov(problem, without + (a,), cov, a)
        est, ci, se = _estimate(info[a], f.theta[a], C, dof)
        if _is_plausible(a, est, p) and (best is None or f.rss < best[0]):
            best = (f.rss, {"name": a, "estimate": est, "unit": effects.get(a).unit, "ci95": ci,
                            "t": abs(est) / se if se > 0 else float("inf")})
    return None if best is None else best[1]


def _evidence(name: str, est: float, unit: str, before: float, after: float, t_stat: float,
              aliases: list[str]) -> str:
    u = f" {unit}" if unit and unit != "1" else ""
    txt = (f"adding {name} ({est:.4g}{u}) cuts the held-out residual RMSE from {before:.3g} "
           f"to {after:.3g} N·m; its term stands {t_stat:.0f} standard errors from zero")
    if aliases:
        txt += f", but this recording cannot tell it from {', '.join(aliases)}"
    return txt + "."


def diagnose(source, *, params: Params | Mapping | None = None, meta: Mapping | None = None,
             thresholds: Thresholds = THRESHOLDS, resimulate: bool = True, seed: int = 0,
             smoothing=None, progress: Callable[[str], None] | None = None) -> dict:
    """Diagnose a recording: where the nominal model fails, which catalogued physics is
    missing, with estimates, intervals, aliases and the improvement.

    Parameters
    ----------
    source : path or pandas.DataFrame
        A CONTRACT recording (CSV/Parquet with its sidecar ``NAME.json``); the
        ``NAME.truth.json`` file is never read.
    params : Params or mapping, optional
        Nominal parameters (default: the sidecar's, else Table 3); h is always
        identified.
    meta : mapping, optional
        Metadata when ``source`` is a DataFrame (maneuver, duration, seed).
    thresholds : Thresholds
    resimulate : bool
        Re-simulate the maneuver with the accepted effects injected (needs the
        maneuver in the metadata).
    seed : int
        Seed of the noise-floor draw.
    smoothing : processing.Smoothing, optional
        The consistent recipe (default ``processing.DEFAULT_SMOOTHING``).
    progress : callable, optional
        Receives short progress messages.

    Returns
    -------
    dict
        CONTRACT's diagnosis object (``recording``, ``nominal_rmse``, ``effects``,
        ``unexplained``, ``windows``) plus ``h_nominal``, ``h_augmented``,
        ``augmented_rmse``, ``noise_floor``, ``decidable``, ``verdict``, ``limits``,
        ``visibility``, ``correlations``, ``history``, ``resimulation`` and more.
    """
    say = progress or (lambda s: None)
    th = thresholds
    say("filtering the recording")
    prep = prepare(source, params, meta, smoothing=smoothing)
    vis = visibility(prep.raw.columns)
    model = residual_model(prep)
    k = prep.keep
    has_w = model.W is not None
    time = np.concatenate([prep.t[k], prep.t[k]]) if has_w else prep.t[k]
    base = sel.Problem(model, {}, time, H_BOUNDS)
    h0 = sel.fit_set(base, ()).h
    say(f"nominal h = {h0:.3f} m; noise floor")
    floor = noise_floor(prep, h0, seed)
    n_eff = max(time.size / floor["tau_int"], 5.0)
    h_cols = h0
    for _ in range(COLUMN_ITERATIONS):
        # the candidate columns depend on h: a large missing effect drags the nominal h
        # away (to the search bound for a strong slalom), so the columns are rebuilt at
        # the augmented model's h and the selection is run again until h settles
        problem, info = build_problem(prep, h_cols)
        say(f"selecting among {len(problem.candidates)} candidate terms (columns at h = {h_cols:.3f} m)")
        s = sel.forward_select(problem, min_bic_drop=th.min_bic_drop, min_cv_gain=th.min_cv_gain,
                               min_t=th.min_t, n_eff=n_eff)
        if not s.selected or abs(s.fit.h - h_cols) < COLUMN_H_TOL:
            break
        h_cols = s.fit.h
    cov_nom, _ = sel.covariance(problem, s.nominal, cluster=2.0)
    h_se = float(np.sqrt(cov_nom[-1, -1]))

    selected = tuple(s.selected)
    estimates = {c: info[c]["offset"] + info[c]["scale"] * float(s.fit.theta[c][0])
                 for c in selected if not info[c].get("amplitude")}
    prob_f, info_f, fit_f, slopes = problem, info, s.fit, {}
    if any(c in selected for c in _NONLINEAR):
        say("refining the nonlinear estimates")
        _, prob_f, info_f, fit_f, slopes = _refine(prep, problem, selected, estimates, s.fit.h)
    cov_f, dof_f = sel.covariance(prob_f, fit_f, cluster=2.0)
    cv_after_all = sel.heldout_rmse(prob_f, selected) if selected else s.cv_nominal

    eff_out = []
    for i, c in enumerate(selected):
        C = _sub_cov(prob_f, selected, cov_f, c)
        if c in slopes:   # θ ≈ −(v − v̂)·|dθ/dv|: se_v = se_θ / |dθ/dv|
            C = C / max(slopes[c] ** 2, 1e-12)
            est, ci, se = _estimate({"offset": info_f[c]["offset"], "scale": 1.0}, np.zeros(1), C, dof_f)
        else:
            est, ci, se = _estimate(info_f[c], fit_f.theta[c], C, dof_f)
        aliases = sel.find_aliases(problem, selected, c, list(problem.candidates), n_eff,
                                   max_bic=th.alias_bic, cosine=th.alias_cosine)
        before = s.cv_nominal if i == 0 else s.cv_path[i - 1]
        after = s.cv_path[i] if i < len(selected) - 1 else cv_after_all
        ref = prep.params.m if c == "rider_mass" else 0.0     # the value of "no effect"
        t_stat = abs(est - ref) / se if se > 0 else float("inf")
        item = {"name": c, "estimate": est, "unit": effects.get(c).unit, "ci95": ci,
                "rmse_after": after, "aliases": aliases,
                "evidence": _evidence(c, est, effects.get(c).unit, before, after, t_stat, aliases)}
        if aliases and not _is_plausible(c, est, prep.params):
            swap = _plausible_alias(problem, selected, c, aliases, info, prep.params, dof_f)
            if swap is not None:
                item = {**swap, "rmse_after": after,
                        "aliases": [c] + [a for a in aliases if a != swap["name"]]}
                item["evidence"] = (_evidence(swap["name"], swap["estimate"], swap["unit"], before, after,
                                              swap["t"], item["aliases"])
                                    + f" Named before {c}, whose estimate {est:.3g} is outside its plausible range.")
                item.pop("t", None)
        eff_out.append(item)

    # detection limits: what this recording could have seen
    limits = {}
    for c in problem.candidates:
        base_set = tuple(x for x in s.selected if x != c) + (c,)
        f1 = sel.fit_set(problem, base_set)
        cov1, dof1 = sel.covariance(problem, f1, cluster=2.0)
        C = _sub_cov(problem, base_set, cov1, c)
        se_theta = float(np.sqrt(np.trace(C) / C.shape[0]))
        if info[c].get("sqrt"):      # lateral: the coupling grows as tilt², the limit is a tilt
            lim = info[c]["scale"] * math.sqrt(th.min_t * se_theta)
        else:
            lim = th.min_t * se_theta * abs(info[c]["scale"])
        lo, hi = _plausible(c)
        status = ("detectable" if lim <= lo else "only large values" if lim <= hi else "not detectable")
        limits[c] = {"detectable_above": lim, "unit": effects.get(c).unit, "plausible": [lo, hi],
                     "status": status}
    for c, v in vis.items():
        if not v["visible"]:
            limits[c] = {"detectable_above": None, "unit": effects.get(c).unit,
                         "plausible": list(_plausible(c)), "status": "invisible: " + v["reason"]}

    # leftover structure: a generic periodic basis, and the noise floor
    say("testing what is left")
    cv_wo, cv_gen = sel.generic_gain(prob_f, selected, sel.sinusoid_basis(prob_f.time))
    gen_gain = 1.0 - cv_gen / cv_wo
    floor_stacked = floor["rms_stacked"]
    ratio = cv_after_all / floor_stacked if floor_stacked > 0 else float("inf")
    unexplained = bool(gen_gain >= th.generic_gain or ratio >= th.floor_ratio)

    # excitation and noise: can this recording decide anything?
    detectable = [c for c, v in limits.items() if v["status"] in ("detectable", "only large values")]
    lo_b, hi_b = H_BOUNDS
    h_se_f = float(np.sqrt(max(cov_f[-1, -1], 0.0)))      # h with the accepted effects
    h_at_bound = min(fit_f.h - lo_b, hi_b - fit_f.h) < 0.01
    h_ok = (1.96 * h_se_f <= th.max_h_halfwidth) and not h_at_bound
    periodic = gen_gain >= th.generic_gain      # a periodic structure is a finding in itself
    decidable = bool(detectable) and (h_ok or periodic)
    notes = []
    if not h_ok and periodic:
        notes.append(f"h is unreliable here (h = {fit_f.h:.2f} m ± {1.96 * h_se_f:.2f} m"
                     f"{', at the search bound' if h_at_bound else ''}): the structure left "
                     "unexplained pulls it")
    elif not h_ok:
        notes.append(f"h is not identifiable here (h = {fit_f.h:.2f} m ± {1.96 * h_se_f:.2f} m"
                     f"{', at the search bound' if h_at_bound else ''}): too little excitation; "
                     "a constant force and a wrong h look the same without speed changes")
    for c in ("rider_mass", "cog_height_drift"):
        if c in limits and limits[c]["detectable_above"] is None:
            notes.append(f"{c} cannot be revealed by this recording: {vis[c]['reason']}")
        elif c in limits and limits[c]["status"] != "detectable":
            lim = limits[c]["detectable_above"]
            why = "without torques (NOTES facts 2-3)" if not has_w else "in this recording"
            unit = "" if limits[c]["unit"] == "1" else f" {limits[c]['unit']}"
            notes.append(f"{c} is near the noise floor {why}: only above {lim:.3g}{unit} could be seen")
    tentative = []
    if unexplained and eff_out:
        # a wrong name is worse than none: with structure left unexplained, keep only
        # effects that explain most of the mismatch (held-out RMSE at least halved)
        keep_eff = []
        for i, e in enumerate(eff_out):
            before = s.cv_nominal if i == 0 else eff_out[i - 1]["rmse_after"]
            (keep_eff if e["rmse_after"] <= th.unexplained_keep * before else tentative).append(e)
        eff_out = keep_eff
        if tentative:
            notes.append("with structure left unexplained, not named (each explained less than half "
                         "of the mismatch): " + ", ".join(e["name"] for e in tentative))
    if not decidable:
        verdict = "too little excitation or too much noise to decide"
        unexplained = False
        tentative += eff_out
        eff_out = []
    elif eff_out:
        verdict = "missing physics found"
    elif unexplained:
        verdict = "structure left that no catalogued effect explains"
    else:
        verdict = "nothing missing"
    if unexplained and eff_out:
        verdict += "; structure is left that no catalogued effect explains"

    if tentative:      # the model that is reported is the one with the named effects only
        named = tuple(e["name"] for e in eff_out)
        if any(e["name"] in _NONLINEAR for e in tentative):
            prob_f = problem            # the refined residual carried a dropped effect
        if named:
            cv_after_all = sel.heldout_rmse(prob_f, named)
            fit_f = sel.fit_set(prob_f, named)
        else:
            cv_after_all, fit_f, prob_f = s.cv_nominal, s.nominal, problem

    # localise on the row that carries the mismatch (the wheel row when M_d is recorded
    # and it dominates)
    r_loc, loc_row = model.kinematic(s.nominal.h), "M_d,1 - M_d,2"
    if has_w:
        r_w = model.wheel(s.nominal.h)
        if np.sqrt(np.mean(r_w ** 2)) > np.sqrt(np.mean(r_loc ** 2)):
            r_loc, loc_row = r_w, "M_d,1 - M_d (wheel row)"
    loc = localise(prep.t[k], r_loc, _signals(prep))
    result = {
        "recording": prep.name,
        "nominal_rmse": s.cv_nominal,
        "effects": eff_out,
        "unexplained": unexplained,
        "tentative": tentative,
        "windows": loc["windows"],
        "augmented_rmse": cv_after_all,
        "h_nominal": s.nominal.h,
        "h_nominal_ci95": [s.nominal.h - 1.96 * h_se, s.nominal.h + 1.96 * h_se],
        "h_augmented_ci95": [fit_f.h - 1.96 * h_se_f, fit_f.h + 1.96 * h_se_f],
        "h_augmented": fit_f.h,
        "residual": "M_d,1 - M_d,2" + (" and wheel row M_d,1 - M_d" if has_w else ""),
        "rmse_unit": "N·m",
        "noise_floor": floor["rms_stacked"],
        "noise_sd": prep.noise_sd,
        "n_eff": n_eff,
        "decidable": decidable,
        "verdict": verdict,
        "notes": notes,
        "limits": limits,
        "visibility": vis,
        "correlations": loc["correlations"],
        "window_share": loc["share"],
        "localised_on": loc_row,
        "generic": {"heldout_without": cv_wo, "heldout_with": cv_gen, "gain": gen_gain,
                    "floor_ratio": ratio},
        "history": [{"step": st.step, "base": list(st.base), "chosen": st.chosen,
                     "accepted": st.accepted, "reason": st.reason, "trials": st.trials}
                    for st in s.history],
        "thresholds": th.__dict__,
    }
    nk = k.size
    y_fin = prob_f.y(fit_f.h) - prob_f.design(fit_f.names) @ fit_f.coef_vector()
    result["_series"] = {
        "t": prep.t[k],
        "residual_nominal": model.kinematic(s.nominal.h),
        "residual_augmented": y_fin[:nk],
        "wheel_nominal": model.wheel(s.nominal.h),
        "wheel_augmented": y_fin[nk:] if has_w else None,
        "terms": {c: problem.candidates[c][:nk] for c in problem.candidates},
        "single_fits": _single_fits(problem, nk),
        "signals": _signals(prep),
    }
    if resimulate:
        say("re-simulating the maneuver")
        rs = resimulate_recording(prep, result)
        result["_series"]["resimulation"] = rs.pop("series", None)
        result["resimulation"] = rs
    return result


def _single_fits(problem: sel.Problem, nk: int) -> dict:
    """Each candidate alone with h: (residual at its h, its fitted term, h) for the
    kinematic row, then the same two for the wheel row (None without M_d)."""
    out = {}
    for c in problem.candidates:
        f = sel.fit_set(problem, (c,))
        y, term = problem.y(f.h), problem.candidates[c] @ f.theta[c]
        out[c] = (y[:nk], term[:nk], f.h, y[nk:] if y.size > nk else None,
                  term[nk:] if y.size > nk else None)
    return out


def json_view(result: dict) -> dict:
    """The result without its private arrays (keys starting with ``_``), for JSON."""
    return {k: v for k, v in result.items() if not k.startswith("_")}


def _sim_params(p: Params, h: float) -> Params:
    return p.replace(h=float(np.clip(h, 0.3, 1.1)))


def _maneuver_of(prep: Prepared):
    """The planned maneuver: the sidecar's (name and ``maneuver_options``) when it names a
    built-in one, else the recording's own filtered speed as a ``profile``."""
    from euc_sim.simulation import maneuvers
    name = prep.meta.get("maneuver")
    opts = prep.meta.get("maneuver_options") or {}
    if isinstance(name, str) and name in maneuvers.MANEUVERS and name != "profile":
        try:
            return maneuvers.make_maneuver(name, **opts), f"{name} {opts or '(defaults)'} from the sidecar"
        except ValueError:
            pass
    t = prep.t
    tt = np.arange(t[0], t[-1], 0.1)
    v = np.interp(tt, t, prep.qd[:, 0])
    return (maneuvers.Maneuver("profile", float(v[0]), (), (tuple((tt - t[0]).tolist()), tuple(v.tolist()))),
            "profile: the recording's own speed")


def resimulate_recording(prep: Prepared, result: dict, engine: str = "mujoco") -> dict:
    """Re-simulate the recording's maneuver, nominal and augmented, with the same controllers.

    The rider's plan is the sidecar's maneuver when it names a built-in one (with
    its ``maneuver_options``), else the recording's own speed (a ``profile``), so the
    closed loop of
    :func:`euc_sim.simulation.engine.simulate` (default motor PD and LQR rider) reproduces
    the maneuver; the nominal run uses h identified by the nominal model, the
    augmented one h re-identified with the accepted effects, which are injected as
    physics (moment, force at G, gravity direction, joint damping, mass, h(t), and a
    re-aligned rider channel for a time offset).

    Returns
    -------
    dict
        ``done``; per run (``nominal``, ``augmented``) the RMSE of φ (rad), γ (rad)
        and ẋ (m/s) against the recording; ``series`` (t, recorded and simulated φ, ẋ)
        for the figure; or ``reason`` when the maneuver could not be re-simulated.
    """
    from euc_sim.simulation import engine as simulation
    from euc_sim.simulation import maneuvers
    t = prep.t
    k = prep.keep
    man, how = _maneuver_of(prep)
    duration = float(t[-1] - t[0])
    eff = {}
    tau = 0.0
    for e in result["effects"]:
        name, val = e["name"], float(e["estimate"])
        if name == "sensor_time_offset":
            tau = val
            continue
        if name == "lateral_dynamics" and prep.lateral is None:
            continue
        eff[name] = abs(val) if name in ("cog_height_drift", "lateral_dynamics") else val
    runs = {"nominal": (_sim_params(prep.params, result["h_nominal"]), {}),
            "augmented": (_sim_params(prep.params, result["h_augmented"]), eff)}
    out = {"done": True, "engine": engine, "maneuver": how,
           "effects_injected": eff, "sensor_time_offset_applied": tau}
    rec_phi, rec_gam, rec_v = prep.q[k, 2], prep.q[k, 1], prep.qd[k, 0]
    series = {"t": t[k], "recording_phi": rec_phi, "recording_speed": rec_v, "recording_gamma": rec_gam}
    sim_dt = simulation.DEFAULT_DT
    lat_motion = None
    if "lateral_dynamics" in eff:     # the recording's own tilt and yaw, on the run's grid
        from scipy.integrate import cumulative_trapezoid

        grid = np.arange(int(round(duration / sim_dt)) + 1) * sim_dt + t[0]
        on = {key: np.interp(grid, t, v) for key, v in prep.lateral.items()}
        lat_motion = maneuvers.LateralMotion(on["theta"], on["theta_d"],
                                              cumulative_trapezoid(on["psi_d"], grid, initial=0.0),
                                              on["psi_d"], on["psi_dd"])
    for label, (p, e) in runs.items():
        try:
            run = simulation.simulate(man, duration, params=p, engine=engine, effects=e, dt=sim_dt,
                                      lateral_motion=lat_motion if e else None)
        except ValueError as exc:      # FallError and SimulationError are ValueErrors
            out[label] = {"error": str(exc).splitlines()[0]}
            continue
        ts = run["t"].to_numpy() + t[0]
        phi = np.interp(t[k], ts, run["phi"].to_numpy())
        if label == "augmented" and tau:
            phi = np.interp(t[k] - tau, ts, run["phi"].to_numpy())
        gam = np.interp(t[k], ts, run["gamma"].to_numpy())
        vs = np.interp(t[k], ts, run["x_dot"].to_numpy())
        out[label] = {"rmse_phi": float(np.sqrt(np.mean((phi - rec_phi) ** 2))),
                      "rmse_gamma": float(np.sqrt(np.mean((gam - rec_gam) ** 2))),
                      "rmse_speed": float(np.sqrt(np.mean((vs - rec_v) ** 2)))}
        series[f"{label}_phi"] = phi
        series[f"{label}_speed"] = vs
        series[f"{label}_gamma"] = gam
    out["series"] = series
    return out

"""Step 3, candidates: one term per catalog effect, from its physics; what a recording can see.

κ·(R Q_e,x + Q_e,γ + Q_e,φ) with Q_e from
:func:`euc_sim.simulation.effects.generalized_force` (virtual power, the paper's
Appendix A), or a finite-difference sensitivity of the residual for parameter and
measurement effects (rider mass, h drift, time offset).
"""

from __future__ import annotations

from dataclasses import replace
from typing import Callable

import numpy as np

from euc_sim.diagnosis import drift_term
from euc_sim.diagnosis.common import H_BOUNDS, LATERAL_WINDOW, RIDER_MASS_RANGE
from euc_sim.diagnosis.prepare import Prepared, lateral_inputs, marker_tilt
from euc_sim.diagnosis.residual import residual_model
from euc_sim.identification import regression as reg
from euc_sim.model import analytic
from euc_sim.model.parameters import Params
from euc_sim.simulation import effects

__all__ = ["visibility", "build_problem", "DriftGiven", "freeze", "validity_rules"]


# --- visibility -------------------------------------------------------------------------
def visibility(columns) -> dict[str, dict]:
    """Which catalog effects a recording with these ``columns`` can reveal: ``{effect: {"visible", "through",
    "reason"}}``."""
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


# --- the candidate library ---------------------------------------------------------------
def _force_column(name: str, prep: Prepared, p: Params, h: float, has_w: bool) -> np.ndarray:
    """The stacked column of a force effect per unit estimate: κ(q)·F[R Q_e,x + Q_e,γ + Q_e,φ], then with M_d
    (``has_w``) F[R Q_e,x], F the term filter."""
    ph = p.replace(h=h)
    kin = prep.kin
    ref = effects.get(name).ref        # the column's reference magnitude (linear forces: exact)
    Q = effects.generalized_force(name, ref, ph, kin.q, kin.qd, prep.lateral) / ref
    col = analytic.residual_gain(ph, kin.q[prep.keep]) * prep.filtered(analytic.moment_about_contact(ph, Q))
    return np.concatenate([col, p.R * prep.filtered(Q[:, 0])]) if has_w else col


def _sensitivity(prep: Prepared, p: Params, h: float, vary: Callable[[float], tuple]) -> np.ndarray:
    """Central difference of the stacked residual for a perturbed (params, prep)."""
    pa, pra = vary(-1.0)
    pb, prb = vary(1.0)
    return (residual_model(prb, pb)(h) - residual_model(pra, pa)(h)) / 2.0


def build_problem(prep: Prepared, h0: float, p: Params | None = None) -> tuple[reg.Problem, dict]:
    """The selection problem: residual r(h), candidate columns at ``h0`` (m) and validity rules.

    Returns
    -------
    problem : regression.Problem
    info : dict
        Per candidate, how θ maps to CONTRACT's estimate: ``{"scale": s, "offset": o}``
        (estimate = o + s·θ), or ``"drift"`` (:mod:`euc_sim.diagnosis.drift_term`).

    Notes
    -----
    The rider-mass term is the wheel row's only (needs M_d): in the kinematic row the
    residual's sensitivity to m is mostly the noise's own.
    """
    p = prep.params if p is None else p
    model = residual_model(prep, p)
    vis = visibility(prep.raw.columns)
    has_w = model.W is not None
    cands, info = _force_candidates(prep, p, h0, vis, has_w)
    more, more_info = _parameter_candidates(prep, p, h0, vis, has_w)
    cands.update(more)
    info.update(more_info)
    time = prep.stacked_time(has_w)
    validity = validity_rules(p, (float(prep.kin.t[0]), float(prep.kin.t[-1])), info.get("cog_height_drift", {}).get("drift"))
    drift_shape = info.get("cog_height_drift", {}).get("drift") or {}
    span = (float(prep.kin.t[0]), float(prep.kin.t[-1]))
    fixed = {c: v for c, v in cands.items() if c != "cog_height_drift"}
    adaptive = {"cog_height_drift": DriftGiven(prep, p, h0, fixed, span)} if "cog_height_drift" in cands else {}
    problem = reg.Problem(target=model, candidates=cands, time=time, bounds=H_BOUNDS,
                          validity={c: v for c, v in validity.items() if c in cands},
                          shape_params={"cog_height_drift": 2 if "start" in drift_shape else 0},
                          adaptive=adaptive)
    return problem, info


def _force_candidates(prep: Prepared, p: Params, h0: float, vis: dict, has_w: bool):
    """Columns and estimate maps of the force effects the recording can see."""
    cands: dict[str, np.ndarray] = {}
    info: dict[str, dict] = {}
    for name in (e.name for e in effects.CATALOG.values() if e.force is not None):
        if not vis[name]["visible"]:
            continue
        col = _force_column(name, prep, p, h0, has_w)
        if not np.any(np.abs(col) > 1e-9):
            continue
        cands[name] = col
        info[name] = ESTIMATE_MAPS.get(name, _linear_info)(prep, p, h0, col, has_w)
    return cands, info


def _linear_info(prep: Prepared, p: Params, h0: float, col: np.ndarray, has_w: bool) -> dict:
    """The estimate map of a force linear in its estimate: the coefficient itself."""
    return {"scale": 1.0, "offset": 0.0}


def _lateral_info(prep: Prepared, p: Params, h0: float, col: np.ndarray, has_w: bool) -> dict:
    """The estimate map of ``lateral_dynamics``: peak tilt (rad) = √s · band peak of the recorded tilt.

    Every lateral term is of second order in the turn, so a coupling s means a tilt √s times
    the recorded one.  ``scale_range`` (rad per √s) spans the choices the recording cannot
    make: the tilt source (angle channel or C, E markers), the window (:data:`LATERAL_WINDOW`
    halved or doubled, s projected as s_w = s ⟨c_w, c⟩ / ⟨c_w, c_w⟩), with the lean markers
    the rider's yaw inertia (isotropic or slender), and with M_d the kinematic row alone
    (docs/spatial.md).
    """
    df, dt = prep.raw, prep.kin.dt
    psi = np.unwrap(df["psi"].to_numpy(float))
    tilts = [df["theta"].to_numpy(float), marker_tilt(df, psi)]
    peaks = [effects.band_peak_tilt(th, dt, LATERAL_WINDOW) for th in tilts if th is not None]
    gains, labels = [1.0], ["column"]
    for w in (LATERAL_WINDOW / 2, LATERAL_WINDOW * 2):
        labels.append(f"window {w:g} s")
        alt = replace(prep, lateral=lateral_inputs(df, prep.kin.q, p, dt, w))
        c_w = _force_column("lateral_dynamics", alt, p, h0, has_w)
        gains.append(float(c_w @ col / (c_w @ c_w)))
    if prep.lateral.get("lean") is not None:      # the slender rider's upright term added
        lat, q = prep.lateral, prep.kin.q
        Q = np.zeros_like(q)
        Q[:, 2] = -effects.upright_slender_moment(p.replace(h=h0), q[:, 2], lat["theta"], lat["theta_d"], lat["psi_d"])
        ph = p.replace(h=h0)
        extra = analytic.residual_gain(ph, q[prep.keep]) * prep.filtered(analytic.moment_about_contact(ph, Q))
        c_w = col + (np.concatenate([extra, np.zeros_like(extra)]) if has_w else extra)
        gains.append(float(c_w @ col / (c_w @ c_w)))
        labels.append("slender rider")
    if has_w:      # the kinematic row alone: the wheel row's lateral coupling is not modelled
        y = residual_model(prep, p)(h0)
        k = y.size // 2
        s_all, s_kin = float(col @ y / (col @ col)), float(col[:k] @ y[:k] / (col[:k] @ col[:k]))
        if s_all > 0:
            gains.append(s_kin / s_all)
            labels.append("kinematic row alone")
    # every choice as a scale of √s: ``alternatives`` for the calibration by a simulated twin
    alternatives = {f"{g_name}, {p_name}": float(np.sqrt(max(g, 0.0)) * pk) for g_name, g in zip(labels, gains)
                    for p_name, pk in zip(("angle channel", "C, E markers"), peaks)}
    scales = list(alternatives.values())
    return {"scale": peaks[0], "offset": 0.0, "sqrt": True, "scale_range": [float(min(scales)), float(max(scales))],
            "alternatives": alternatives}


#: A force whose estimate is not its column's coefficient: name -> its estimate map
#: ``f(prep, p, h0, col, has_w) -> info`` (the others: :func:`_linear_info`).
ESTIMATE_MAPS = {"lateral_dynamics": _lateral_info}


def _parameter_candidates(prep: Prepared, p: Params, h0: float, vis: dict, has_w: bool):
    """Columns of the parameter and measurement effects: sensitivities of the residual."""
    k = prep.keep
    cands: dict[str, np.ndarray] = {}
    info: dict[str, dict] = {}
    # rider mass: r(m_nom) ≈ −∂r/∂m · Δm  ⇒  column −∂r/∂m, θ = Δm (kg)
    dm = 5.0

    def vary_m(s):
        return effects.apply_to_params(p, "rider_mass", p.m + s * dm), prep

    if vis["rider_mass"]["visible"]:
        # the wheel row's alone (build_problem's Notes)
        col = -_sensitivity(prep, p, h0, vary_m) / dm
        col[:k.size] = 0.0
        cands["rider_mass"] = col
        info["rider_mass"] = {"scale": 1.0, "offset": p.m}
    # time offset of the rider channel: φ_rec(t) = φ(t − τ) ⇒ r(0) ≈ −∂r/∂τ · τ
    dtau = 0.005

    def vary_tau(s):
        return p, prep.shifted(s * dtau)

    cands["sensor_time_offset"] = -_sensitivity(prep, p, h0, vary_tau) / dtau
    info["sensor_time_offset"] = {"scale": 1.0, "offset": 0.0}
    # h drift of any smooth shape: splines of Δh(t), with the ḣ terms (drift_term)
    model = residual_model(prep, p)
    drdh = model.slope(h0)
    time = prep.stacked_time(has_w)
    shape = drift_term.choose_shape(time, model(h0), drdh, max(time.size / 10.0, 5.0))
    cands["cog_height_drift"] = drift_term.drift_columns(prep, p, h0, drdh, has_w, shape)
    info["cog_height_drift"] = {"scale": 1.0, "offset": 0.0, "drift": shape,
                                "span": (float(prep.kin.t[0]), float(prep.kin.t[-1]))}
    return cands, info


class DriftGiven:
    """The h drift's adaptive term (:class:`regression.Problem`): its shape scanned on what the set's other
    members leave.

    Called with the others' names (a sorted tuple) it gives :class:`regression.Adapted`;
    :meth:`shape` the shape chosen; cached per set.
    """

    def __init__(self, prep: Prepared, p: Params, h0: float, cands: dict, span: tuple):
        self.prep, self.p, self.h0, self.cands, self.span = prep, p, h0, cands, span
        model = residual_model(prep, p)
        self.drdh = model.slope(h0)
        self.y = model(h0)
        self.has_w = model.W is not None
        self.time = prep.stacked_time(self.has_w)
        self._cache: dict = {}

    def shape(self, others: tuple) -> dict:
        return self._get(others)[1]

    def _get(self, others: tuple):
        if others not in self._cache:
            given = np.column_stack([np.asarray(self.cands[c], float).reshape(self.y.size, -1) for c in others]) if others else None
            shape = drift_term.choose_shape(self.time, self.y, self.drdh, max(self.time.size / 10.0, 5.0), given)
            cols = drift_term.drift_columns(self.prep, self.p, self.h0, self.drdh, self.has_w, shape)
            check = validity_rules(self.p, self.span, shape)["cog_height_drift"]
            self._cache[others] = (reg.Adapted(cols, 2 if "start" in shape else 0, check), shape)
        return self._cache[others]

    def __call__(self, others: tuple) -> reg.Adapted:
        return self._get(others)[0]


def freeze(problem: reg.Problem, info: dict, names) -> tuple[reg.Problem, dict]:
    """The problem with the drift's term fixed as it is inside the set ``names`` (as it would
    join it, when it is not a member), and ``info`` with that set's drift shape."""
    hook = problem.adaptive.get("cog_height_drift")
    if hook is None:
        return problem, info
    names = tuple(names)
    others = tuple(sorted(c for c in names if c != "cog_height_drift"))
    info = {**info, "cog_height_drift": {**info["cog_height_drift"], "drift": hook.shape(others)}}
    return problem.frozen(names), info


def validity_rules(p: Params, span: tuple, shape: dict | None) -> dict:
    """Physical-range checks of each candidate's θ (None: valid, else why); ``span``: first and last time, s;
    ``shape``: the drift's."""
    grid = np.linspace(span[0], span[1], 201)

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
        a = float(np.ptp(drift_term.shape_profile(shape, grid) @ theta))
        return None if a <= 0.6 else f"h drift {a:.2f} m peak to peak is beyond physical range (> 0.6 m)"

    # a force's coefficient within its record's bounds (a resistance, from 0: of the right sign)
    rules = {e.name: (positive if e.bounds[0] == 0 else bounded)(*e.bounds, "" if e.unit == "1" else e.unit)
             for e in effects.CATALOG.values() if e.force is not None}
    return {**rules,
            "lateral_dynamics": bounded(0.5, 2.0, "(coupling scale)"),
            "rider_mass": bounded(*RIDER_MASS_RANGE, "kg", offset=p.m),
            "sensor_time_offset": bounded(-0.3, 0.3, "s"),
            "cog_height_drift": drift}

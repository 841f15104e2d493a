"""The drivetrain between the road and the battery: battery, motor, controller, PWM.

Battery (Thevenin, no RC branch) and motor under PWM::

    V   = E₀ − k_Q·Q − R_int·I          Q = ∫I dt, Ah (coulomb counting)
    d·V = K_v·v + r_F·F                 K_v = K_e/R, V per m/s; F = P/v, N

``d`` the duty (0–1); with a logged phase current ``d·V = K_v·v + R_w·I_ph``.  At ``d = 1``
no torque is left (the cut-out: :mod:`euc_sim.rides.drive.cutout`).  Each fit is least squares
on :func:`euc_sim.rides.grids.power.power_signals` with a moving-block bootstrap 95 % interval
(30 s blocks).  See docs/drivetrain.md.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from euc_sim.rides.drive.mass import MassFit
from euc_sim.rides.drive.pwm import BASE, EXTRA, pwm_columns, select_pwm_terms
from euc_sim.rides.grids.power import G, RHO_AIR, PowerSignals
from euc_sim.rides.source.gaps import GAP_POLICY
from euc_sim.stats import block_labels, draw_blocks, gram_lstsq_many, label_grams, one_blas_thread, percentile_interval

__all__ = ["Term", "Drivetrain", "fit_battery", "charge_drawn", "fit_pwm", "predict_pwm", "fit_drivetrain"]


@dataclass(frozen=True)
class Term:
    """One identified drivetrain constant.

    Attributes
    ----------
    estimate : float or None
        None where the log cannot identify the term.
    ci95 : tuple of float or None
    unit : str or None
    why : str or None
        Why the term is not identified.
    accepted : bool or None
        For a term the balance fit gives (``parameter``): whether it is accepted.
    parameter : str or None
        The balance fit's parameter this term repeats (C_rr from ``rolling_resistance``, ...).
    """

    estimate: float | None
    ci95: tuple[float, float] | None
    unit: str | None
    why: str | None = None
    accepted: bool | None = None
    parameter: str | None = None


@dataclass(frozen=True)
class Drivetrain:
    """Identified battery, motor and road terms of one ride.

    Attributes
    ----------
    terms : dict of str -> Term
        By name (the JSON's ``drivetrain``: :func:`euc_sim.report.ride.contract.term_json`).
    unidentified : dict of str -> str
        Term -> why this log cannot identify it.
    pwm_coef : dict or None
        ``{"K_v": V per m/s, "r_F": V/N}`` of the PWM model (None without PWM).
    battery_coef : dict or None
        ``{"E0": V, "k_Q": V/Ah, "R_int": Ω}``.
    mass : float or None
        Total mass, kg.
    charge : numpy.ndarray or None
        The battery fit's charge drawn at each sample (:func:`charge_drawn`), Ah.
    """

    terms: dict
    unidentified: dict
    pwm_coef: dict | None
    battery_coef: dict | None
    mass: float | None
    charge: np.ndarray | None = None


def _lstsq_boot(X: np.ndarray, y: np.ndarray, t: np.ndarray, n_boot: int, seed: int):
    """Least squares and moving-block (30 s) bootstrap percentiles of each coefficient.

    A replicate's fit is from its blocks' Gram matrices summed (each block once per draw).
    """
    beta, *_ = np.linalg.lstsq(X, y, rcond=None)
    rng = np.random.default_rng(seed)
    _, label = np.unique(block_labels(t, 30.0), return_inverse=True)
    G = label_grams(np.column_stack([X, y]), label, int(label.max()) + 1)
    flat, p1 = G.reshape(len(G), -1), G.shape[-1]
    summed = np.empty((n_boot, p1, p1))
    for i in range(n_boot):
        counts = np.bincount(draw_blocks(len(G), rng), minlength=len(G)).astype(float)[None]
        summed[i] = np.dot(counts, flat).reshape(p1, p1)
    q = percentile_interval(gram_lstsq_many(summed).reshape(n_boot, X.shape[1]), min_draws=10)
    ci = [None if q is None else (float(q[0, j]), float(q[1, j])) for j in range(X.shape[1])]
    return beta, ci


def charge_drawn(t: np.ndarray, current: np.ndarray) -> np.ndarray:
    """Charge drawn from the battery since the first sample, Ah (an interval over the gap
    policy's ``charge`` adds nothing: the current across it is unknown).

    Parameters
    ----------
    t : numpy.ndarray
        s.
    current : numpy.ndarray
        Battery current, A (NaN counts as 0).
    """
    dt = np.r_[0.0, np.diff(t)]
    dt[dt > GAP_POLICY.charge] = 0.0
    return np.cumsum(np.nan_to_num(current) * dt) / 3600.0


def fit_battery(sig: PowerSignals, charge: np.ndarray, n_boot: int = 100, seed: int = 0):
    """Open-circuit voltage falling with ``charge``, the charge drawn at each sample
    (:func:`charge_drawn` of the log's current, Ah), and internal resistance.

    Returns
    -------
    coef : dict
        ``E0`` (V), ``k_Q`` (V/Ah), ``R_int`` (Ω).
    ci : dict
        Their 95 % intervals.
    """
    V, I = sig.extra["voltage"], sig.extra["current"]
    ok = np.isfinite(V) & np.isfinite(I)
    X = np.column_stack([np.ones(ok.sum()), -charge[ok], -I[ok]])
    beta, ci = _lstsq_boot(X, V[ok], sig.t[ok], n_boot, seed)
    names = ("E0", "k_Q", "R_int")
    return dict(zip(names, map(float, beta))), dict(zip(names, ci))


def _pwm_rows(sig: PowerSignals, v_min: float = 2.0) -> np.ndarray:
    d = sig.extra.get("pwm")
    ok = np.isfinite(d) & (np.nan_to_num(sig.v) > v_min) & np.isfinite(sig.P)
    return ok & np.isfinite(sig.extra["voltage"])


def _raw_speed(sig: PowerSignals) -> np.ndarray:
    """The wheel's own speed reading (the controller's ω·R), m/s."""
    return sig.v / sig.scale.estimate


def fit_pwm(sig: PowerSignals, n_boot: int = 100, seed: int = 0):
    """Back-EMF and resistive drop from the logged duty: d·V = K_v·v + r_F·F (+ the
    dead-time and flux-weakening terms that held-out validation keeps, :mod:`euc_sim.rides.drive.pwm`).

    Returns
    -------
    coef : dict
        ``K_v`` (V per m/s of the wheel's speed reading), ``r_F`` (V/N), and any
        kept ``dead_time`` (1), ``flux_weakening`` (V/(m/s)²) with ``v_fw`` (m/s,
        the fastest speed fitted: the weakening is not extrapolated beyond it).
    ci : dict
    """
    ok = _pwm_rows(sig)
    v = _raw_speed(sig)[ok]
    F = sig.P[ok] / v
    V, duty = sig.extra["voltage"][ok], sig.extra["pwm"][ok] / 100.0
    names, _ = select_pwm_terms(v, F, V, duty, sig.t[ok])
    beta, ci = _lstsq_boot(pwm_columns(v, F, V, names), duty * V, sig.t[ok], n_boot, seed)
    coef = dict(zip(names, map(float, beta)))
    if "flux_weakening" in coef:
        coef["v_fw"] = float(np.max(v))
    return coef, dict(zip(names, ci))


def predict_pwm(sig: PowerSignals, coef: dict) -> tuple[np.ndarray, np.ndarray]:
    """Duty predicted from speed, power and voltage, and the logged one, %, where both exist."""
    ok = _pwm_rows(sig)
    v = _raw_speed(sig)[ok]
    V = sig.extra["voltage"][ok]
    names = [n for n in BASE + tuple(EXTRA) if n in coef]
    X = pwm_columns(v, sig.P[ok] / v, V, names, coef.get("v_fw", np.inf))
    pred = X @ np.array([coef[n] for n in names]) / V * 100.0
    return pred, sig.extra["pwm"][ok]


def _phase_resistance(sig: PowerSignals, n_boot: int, seed: int):
    ok = _pwm_rows(sig) & np.isfinite(sig.extra.get("phase_current", np.full(sig.t.shape, np.nan)))
    v = _raw_speed(sig)[ok]
    y = sig.extra["pwm"][ok] / 100.0 * sig.extra["voltage"][ok]
    beta, ci = _lstsq_boot(np.column_stack([v, np.abs(sig.extra["phase_current"][ok])]), y,
                           sig.t[ok], n_boot, seed)
    return float(beta[1]), ci[1]


def fit_drivetrain(sig: PowerSignals, mass: MassFit, radius: float | None = None,
                   n_boot: int = 100, seed: int = 0) -> Drivetrain:
    """All drivetrain and road terms of one ride.

    Parameters
    ----------
    sig : PowerSignals
    mass : MassFit
        Gives the mass, the loss and the road terms.
    radius : float, optional
        Wheel radius, m (from the spec): converts K_v to the back-EMF constant
        K_e = K_v·R, V·s/rad.
    """
    with one_blas_thread():
        return _fit_drivetrain(sig, mass, radius, n_boot, seed)


def _fit_drivetrain(sig: PowerSignals, mass: MassFit, radius: float | None = None,
                    n_boot: int = 100, seed: int = 0) -> Drivetrain:
    terms, why = {}, dict(mass.unidentified)
    m = mass.estimate
    c = mass.coef
    # c₁ and c₃ hold the road's resistances and the losses with the same speed law
    road = {"c1": c.get("rolling", 0.0), "c3": c.get("drag", 0.0)}
    if "rolling" in c and m:
        ci = mass.coef_ci95.get("rolling")
        terms["C_rr"] = Term(road["c1"] / (m * G),
                             tuple(x / (m * G) for x in ci) if ci else None, "dimensionless")
    if "drag" in c:
        ci = mass.coef_ci95.get("drag")
        terms["C_dA"] = Term(2 * road["c3"] / RHO_AIR,
                             tuple(2 * x / RHO_AIR for x in ci) if ci else None, "m^2")
    if "no_load" in c:
        terms["no_load_power"] = Term(c["no_load"], mass.coef_ci95.get("no_load"), "W")
    if "copper" in c:
        name, unit = {"phase_current": ("winding_resistance", "ohm"),
                      "force": ("copper_loss_per_force2", "W/N^2")}.get(
                          mass.copper_column, ("copper_loss_per_accel2", "W/(m/s^2)^2"))
        terms[name] = Term(c["copper"], mass.coef_ci95.get("copper"), unit)
    if "grade" in c:
        terms["grade_mass"] = Term(c["grade"], mass.coef_ci95.get("grade"), "kg")
    terms["speed_scale"] = Term(mass.scale.estimate,
                                (mass.scale.estimate - 1.96 * mass.scale.sd,
                                 mass.scale.estimate + 1.96 * mass.scale.sd), "dimensionless")
    charge = charge_drawn(sig.t, sig.extra["current"])
    bcoef, bci = fit_battery(sig, charge, n_boot, seed)
    for k, unit in (("E0", "V"), ("k_Q", "V/Ah"), ("R_int", "ohm")):
        terms[{"E0": "ocv_start", "k_Q": "ocv_per_Ah", "R_int": "internal_resistance"}[k]] = \
            Term(bcoef[k], bci[k], unit)
    pcoef = None
    if "pwm" in sig.extra and _pwm_rows(sig).sum() > 200:
        pcoef, pci = fit_pwm(sig, n_boot, seed)
        terms["back_emf_per_speed"] = Term(pcoef["K_v"], pci["K_v"], "V/(m/s)")
        if radius:
            terms["back_emf_constant"] = Term(pcoef["K_v"] * radius,
                                              tuple(x * radius for x in pci["K_v"]) if pci["K_v"]
                                              else None, "V*s/rad")
        terms["resistive_drop"] = Term(pcoef["r_F"], pci["r_F"], "V/N")
        for name, (_, unit) in EXTRA.items():
            if name in pcoef:
                terms[name] = Term(pcoef[name], pci[name], unit)
        if "v_fw" in pcoef:
            terms["flux_weakening_up_to"] = Term(pcoef["v_fw"], None, "m/s")
        if "phase_current" in sig.extra:
            r, rci = _phase_resistance(sig, n_boot, seed)
            terms["phase_resistance_pwm"] = Term(r, rci, "ohm")
    else:
        why["pwm"] = "no PWM or safety-margin column: back-EMF and the duty limit cannot be identified"
    return Drivetrain(terms=terms, unidentified=why, pwm_coef=pcoef, battery_coef=bcoef, mass=m,
                      charge=charge)

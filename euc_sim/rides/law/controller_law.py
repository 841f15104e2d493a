"""The wheel's own balance law, read from a log that has pitch and motor torque.

The nominal law is the paper's PD (Section 3), M_d = K_p (γ − γ_ref) + K_d γ̇, fitted on the
riding rows of :func:`~euc_sim.rides.grids.law_signals.law_rows`.  The logged pitch is
tilt = s·γ + tilt₀, so the nominal regression y = c₀ + c_P·tilt + c_D·tilt' gives s = sign
c_P, K_p = |c_P|, K_d = s·c_D, tilt₀ = −c₀/c_P.  The catalogued terms (:data:`CATALOG`:
``tiltback``, ``accel_setpoint``, ``integral`` with a :data:`INTEGRAL_TAU` leak,
``brake_gain``, ``torque_limit``) are each kept when they lower the blocked held-out RMS
error by :data:`MIN_GAIN`; intervals by a 30 s moving-block bootstrap of the whole fit.
:class:`LawUnavailable` says, with numbers, why a log cannot show the law.  See
docs/controller.md.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import NamedTuple

import numpy as np
import scipy.linalg

from euc_sim.stats import block_bootstrap_indices, blocks_by_length, percentile_interval
from euc_sim.stats import forward_select as select_by_heldout
from euc_sim.stats import time_blocks
from euc_sim.rides.grids.law_signals import (INTEGRAL_TAU, MAX_PITCH, V_MIN, LawRows, LawUnavailable,
                                       law_rows)

# LawUnavailable, LawRows, law_rows, V_MIN, MAX_PITCH and INTEGRAL_TAU are defined in
# euc_sim.rides.grids.law_signals and exported here too: this module is the law's public face.
__all__ = ["LawUnavailable", "LawRows", "Law", "LawFit", "CATALOG", "BASE", "V_MIN", "MAX_PITCH", "MIN_GAIN",
           "INTEGRAL_TAU", "R2_MIN", "law_rows", "fit_params", "predict", "fit_law",
           "heldout_score", "r2"]

#: A kept term must lower the held-out RMS error by this fraction.
MIN_GAIN = 0.01
#: The acceleration set-point, tried after the other terms, must lower the held-out
#: RMS error by this fraction.  Value: see docs/controller.md.
ACCEL_GAIN = 0.05
#: Rows on either side of a row at the torque limit left out of the fit, and passes
#: of the censoring (:func:`_censored_lstsq`).
CENSOR_GUARD = 1
CENSOR_ITER = 3
#: Below this held-out R² the pitch does not explain the torque: no law is reported.
R2_MIN = 0.5
#: The pitch's law must explain this much more held-out R² than speed alone.
PITCH_GAIN = 0.1
#: Always in the model.
BASE = ("offset", "P", "D")
#: Catalogued terms: name -> what it is.
CATALOG: dict[str, str] = {
    "tiltback": "pitch set-point tilting back above a speed",
    "accel_setpoint": "pitch set-point moving with acceleration",
    "integral": "integral action on the pitch",
    "brake_gain": "a different proportional gain while braking",
    "torque_limit": "a torque (current) limit",
}
_TB_GRID = np.linspace(0.30, 0.95, 14)       # tilt-back onset: quantiles of the riding speed
_LIM_GRID = (0.9, 0.95, 0.98, 0.99, 0.995, 0.999)   # torque limit: quantiles of |y|


def _columns(rows: LawRows, names, v_tb: float = np.inf, nominal: tuple[float, float] | None = None,
             mean3: bool = False) -> np.ndarray:
    """Columns of the law, torque = X·c, one per name (``torque_limit`` has none): the tilt-back's
    above its onset ``v_tb`` (m/s), ``brake_gain``'s by the nominal PD's (sign, tilt0).  ``mean3``:
    each column as its mean over [t₋₁, t₊₁] (``rows.w3``), the interval of the rate columns.
    """
    tilt, v, z = (rows.tilt3, rows.v3, rows.z3) if mean3 else (rows.tilt, rows.v, rows.z)
    make = {"offset": lambda: np.ones_like(tilt), "P": lambda: tilt,
            "D": lambda: rows.tilt_dot,
            "tiltback": lambda: np.maximum(v - v_tb, 0.0),
            "accel_setpoint": lambda: rows.a, "integral": lambda: z,
            "brake_gain": lambda: (tilt - nominal[1]) * (nominal[0] * (tilt - nominal[1]) < 0)}
    cols = []
    for n in names:
        if n == "torque_limit":
            continue
        c = make[n]()
        cols.append(np.sum(rows.w3 * c, axis=1) if mean3 and c.ndim == 2 else c)
    return np.column_stack(cols)


def _target(rows: LawRows) -> np.ndarray:
    """The torque's mean over [t₋₁, t₊₁] (the fitted quantity, unit of y)."""
    return np.sum(rows.w3 * rows.y3, axis=1)


def _lstsq(X: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Least-squares β of y ≈ X·β by LAPACK's pivoted QR (``gelsy``, faster than the SVD driver)."""
    return scipy.linalg.lstsq(X, y, lapack_driver="gelsy", check_finite=False)[0]


def _censored_lstsq(X: np.ndarray, y: np.ndarray, M: float, at_limit: np.ndarray) -> np.ndarray:
    """Least squares of ``y`` on ``X`` leaving out the rows the limit ``M`` touches (at the
    limit, or commanded beyond it by the previous pass) and their :data:`CENSOR_GUARD`
    neighbours; ``M = inf``: plain least squares.
    """
    if not np.isfinite(M):
        return _lstsq(X, y)
    bad = at_limit.copy()
    beta, last = None, None
    for _ in range(CENSOR_ITER):
        if beta is not None:
            bad = bad | (np.abs(X @ beta) >= M)
        out = bad.copy()
        for k in range(1, CENSOR_GUARD + 1):
            out[k:] |= bad[:-k]
            out[:-k] |= bad[k:]
        if out.sum() > 0.5 * y.size:
            out = at_limit
        if last is not None and np.array_equal(out, last):
            break                                   # the censored rows settled
        beta, last = _lstsq(X[~out], y[~out]), out
    return beta


class LawFit(NamedTuple):
    """One fit of the law (:func:`fit_params`): ``beta`` column -> coefficient (the log's convention),
    the tilt-back onset ``v_tb`` m/s and limit ``M_max`` (unit of y; inf without), the nominal PD's
    (sign, tilt0) and the ``physical`` terms (:func:`_physical`)."""

    names: list
    beta: dict[str, float]
    v_tb: float
    M_max: float
    nominal: tuple[float, float]
    physical: dict[str, float]


def fit_params(rows: LawRows, names) -> LawFit:
    """Fit the law with terms ``names`` (``BASE`` plus any of ``CATALOG``) on ``rows``.

    Linear least squares of the torque on the columns of :func:`_columns`; the
    tilt-back onset ``v_tb`` on a grid of the riding speed's quantiles, the limit
    ``M_max`` on a grid of |y|'s upper quantiles (rows at the limit left out of the
    linear fit, the prediction clipped), each the grid point of least squared error.

    Returns
    -------
    LawFit
    """
    names = list(names)
    lin = [n for n in names if n != "torque_limit"]
    y = _target(rows)
    b0 = _lstsq(_columns(rows, BASE, mean3=True), y)
    nominal = (1.0 if b0[1] >= 0 else -1.0, float(-b0[0] / b0[1]) if b0[1] else 0.0)
    lims = [np.inf]
    if "torque_limit" in names:
        lims = [float(np.quantile(np.abs(rows.y), q)) for q in _LIM_GRID]
    v_tbs = [np.inf]
    if "tiltback" in names:
        v_tbs = [float(np.quantile(rows.v, q)) for q in _TB_GRID]
    best = None
    for M in lims:
        for v_tb in v_tbs:
            X = _columns(rows, lin, v_tb, nominal, mean3=True)
            beta = _censored_lstsq(X, y, M, np.any(np.abs(rows.y3) >= 0.99 * M, axis=1))
            sse = float(np.sum((y - np.clip(X @ beta, -M, M)) ** 2))
            if best is None or sse < best[0]:
                best = (sse, beta, M, v_tb)
    _, beta, M, v_tb = best
    c = dict(zip(lin, map(float, beta)))
    return LawFit(names, c, v_tb, M, nominal, _physical(c))


def _physical(c: dict[str, float]) -> dict[str, float]:
    """The coefficients ``c`` in the log's convention → the paper's law (γ forward positive):
    ``tilt = s·γ + tilt₀``, M = K_p (γ − γ_ref) + K_d γ̇ + K_i ∫γ: ``sign``, ``K_p``, ``K_d``,
    ``tilt0`` and the kept terms' gains."""
    s = 1.0 if c["P"] >= 0 else -1.0
    Kp = abs(c["P"])
    out = {"sign": s, "K_p": Kp, "K_d": s * c["D"], "tilt0": -c["offset"] / c["P"] if c["P"] else 0.0}
    if "tiltback" in c:
        out["tiltback_gain"] = c["tiltback"] / Kp
    if "accel_setpoint" in c:
        out["accel_setpoint_gain"] = -c["accel_setpoint"] / Kp
    if "integral" in c:
        out["K_i"] = s * c["integral"]
    if "brake_gain" in c:
        out["K_p_brake"] = Kp + s * c["brake_gain"]
    return out


def predict(rows: LawRows, fit: LawFit, mean3: bool = False) -> np.ndarray:
    """The law's torque on ``rows`` from their pitch, speed and acceleration (unit of
    ``rows.y``), clipped at the limit; ``mean3``: its mean over [t₋₁, t₊₁], the fitted
    quantity (:func:`_target`)."""
    lin = [n for n in fit.names if n != "torque_limit"]
    pred = _columns(rows, lin, fit.v_tb, fit.nominal, mean3) @ np.array([fit.beta[n] for n in lin])
    return np.clip(pred, -fit.M_max, fit.M_max)


def r2(y: np.ndarray, pred: np.ndarray) -> float:
    """1 − Σ(y − ŷ)²/Σ(y − ȳ)²."""
    return float(1.0 - np.sum((y - pred) ** 2) / np.sum((y - np.mean(y)) ** 2))


def _heldout(rows: LawRows, predict_block) -> tuple[np.ndarray, np.ndarray]:
    """The torque (its mean over [t₋₁, t₊₁], :func:`_target`, the fitted quantity) and its
    blocked held-out prediction: each of 10 contiguous time blocks (rows ``test``) predicted
    by ``predict_block(test, y)`` from a fit on the others."""
    label = time_blocks(rows.t, 10)
    y = _target(rows)
    pred = np.empty_like(y)
    for b in range(10):
        test = label == b
        pred[test] = predict_block(test, y)
    return y, pred


def heldout_score(rows: LawRows, names) -> tuple[float, float]:
    """Blocked held-out RMS error (unit of y) and R² of the torque (:func:`_heldout`; grids
    re-found per fold)."""
    y, pred = _heldout(rows, lambda test, y: predict(rows.take(test), fit_params(rows.take(~test), names),
                                                     mean3=True))
    return float(np.sqrt(np.mean((y - pred) ** 2))), r2(y, pred)


def _without_pitch_r2(rows: LawRows, accel: bool = True, v_tb: float = np.inf) -> float:
    """Blocked held-out R² of the torque (:func:`_heldout`) from speed (1, v, v², (v − v_tb)⁺)
    and, with ``accel``, acceleration: what the ride explains without the pitch."""
    cols = [np.ones_like(rows.v), rows.v, rows.v ** 2]
    if np.isfinite(v_tb):
        cols.append(np.maximum(rows.v - v_tb, 0.0))
    X = np.column_stack(cols + ([rows.a] if accel else []))
    return r2(*_heldout(rows, lambda test, y: X[test] @ _lstsq(X[~test], y[~test])))


def _select_with_pairs(score, candidates: list) -> tuple[list, list]:
    """Forward selection from ``BASE``; when no single term earns :data:`MIN_GAIN`, the best pair
    left is tried as one step (a tilt-back and a torque limit may be needed together).
    """
    names, history = select_by_heldout(score, list(BASE), candidates, MIN_GAIN)
    while True:
        left = [c for c in candidates if c not in names]
        cur = history[-1]["heldout_rmse"]
        trial = {(a, b): score(names + [a, b]) for i, a in enumerate(left) for b in left[i + 1:]}
        if not trial:
            return names, history
        pair = min(trial, key=trial.get)
        if trial[pair] >= cur * (1.0 - MIN_GAIN):
            return names, history
        names = names + list(pair)
        history.append({"term": "+".join(pair), "heldout_rmse": trial[pair]})
        names, more = select_by_heldout(score, names, [c for c in candidates if c not in names], MIN_GAIN)
        history += more[1:]


@dataclass(frozen=True)
class Law:
    """A wheel's balance law identified on one log.

    Attributes
    ----------
    names : list of str
        ``BASE`` plus the kept catalogued terms, in order.
    fit : LawFit
        :func:`fit_params` on the whole log.
    terms : dict
        Physical term → ``(estimate, ci95 or None, unit)``, paper's signs.
    sign : int
        +1 when the logged pitch grows as the body leans forward.
    heldout_rmse : float
        Blocked held-out RMS error of the torque, the selection's score.
    heldout_r2, nominal_r2, blind_r2 : float
        Blocked held-out R² of the torque from the kept law, the nominal PD alone, and speed
        and acceleration without the pitch.
    history : list of dict
        ``{"term", "heldout_rmse"}`` per step.
    channel, unit : str
    scale : float
        N·m per unit of the logged channel.
    sign_share : float
        Share of bootstrap replicates agreeing on the sign.
    """

    names: list
    fit: LawFit
    terms: dict
    sign: int
    heldout_rmse: float
    heldout_r2: float
    nominal_r2: float
    blind_r2: float
    history: list
    channel: str
    unit: str
    scale: float
    sign_share: float
    notes: list = field(default_factory=list)


def _terms(fit: LawFit, unit: str) -> dict[str, tuple[float, str]]:
    """The physical terms for people and JSON: name → (value, unit)."""
    per, ph = unit + "/rad", fit.physical
    out = {"K_p": (ph["K_p"], per), "K_d": (ph["K_d"], unit + "·s/rad"),
           "pitch_zero": (ph["tilt0"], "rad (logged)")}
    if "tiltback_gain" in ph:
        out["tiltback_speed"] = (fit.v_tb, "m/s")
        out["tiltback_gain"] = (ph["tiltback_gain"], "rad/(m/s)")
    if "accel_setpoint_gain" in ph:
        out["accel_setpoint_gain"] = (ph["accel_setpoint_gain"], "rad/(m/s^2)")
    if "K_i" in ph:
        out["K_i"] = (ph["K_i"], unit + "/(rad·s)")
    if "K_p_brake" in ph:
        out["K_p_brake"] = (ph["K_p_brake"], per)
    if np.isfinite(fit.M_max):
        out["torque_limit"] = (fit.M_max, unit)
    return out


def _bootstrap(rows: LawRows, names, n_boot: int, seed: int, block: float = 30.0):
    rng = np.random.default_rng(seed)
    blocks = blocks_by_length(rows.t, block)
    draws, signs = [], []
    for _ in range(n_boot):
        idx = block_bootstrap_indices(blocks, rng)
        f = fit_params(rows.take(idx), names)
        signs.append(f.physical["sign"])
        draws.append({k: v for k, (v, _) in _terms(f, rows.unit).items()})
    return draws, np.asarray(signs)


def fit_law(rows: LawRows, n_boot: int = 100, seed: int = 0) -> Law:
    """Identify the balance law on ``rows``: nominal PD, catalogued terms kept by held-out
    validation, 95 % block-bootstrap intervals.  :class:`LawUnavailable` when the pitch is
    too quantised, the stamps too coarse, or the held-out R² without the acceleration
    column is below :data:`R2_MIN`.
    """
    spread = float(np.subtract(*np.percentile(rows.tilt, [95, 5])))
    deg = math.degrees
    if rows.pitch_step > 0 and spread < 3 * rows.pitch_step:
        raise LawUnavailable(f"the riding pitch spans {deg(spread):.2f}° (5–95 %), under 3 of the "
                             f"log's {deg(rows.pitch_step):.2f}° steps: the pitch is too quantised")
    if rows.dt_median > 1.0:
        raise LawUnavailable(f"median sample interval {rows.dt_median:.2f} s: too coarse for a "
                             f"balance law that acts within a fraction of a second")
    score = lambda n: heldout_score(rows, n)[0]                         # noqa: E731
    names, history = _select_with_pairs(score, [n for n in CATALOG if n != "accel_setpoint"])
    # acceleration also carries the ride's physics (the torque follows it whatever the
    # firmware does): its set-point term is tried last and must earn ACCEL_GAIN
    names, more = select_by_heldout(score, names, ["accel_setpoint"], ACCEL_GAIN)
    history += more[1:]
    rmse, r2_kept = heldout_score(rows, names)
    r2_nom = heldout_score(rows, BASE)[1]
    r2_blind = _without_pitch_r2(rows)
    pitch_only = [n for n in names if n != "accel_setpoint"]
    r2_pitch = r2_kept if pitch_only == names else heldout_score(rows, pitch_only)[1]
    v_tb = fit_params(rows, pitch_only).v_tb
    r2_speed = _without_pitch_r2(rows, accel=False, v_tb=v_tb)
    if r2_pitch < R2_MIN or r2_pitch - r2_speed < PITCH_GAIN:
        raise LawUnavailable(
            f"held-out R² of the {rows.channel}: {r2_nom:.2f} from the pitch's PD, {r2_pitch:.2f} "
            f"from the pitch with {', '.join(pitch_only[3:]) or 'no'} catalogued terms "
            f"({R2_MIN:g} needed, and {PITCH_GAIN:g} more than the {r2_speed:.2f} from speed "
            f"alone), {r2_kept:.2f} adding acceleration, {r2_blind:.2f} from speed and "
            f"acceleration alone; riding pitch spread {deg(spread):.2f}° (5–95 %), steps "
            f"{deg(rows.pitch_step):.3f}°, median interval {rows.dt_median:.2f} s: the pitch "
            f"stays nearly level whatever the torque, so the law is not visible in this log")
    fit = fit_params(rows, names)
    draws, signs = _bootstrap(rows, names, n_boot, seed)
    terms = {}
    for k, (val, unit) in _terms(fit, rows.unit).items():
        xs = np.array([d[k] for d in draws if k in d and np.isfinite(d[k])])
        ci = None
        q = percentile_interval(xs, min_draws=10)
        if q is not None:
            # the draws' 2.5-97.5 % percentiles, reaching out to the estimate where the draws
            # lie to one side of it (a grid-searched onset or limit, or few draws): widened,
            # never narrowed, so the interval always holds its own estimate
            ci = (float(min(q[0], val)), float(max(q[1], val)))
        terms[k] = (float(val), ci, unit)
    sign = int(fit.physical["sign"])
    return Law(names=names, fit=fit, terms=terms, sign=sign, heldout_rmse=rmse,
               heldout_r2=r2_kept, nominal_r2=r2_nom, blind_r2=r2_blind, history=history, channel=rows.channel,
               unit=rows.unit, scale=rows.scale, sign_share=float(np.mean(signs == sign)) if signs.size else math.nan)

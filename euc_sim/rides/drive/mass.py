"""The total mass (rider plus wheel) found blind from a ride log's battery power.

The battery gives the road's mechanical power plus the drivetrain's losses::

    P = V·I = m·a·v + m·g·ḣ + c₁·v + c₃·v³ + k_cu·I_ph² + P₀

(m the translating mass plus J/R², kg; g·ḣ the climb from GPS altitude; c₁·v rolling and
losses linear in speed; c₃ = ½ρC_dA plus losses growing with v³; k_cu·I_ph² the copper
loss, with the proxy a² or the drive force² without phase current; P₀ a constant drain).
The losses are added, regeneration is P < 0, so no efficiency multiplies the mass.  The
balance is fitted over 2, 4 and 8 s windows (:mod:`euc_sim.rides.drive.energy`); the
estimate is their median and the 95 % interval pools their 30 s moving-block bootstrap
replicates, widened by :mod:`euc_sim.rides.source.systematic`.  A log without signed
current fits |P̂| and gives no mass.  See docs/drivetrain.md.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from euc_sim.rides.drive.energy import window_difference, window_mean, window_samples_odd
from euc_sim.rides.source.channels import power_not_measured
from euc_sim.stats import block_labels, distinct, draw_blocks, gram_lstsq_many, label_grams, percentile_interval
from euc_sim.stats import forward_select as select_by_heldout
from euc_sim.stats import one_blas_thread, time_blocks
from euc_sim.rides.source.ride import Ride
from euc_sim.rides.grids.power import (G, NO_GPS_SCALE_SD, MassSettings, PowerSignals, RideDataError,
                                 SpeedScale, power_signals)
from euc_sim.rides.source.systematic import combined_interval, current_scale_kg, speed_scale_kg

__all__ = ["MassFit", "mass_regressors", "energy_regressors", "fit_mass", "predict_power",
           "heldout_folds", "heldout_rmse"]

def _shift(x: np.ndarray, lag: int) -> np.ndarray:
    """x delayed by ``lag`` samples (x(t − lag)); NaN where undefined."""
    out = np.full(x.shape, np.nan)
    if lag > 0:
        out[lag:] = x[:-lag]
    elif lag < 0:
        out[:lag] = x[-lag:]
    else:
        out[:] = x
    return out


#: The energy balance's loss and road terms beyond the inertia, by name: (physics, unit of the
#: coefficient).  Nuisance terms of the mass: the ride's rolling, drag and idle-loss parameters
#: are the balance fit's (:data:`euc_sim.rides.balance.design.CANDIDATES`, :mod:`euc_sim.rides.balance.parameters`).
ENERGY_TERMS = {
    "rolling": ("c₁·v: rolling resistance and losses linear in speed", "N"),
    "drag": ("c₃·v³: aerodynamic drag ½ρC_dA and losses growing with v³", "kg/m"),
    "no_load": ("P₀: constant drain (controller, lights)", "W"),
    "grade": ("β_h·g·ḣ: climb from GPS altitude (β_h ≈ m, attenuated by altitude noise)", "kg"),
    "copper": ("k_cu·I_ph²: winding loss (R_w, ohm, with phase current; else a² proxy)", "ohm"),
}


def mass_regressors(sig: PowerSignals, lag: int, force: tuple | None = None) -> dict[str, np.ndarray]:
    """Columns of the battery-power model, the speed signals delayed by ``lag`` samples.

    Returns
    -------
    dict
        ``inertia`` a·v (W/kg), ``rolling`` v (m/s), ``drag`` v³ (m³/s³),
        ``no_load`` 1, ``copper`` I_ph² (A², phase current not delayed) or a²
        ((m/s²)², when the log has no phase current) and ``grade`` g·ḣ (W/kg)
        when the log has GPS altitude.
    """
    v = _shift(sig.v, lag)
    cols = {"inertia": _shift(sig.av, lag), "rolling": v, "drag": v ** 3,
            "no_load": np.ones_like(v)}
    if "phase_current" in sig.extra:
        cols["copper"] = sig.extra["phase_current"] ** 2
    elif force is not None:                     # (m, c₁, c₃): see energy_regressors
        cols["copper"] = (force[0] * _shift(sig.a, lag) + force[1] + force[2] * v ** 2) ** 2
    else:
        cols["copper"] = _shift(sig.a, lag) ** 2
    if sig.climb is not None:
        cols["grade"] = _shift(sig.climb, lag)
    return cols


def _solve(X: np.ndarray, y: np.ndarray, signed: bool) -> np.ndarray:
    """Least squares of y on X; for an unsigned log, of y on |X·β| (Gauss–Newton)."""
    beta, *_ = np.linalg.lstsq(X, y, rcond=None)
    if signed:
        return beta
    from scipy.optimize import least_squares

    x0 = beta.copy()
    x0[0] = max(beta[0], 50.0)                  # a positive mass to start from
    res = least_squares(lambda b: np.abs(X @ b) - y, x0, method="lm", max_nfev=40 * X.shape[1])
    return res.x


@dataclass(frozen=True)
class MassFit:
    """The blind total-mass estimate and the balance it comes from.

    Attributes
    ----------
    estimate : float or None
        Mass of the ``a·v`` term, kg: m_eq (eq. 6) as :func:`fit_mass` returns it, rider plus
        wheel once :func:`~euc_sim.rides.drive.rotating.without_rotating_inertia` took J_w/R²
        out; None when not identified (``why``).
    ci95, stat_ci95 : tuple of float or None
        95 % interval, kg, with and without ``systematic``.
    coef, coef_ci95 : dict
        Coefficient of every accepted term (SI, :data:`ENERGY_TERMS`) and its interval.
    terms : list of str
        Accepted terms in order of acceptance.
    history : list of dict
        ``{"term", "heldout_rmse"}`` (W) after each step, the first the inertia alone.
    lag : float
        Delay of the speed signals against the current, s.
    scale : SpeedScale
    signed : bool
    n_samples : int
    unidentified : dict
        Term or quantity -> why this log cannot identify it.
    why : str
        Why ``estimate`` is None, else "".
    by_window : dict
        Energy-balance window (s) -> its mass, kg.
    equivalent : dict
        ``{"estimate", "ci95", "rotating_inertia"}`` (kg) once J_w/R² is taken out.
    copper_column : str
        ``"phase_current"`` (I_ph²), ``"force"`` ((m·a + c₁ + c₃v²)²) or ``"accel"`` (a²).
    systematic : dict
        Source -> 95 % half-width, kg (:mod:`euc_sim.rides.source.systematic`).
    """

    estimate: float | None
    ci95: tuple[float, float] | None
    coef: dict
    coef_ci95: dict
    terms: list
    history: list
    lag: float
    scale: SpeedScale
    signed: bool
    n_samples: int
    unidentified: dict
    why: str = ""
    by_window: dict = field(default_factory=dict)
    equivalent: dict = field(default_factory=dict)
    copper_column: str = "accel"
    systematic: dict = field(default_factory=dict)
    stat_ci95: tuple | None = None


def _rows(sig: PowerSignals, cols: dict, v_min: float) -> np.ndarray:
    ok = np.isfinite(sig.P) & (np.nan_to_num(sig.v) > v_min)
    for c in cols.values():
        ok &= np.isfinite(c)
    return ok


def _best_lag(sig: PowerSignals, settings: MassSettings) -> int:
    """The delay, in samples, that best explains power with the base terms."""
    n = int(round(settings.max_lag * settings.rate))
    best = (np.inf, 0)
    for lag in range(-n, n + 1):
        cols = mass_regressors(sig, lag)
        cols.pop("grade", None)
        ok = _rows(sig, cols, settings.v_min)
        X = np.column_stack([c[ok] for c in cols.values()])
        beta, *_ = np.linalg.lstsq(X, sig.P[ok], rcond=None)
        rms = float(np.sqrt(np.mean((sig.P[ok] - X @ beta) ** 2)))
        best = min(best, (rms, lag))
    return best[1]


def heldout_folds(t: np.ndarray, signed: bool) -> np.ndarray:
    """Each row's block for :func:`heldout_rmse`: 10 contiguous blocks of the times ``t`` (s), or 4
    for an unsigned log (whose fits are nonlinear)."""
    return time_blocks(t, 10 if signed else 4)


def heldout_rmse(X: np.ndarray, y: np.ndarray, label: np.ndarray, signed: bool) -> float:
    """RMS error, W, predicting each contiguous time block (``label``, :func:`heldout_folds`) from the rest."""
    n_blocks = int(label.max()) + 1
    if signed:                  # linear: each fold's fit from the other blocks' Gram matrices
        grams = label_grams(np.column_stack([X, y]), label, n_blocks)
        sse = 0.0
        for Gb, beta in zip(grams, gram_lstsq_many(grams.sum(axis=0) - grams)):
            r = np.append(beta, -1.0)                               # y − X·β = −[X y]·r
            sse += float(r @ Gb @ r)
        return float(np.sqrt(max(sse, 0.0) / len(y)))
    err = np.empty_like(y)
    for b in range(n_blocks):
        test = label == b
        err[test] = y[test] - np.abs(X[test] @ _solve(X[~test], y[~test], signed))
    return float(np.sqrt(np.mean(err ** 2)))


def _select(cols: dict, y: np.ndarray, t: np.ndarray, signed: bool,
            min_gain: float = 0.005) -> tuple[list, list]:
    """Forward selection of speed-only terms by blocked held-out RMSE."""
    X = lambda names: np.column_stack([cols[c] for c in names])   # noqa: E731
    label = heldout_folds(t, signed)
    return select_by_heldout(lambda names: heldout_rmse(X(names), y, label, signed), ["inertia"],
                          [c for c in ENERGY_TERMS if c in cols], min_gain)


def _mass(beta: dict) -> float:
    return float(beta["inertia"]) if beta["inertia"] > 0 else float("nan")


def energy_regressors(sig: PowerSignals, lag: int, n: int, rate: float,
                      force: tuple | None = None) -> tuple[np.ndarray, dict]:
    """Both sides of the energy balance over windows of ``n`` samples (odd; T = (n − 1)/``rate``).

    ``lag`` delays the speed signals (samples); with ``force`` (m kg, c₁ N, c₃ kg/m) and no
    phase current the copper column is the squared drive force, not a².  Returns the window
    mean of battery power (W) and the :func:`mass_regressors` columns as window means
    (``inertia`` and ``grade`` as window differences over T).
    """
    seg = sig.segment
    v = _shift(sig.raw["v"], lag)
    mean = lambda x: window_mean(x, seg, n)                        # noqa: E731
    cols = {"inertia": window_difference(0.5 * v ** 2, seg, n, rate), "rolling": mean(v),
            "drag": mean(v ** 3), "no_load": np.ones_like(v)}
    if "phase_current" in sig.raw:
        cols["copper"] = mean(sig.raw["phase_current"] ** 2)
    elif force is not None:
        m, c1, c3 = force
        vs = _shift(sig.v, lag)
        cols["copper"] = mean((m * _shift(sig.a, lag) + c1 + c3 * vs ** 2) ** 2)
    else:
        cols["copper"] = mean(_shift(sig.a, lag) ** 2)
    if "h" in sig.raw:
        cols["grade"] = G * window_difference(_shift(sig.raw["h"], lag), seg, n, rate)
    return mean(sig.raw["P"]), cols


@dataclass(frozen=True)
class _Design:
    """One window's regression: columns by name, power, time (rows kept)."""

    window: float
    cols: dict
    y: np.ndarray
    t: np.ndarray

    def X(self, names) -> np.ndarray:
        return np.column_stack([self.cols[c] for c in names])


def _design(sig: PowerSignals, lag: int, window: float, settings: MassSettings,
            force: tuple | None = None) -> _Design:
    n = window_samples_odd(window, settings.rate)
    y, cols = energy_regressors(sig, lag, n, settings.rate, force)
    ok = np.isfinite(y) & (np.nan_to_num(cols["rolling"]) > settings.v_min)
    for c in cols.values():
        ok &= np.isfinite(c)
    return _Design((n - 1) / settings.rate, {k: c[ok] for k, c in cols.items()}, y[ok], sig.t[ok])


def _bootstrap(designs: list, names, signed, settings: MassSettings, mid: int):
    """Moving-block bootstrap, the same blocks for every window: the masses of every replicate
    and window pooled, and the replicates' coefficients at window ``mid``.
    """
    rng = np.random.default_rng(settings.seed)
    t0 = min(d.t[0] for d in designs)
    labels = [block_labels(d.t, settings.block, t0) for d in designs]
    blocks = [] if signed else [{b: np.flatnonzero(lab == b) for b in distinct(lab)} for lab in labels]
    keys = np.unique(np.concatenate(labels))
    n_boot = settings.n_boot if signed else max(10, settings.n_boot // 10)  # |P̂|: slow fits
    # a signed log's fit is linear: a replicate's Gram matrix is its blocks' Grams summed
    # (keys, (p + 1)²) each: a replicate's Gram matrix is its block counts times these
    grams = ([label_grams(np.column_stack([d.X(names), d.y]), np.searchsorted(keys, lab),
                          keys.size).reshape(keys.size, -1) for d, lab in zip(designs, labels)] if signed else None)
    p1 = len(names) + 1
    coef = np.empty((n_boot, len(designs), len(names)))
    summed = np.empty((n_boot, len(designs), p1, p1))
    for i in range(n_boot):
        pick = keys[draw_blocks(keys.size, rng)]
        counts = np.bincount(np.searchsorted(keys, pick), minlength=keys.size).astype(float)[None]
        for k, d in enumerate(designs):
            if signed:
                summed[i, k] = np.dot(counts, grams[k]).reshape(p1, p1)
            else:
                idx = np.concatenate([blocks[k].get(b, np.empty(0, int)) for b in pick])
                coef[i, k] = _solve(d.X(names)[idx], d.y[idx], signed)
    if signed:
        coef = gram_lstsq_many(summed)
    m = coef[:, :, names.index("inertia")].ravel()
    return np.where(m > 0, m, np.nan), coef[:, mid, :]                      # no draws: 0 rows


def _ci(x: np.ndarray) -> tuple[float, float] | None:
    q = percentile_interval(x[np.isfinite(x)], min_draws=10)
    return None if q is None else (float(q[0]), float(q[1]))


def fit_mass(log, settings: MassSettings = MassSettings(), sig: PowerSignals | None = None) -> MassFit:
    """Estimate the total mass from a log alone (never from a stated rider weight).

    The terms are selected on the middle window of ``settings.windows``; ``sig`` reuses
    :func:`power_signals`.  :class:`RideDataError` naming file and column for a log without
    voltage or current, or never ridden.
    """
    with one_blas_thread():
        return _fit_mass(log, settings, sig)


def _fit_mass(log, settings: MassSettings = MassSettings(), sig: PowerSignals | None = None) -> MassFit:
    sig = sig if sig is not None else power_signals(log, settings)
    lag = _best_lag(sig, settings)
    designs = [_design(sig, lag, w, settings) for w in sorted(settings.windows)]
    mid = len(designs) // 2
    if designs[-1].y.size < 20 * settings.rate:
        raise RideDataError(f"{log.path}: column 'speed': only {designs[-1].y.size / settings.rate:.0f} s "
                            f"ridden above {settings.v_min * 3.6:.1f} km/h in {designs[-1].window:g} s "
                            f"windows; need 20 s")
    names, history = _select(designs[mid].cols, designs[mid].y, designs[mid].t, sig.signed)
    betas = [dict(zip(names, _solve(d.X(names), d.y, sig.signed))) for d in designs]
    copper_column = "phase_current" if "phase_current" in sig.raw else "accel"
    efficiency_model = 0.0
    if "copper" in names and "phase_current" not in sig.raw:
        f_designs, f_betas = _force_copper(sig, lag, settings, names, betas)
        m_a = np.median([_mass(b) for b in betas])
        m_f = np.median([_mass(b) for b in f_betas])
        efficiency_model = abs(float(m_f - m_a))
        if settings.copper_model == "force":
            designs, betas, copper_column = f_designs, f_betas, "force"
    by_window = {d.window: _mass(b) for d, b in zip(designs, betas)}
    masses, coefs = _bootstrap(designs, names, sig.signed, settings, mid)
    m = float(np.median(list(by_window.values())))
    why = "" if math.isfinite(m) else (
        f"the coefficient of a·v is {betas[mid]['inertia']:.3g} kg, not positive: the "
        f"acceleration power does not show the mass")
    if not sig.signed:
        m, why = float("nan"), ("the battery current is never negative: braking cannot be told "
                                "from driving, so the acceleration power's sign is lost and the "
                                "mass is not identified")
        if derived := power_not_measured(log):
            why += "; " + derived
    ok = math.isfinite(m)
    systematic, stat = {}, _ci(masses) if ok else None
    if ok:
        systematic = {"speed_scale": speed_scale_kg(m, sig.scale.sd),
                      "current_scale": current_scale_kg(m, settings.current_scale_sd),
                      "efficiency_model": efficiency_model if math.isfinite(efficiency_model) else 0.0,
                      "grade": _grade_kg(designs[mid], names, sig, m, settings)}
    return MassFit(
        estimate=m if ok else None,
        ci95=combined_interval(m, stat, systematic) if ok and stat else None,
        stat_ci95=stat, systematic=systematic,
        coef=betas[mid], coef_ci95={n: _ci(coefs[:, i]) for i, n in enumerate(names)},
        terms=[h["term"] for h in history[1:]], history=history, lag=lag / settings.rate, scale=sig.scale,
        signed=sig.signed, n_samples=int(designs[mid].y.size), unidentified=_unidentified(log, sig), why=why,
        by_window=by_window if ok else {}, copper_column=copper_column)


def _grade_kg(d: "_Design", names, sig: PowerSignals, m: float, settings: MassSettings) -> float:
    """95 % half-width, kg, of the grade: the mass's change without the GPS-altitude grade term
    (middle window), or without altitude the prior share ``settings.grade_share`` of the mass."""
    if "grade" not in d.cols:
        return settings.grade_share * m
    if "grade" not in names:
        return 0.0
    with_g = _mass(dict(zip(names, _solve(d.X(names), d.y, sig.signed))))
    rest = [n for n in names if n != "grade"]
    without = _mass(dict(zip(rest, _solve(d.X(rest), d.y, sig.signed))))
    dm = abs(with_g - without)
    return float(dm) if math.isfinite(dm) else 0.0


def _force_copper(sig: PowerSignals, lag: int, settings: MassSettings, names, betas):
    """The copper loss as κ·F², F = m·a + c₁ + c₃v² from the fit itself, iterated 4 times per
    window from its coefficients ``betas``; the final designs and coefficients.
    """
    designs, out = [], []
    for k, w in enumerate(sorted(settings.windows)):
        b = betas[k]
        for _ in range(4):
            m = b["inertia"] if np.isfinite(b["inertia"]) and b["inertia"] > 0 else 100.0
            d = _design(sig, lag, w, settings, (m, b.get("rolling", 0.0), b.get("drag", 0.0)))
            b = dict(zip(names, _solve(d.X(names), d.y, sig.signed)))
        designs.append(d)
        out.append(b)
    return designs, out


def _unidentified(log: Ride, sig: PowerSignals) -> dict[str, str]:
    """What this log cannot identify, and why."""
    out = {}
    if not sig.signed:
        out["regeneration"] = ("battery current is never negative in this log: braking cannot "
                               "be told from driving; the log is taken to carry |P| and |model| "
                               "is fitted")
    if sig.climb is None:
        out["grade"] = "no GPS altitude: road grade cannot be identified (left in the residual)"
    if sig.scale.source == "assumed":
        out["speed_scale"] = (f"no GPS speed: speedometer scale assumed 1 ± "
                              f"{NO_GPS_SCALE_SD:.0%}, propagated into the mass interval")
    if why := power_not_measured(log):
        out["battery_power"] = why
    if sig.current_from_phase:
        out["phase_current"] = ("the battery current is the app's duty × phase current (to 3 %), "
                                "not measured: the phase current is not used for the copper loss")
    if "phase_current" not in sig.extra:
        out["winding_resistance"] = ("no phase current: the copper loss is fitted as κ·F², F the "
                                     "drive force the fit implies (m·a + c₁ + c₃v²; or its proxy a²), "
                                     "so the winding resistance itself is not identified")
    return out


def predict_power(sig: PowerSignals, fit: MassFit, v_min: float = 1.0) -> tuple[np.ndarray, np.ndarray]:
    """Battery power predicted by ``fit`` on ``sig`` (possibly another ride) and the logged one, W,
    on the samples faster than ``v_min`` m/s; |P̂| for an unsigned log.
    """
    lag = int(round(fit.lag * (1.0 / np.median(np.diff(sig.t)))))
    c = fit.coef
    force = ((c["inertia"], c.get("rolling", 0.0), c.get("drag", 0.0))
             if fit.copper_column == "force" else None)
    cols = mass_regressors(sig, lag, force)
    names = list(fit.coef)
    if any(n not in cols for n in names):        # e.g. grade fitted, no altitude here
        names = [n for n in names if n in cols]
    ok = _rows(sig, {n: cols[n] for n in names}, v_min)
    pred = sum(fit.coef[n] * cols[n][ok] for n in names)
    return (pred if sig.signed else np.abs(pred)), sig.P[ok]

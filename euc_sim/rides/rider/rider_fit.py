"""The simulated rider calibrated on a ride log: reaction delay, feedback bandwidth, motor noise.

The fitted settings: ``delay`` τ (s, the predictor tuned to it), ``bandwidth`` ρ (the LQR's
state/input weight ratio relative to Bryson's, R = 1/(ρ^½ M_h,scale)²; ρ > 1 stiffer) and
``noise_std`` σ (N·m, Ornstein–Uhlenbeck ankle-torque noise, correlation time held at
0.05 s).  The features are the log RMS of the battery power, motor torque and pitch in
the :data:`BAND_WINDOWS` bands (:mod:`euc_sim.rides.grids.rider_features`).  Method of
simulated moments: the rider rides windows of the fit ride in MuJoCo, read as the log is
written (:mod:`euc_sim.rides.sim.reading`); a quadratic response surface of each feature
is fitted on design points in shrinking boxes and the weighted squared distance to the
log's features minimised on it, weights 1/(variance of the log's + the simulation's
features) from a 10 s block bootstrap, which also gives the 95 % intervals.  See
docs/rider_calibration.md.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from numbers import Integral
from typing import Callable, Mapping, Sequence

import numpy as np
import pandas as pd

from euc_sim.controllers.motor import MotorPD
from euc_sim.controllers.rider import Rider
from euc_sim.model.parameters import Params
from euc_sim.rides.grids.profile import PLAN_WINDOW, rider_plan, speed_profile
from euc_sim.rides.rider.response_surface import lhs as _lhs, minimise as _minimise, surface as _surface
from euc_sim.rides.sim.reading import quantise, stamp_readings
from euc_sim.rides.grids.rider_features import (BAND_WINDOWS, RiderFitError, band_features,  # noqa: F401
                                         fit_windows, log_channels)
from euc_sim.rides.grids.signals import RideAssumptions
from euc_sim.rides.source.gaps import GAP_POLICY
from euc_sim.rides.rider.rider_params import RIDER_PARAMS, rider_from
from euc_sim.rides.sim.simulate import battery_power
from euc_sim.simulation.engine import simulate
from euc_sim.simulation.errors import FallError
from euc_sim.simulation.maneuvers import Maneuver

__all__ = ["BAND_WINDOWS", "RiderFitError", "RiderFit",
           "log_channels", "band_features", "fit_windows", "fit_rider"]


#: Block length of the bootstrap, s.
BLOCK = 10.0


@dataclass(frozen=True)
class _Setup:
    """Everything a window simulation needs but the rider."""

    channels: pd.DataFrame
    names: tuple                      # channel names used
    windows: tuple
    profile: tuple                    # (t, v) of the whole ride
    params: Params
    motor: MotorPD
    effects: dict
    drivetrain: dict
    seed: int
    dt: float
    lead: float
    repeats: int = 1                  # noise draws per window, their mean squares averaged


def _rows_and_blocks(setup: _Setup) -> tuple[np.ndarray, np.ndarray]:
    t = setup.channels["t"].to_numpy()
    rows = np.zeros(t.size, bool)
    block = np.full(t.size, -1)
    nb = 0
    for t0, t1 in setup.windows:
        m = (t >= t0) & (t <= t1)
        rows |= m
        k = np.floor((t[m] - t0) / BLOCK).astype(int)
        block[m] = nb + k
        nb += int(k.max()) + 1
    return rows, block


def _features(frame: pd.DataFrame, names, rows, block=None) -> np.ndarray:
    seg = frame["segment"].to_numpy()
    rate = 1.0 / float(np.median(np.diff(frame["t"].to_numpy())))
    parts = [band_features(frame[c].to_numpy(), seg, rate, rows, block) for c in names]
    return np.concatenate(parts, axis=-1)


def _window_span(t: np.ndarray, windows) -> tuple[np.ndarray, np.ndarray]:
    """Rows a window's simulation covers (1 s before it to 0.5 s after) and their window label."""
    seg = np.full(t.size, -1)
    for w, (t0, t1) in enumerate(windows):
        seg[(t >= t0 - 1.0) & (t <= t1 + 0.5)] = w
    return seg >= 0, seg


def _windowed_log(setup: _Setup) -> pd.DataFrame:
    """The log's channels cut as the simulation is (NaN outside the windows, one segment each),
    so the band smoothers meet the same edges on both sides.
    """
    ch = setup.channels
    inside, seg = _window_span(ch["t"].to_numpy(), setup.windows)
    out = {c: np.where(inside, ch[c].to_numpy(), np.nan) for c in setup.names}
    return pd.DataFrame({"t": ch["t"].to_numpy(), "segment": seg, **out})


def _simulated_channels(setup: _Setup, rider: Rider, draw: int = 0) -> pd.DataFrame | None:
    """The rider along the windows, read like the log (:mod:`euc_sim.rides.sim.reading`, in the
    log's steps ``channels.attrs["quantum"]``); None when he falls.  Seeds
    ``setup.seed + 1000 draw + window``.
    """
    ch = setup.channels
    t = ch["t"].to_numpy()
    stamps = ch.attrs["stamps"]
    quantum = ch.attrs.get("quantum", {})
    tp, vp = setup.profile
    out = {c: np.full(t.size, np.nan) for c in setup.names}
    seg = np.full(t.size, -1)
    dtv = setup.drivetrain
    for w, (t0, t1) in enumerate(setup.windows):
        start = t0 - setup.lead
        sel = (tp >= start - 1.0) & (tp <= t1 + 1.0)
        man = Maneuver(name="profile", table=(tuple((tp[sel] - start).tolist()), tuple(vp[sel].tolist())))
        try:
            df = simulate(man, t1 + 0.5 - start, params=setup.params, motor=setup.motor, rider=rider,
                          seed=setup.seed + 1000 * draw + w, effects=setup.effects, dt=setup.dt)
        except FallError:
            return None
        ts = df["t"].to_numpy() + start
        rng = np.random.default_rng(setup.seed + 1000 * draw + w)
        sim = {"P": battery_power(df["M_d"], df["x_dot"], df["gamma_dot"], setup.params.R,
                                  dtv.get("copper_loss", 0.0), dtv.get("drivetrain_idle_loss", 0.0)),
               "M": df["M_d"].to_numpy(), "pitch": df["gamma"].to_numpy()}
        st = stamps[(stamps >= t0 - 1.0) & (stamps <= t1 + 0.5)]
        m = (t >= t0 - 1.0) & (t <= t1 + 0.5)
        for c in setup.names:
            reading = stamp_readings(ts, sim[c], st)
            q = quantum.get(c)
            if q:                                              # written in the log's steps
                reading = quantise(reading, q, rng)
            out[c][m] = np.interp(t[m], st, reading)
        seg[m] = w
    return pd.DataFrame({"t": t, "segment": seg, **out})


def _simulated_mean_squares(setup: _Setup, rider: Rider, rows, block) -> np.ndarray | None:
    """(blocks, F) mean squares of the bands, averaged over ``setup.repeats`` noise draws."""
    ms = []
    for r in range(setup.repeats):
        sim = _simulated_channels(setup, rider, r)
        if sim is None:
            return None
        ms.append(_features(sim, setup.names, rows, block))
    return np.mean(ms, axis=0)


def _simulated_features(setup: _Setup, values: Mapping[str, float], rows, block):
    """Log RMS of the bands (F,) of the rider ``values``, or None when he falls."""
    ms = _simulated_mean_squares(setup, rider_from(values, setup.params, setup.motor), rows, block)
    return None if ms is None else _log_rms(ms)


def _log_rms(ms: np.ndarray) -> np.ndarray:
    """Log RMS over the blocks of (blocks, F) mean squares (blocks of equal length but the last)."""
    return 0.5 * np.log(ms.mean(axis=0))


@dataclass(frozen=True)
class RiderFit:
    """The rider calibrated on a ride.

    Attributes
    ----------
    rider : Rider
        Gains designed for the fit's params and motor.
    params : dict
        name → ``{"value", "lo", "hi"`` (95 %), ``"bound"``, ``"at_bound"``, ``"nominal"``, ``"unit"}``.
    objective, objective_nominal : float
        Weighted squared feature distance of the calibrated and the default rider.
    features : dict
        ``names``, ``log``, ``fitted``, ``nominal`` (log RMS).
    windows : tuple of (t0, t1)
        s, the stretches ridden.
    simulations : int
        Closed-loop window sets simulated (falls included).
    notes : tuple of str
    falls : tuple of dict
        The design points at which the rider fell.
    """

    rider: Rider
    params: dict
    objective: float
    objective_nominal: float
    features: dict
    windows: tuple
    simulations: int
    notes: tuple = field(default=())
    falls: tuple = field(default=())


def _values_of(x: np.ndarray) -> dict[str, float]:
    """The rider's parameters by name, in their own units, from the fit's scaled ``x``."""
    return {p.name: p.from_unit(float(u)) for p, u in zip(RIDER_PARAMS, x)}


def _round(setup: _Setup, rows, block, F_log, w, npts, center, level, pool, rng):
    """One response-surface round around ``center`` with box level ``level``.

    Simulates ``npts`` design points (``center`` and a Latin hypercube of the box) into
    ``pool`` (X, F, drawn, fell); a point where the rider falls moves halfway back towards
    one that rode (:func:`_ride_or_halve`), and fresh points top the round up.  Fits the
    quadratic surface on the points near ``center`` and minimises it in the box.  Returns
    the new center, the surface, the hull of its points (3 × 2), the next level and whether
    the optimum is on the box's edge; :class:`RiderFitError` with fewer than
    :data:`MIN_POINTS` points that rode.
    """
    X, F, drawn, fell = pool
    half = _HALVES[min(level, len(_HALVES) - 1)]
    nearest = lambda c: X[int(np.argmin([np.sum((xi - c) ** 2) for xi in X]))] if X else c  # noqa: E731
    # where he rode: the center, or halfway back from it to the nearest point that rode, or that point
    center = X[-1] if _ride_or_halve(setup, rows, block, center, nearest(center), pool) else nearest(center)
    box = np.stack([np.clip(center - half, 0, 1), np.clip(center + half, 0, 1)], axis=1)
    rode, start = sum(_ride_or_halve(setup, rows, block, x, nearest(center), pool)
                      for x in _lhs(npts - 1, box, rng)), len(drawn)
    while rode < npts - 1 and len(drawn) - start < ROUND_BUDGET * npts:   # top up where he rides
        rode += _ride_or_halve(setup, rows, block, _lhs(1, box, rng)[0], nearest(center), pool)
    near = [i for i, x in enumerate(X) if np.all(np.abs(x - center) <= max(half, 0.2) + 1e-9)]
    if len(near) < MIN_POINTS:
        short = lambda x: ", ".join(f"{k} {v:.3g}" for k, v in _values_of(x).items())  # noqa: E731
        raise RiderFitError(f"rider fit: only {len(near)} of the design points near {short(center)} rode without "
                            f"falling ({MIN_POINTS} needed: a quadratic in the three settings has {MIN_POINTS} coefficients); "
                            f"{len(fell)} of {len(drawn)} simulated fell, the last at {'; '.join(map(short, fell[-6:]))}")
    Xn, Fn = np.asarray(X)[near], np.asarray(F)[near]
    coef = _surface(Xn, Fn)
    hull = np.stack([Xn.min(axis=0), Xn.max(axis=0)], axis=1)
    best = np.argsort([np.sum(w * (f - F_log) ** 2) for f in Fn])[:3]
    new = _minimise(coef, F_log, w, box, np.vstack([center, Xn[best]]))
    edge = ((np.abs(new - box[:, 0]) < 1e-6) & (box[:, 0] > 1e-9)) | \
           ((np.abs(new - box[:, 1]) < 1e-6) & (box[:, 1] < 1 - 1e-9))
    return new, coef, hull, level + (0 if edge.any() else 1), bool(edge.any())


def _ride_or_halve(setup: _Setup, rows, block, x: np.ndarray, anchor: np.ndarray, pool) -> bool:
    """Simulate the design point ``x`` into ``pool`` (noise seed + :data:`POINT_SEED` × its rank); where
    the rider falls, the point halfway to ``anchor`` instead, up to :data:`HALVINGS` times.  True when one rode."""
    X, F, drawn, fell = pool
    for _ in range(HALVINGS + 1):
        drawn.append(x)
        f = _simulated_features(replace(setup, seed=setup.seed + POINT_SEED * len(drawn)), _values_of(x),
                                rows, block)
        if f is not None:
            X.append(x)
            F.append(f)
            return True
        fell.append(x)
        if np.allclose(x, anchor):
            return False
        x = anchor + 0.5 * (x - anchor)
    return False


#: Offset of the noise seeds on which the search's paths are compared.
CHECK_SEED = 100_000
#: Step of the design points' noise seeds: independent draws leave their noise to the surface's
#: least squares (common draws let the search end where one realisation matches the log).
POINT_SEED = 10_007
#: Half-widths of the search boxes by level, in the scaled [0, 1] coordinates.
_HALVES = (0.5, 0.2, 0.08)
#: A design point at which the rider falls moves halfway back to the round's center at most this often.
HALVINGS = 2
#: Design points a round's surface needs: a quadratic in the three settings has 10 coefficients.
MIN_POINTS = 10
#: Fresh points top a round up to the points it asked for that rode, in at most this many times as many.
ROUND_BUDGET = 2


def _search(setup: _Setup, rows, block, F_log, w, rounds, rng, say) -> tuple[np.ndarray, np.ndarray, np.ndarray, int]:
    """Response-surface rounds in shrinking boxes, from two starts along the delay.

    Delay and bandwidth trade off along a curved valley, so the later rounds run from the
    first round's optimum and from its best point farther along the delay; each path's
    optimum is scored on draws of its own (:data:`CHECK_SEED`) and the nearer to the log
    kept.  A box shrinks only when its optimum is inside it.  Returns the optimum in [0, 1]³,
    the surface, the hull of its points, the number of simulations and the points that fell.
    """
    X, F, drawn, fell = [], [], [], []
    J = lambda f: float(np.sum(w * (f - F_log) ** 2))                 # noqa: E731
    nominal = np.array([p.to_unit(p.nominal) for p in RIDER_PARAMS])
    center, coef, hull, level, edge = _round(setup, rows, block, F_log, w, rounds[0], nominal, 0, (X, F, drawn, fell), rng)
    n_sims = len(drawn)
    say(f"rider fit round 1: {n_sims} simulations, now {_values_of(center)}")
    starts = [center]
    if len(rounds) > 1:
        half = _HALVES[min(level, len(_HALVES) - 1)]
        far = [i for i, x in enumerate(X) if abs(x[0] - center[0]) > half]
        if far:
            starts.append(X[min(far, key=lambda i: J(F[i]))])
    # the paths are compared on noise draws of their own: on the design's draws a path can
    # end where that one realisation happens to match the log
    check = replace(setup, seed=setup.seed + CHECK_SEED)
    finals = []
    for k, c in enumerate(starts):
        lv, cf, hl = level, coef, hull
        for r, npts in enumerate(rounds[1:]):
            c, cf, hl, lv, edge = _round(setup, rows, block, F_log, w, npts, c, lv, (X, F, drawn, fell), rng)
            n_sims = len(drawn) + k
            say(f"rider fit start {k + 1} round {r + 2}: {n_sims} simulations, now {_values_of(c)}"
                + (" (on the box's edge: the next box moves there)" if edge else ""))
        f = _simulated_features(check, _values_of(c), rows, block) if len(starts) > 1 else None
        if f is not None and _simulated_features(setup, _values_of(c), rows, block) is None:
            f = None                    # rides the check's draws but falls on the fit's own: not kept
        n_sims += 2 * (len(starts) > 1)
        finals.append((J(f) if f is not None else (0.0 if len(starts) == 1 else math.inf), k, c, cf, hl))
    _, k, center, coef, hull = min(finals, key=lambda z: z[0])
    if len(finals) > 1:
        say("rider fit: the paths end at " + "; ".join(f"{_values_of(z[2])} (distance {z[0]:.1f})"
                                                         for z in finals) + f": start {k + 1} kept")
    return center, coef, hull, n_sims, np.asarray(fell).reshape(-1, len(RIDER_PARAMS))


def _fall_note(fell: np.ndarray, n_sims: int) -> str:
    """Where the design points fell, for the notes (the region the plant cannot be ridden in)."""
    v = np.array([[_values_of(x)[p.name] for p in RIDER_PARAMS] for x in fell]).reshape(-1, len(RIDER_PARAMS))
    where = [f"{p.name} {v[:, j].min():.3g}–{v[:, j].max():.3g} {p.unit}" for j, p in enumerate(RIDER_PARAMS) if len(v)]
    return f"{len(v)} of {n_sims} design simulations fell" + (" (each moved back towards a point that rode): "
                                                              + ", ".join(where) if len(v) else "")


def _param_table(center: np.ndarray, boot: np.ndarray) -> tuple[dict, list]:
    """``RiderFit.params`` from the optimum and the bootstrap optima (both in [0, 1]³), and warnings."""
    out, notes = {}, []
    values = _values_of(center)
    for j, p in enumerate(RIDER_PARAMS):
        lo_u, hi_u = np.percentile(boot[:, j], [2.5, 97.5])
        at = bool(center[j] < 0.01 or center[j] > 0.99)
        out[p.name] = {"value": values[p.name], "lo": p.from_unit(lo_u), "hi": p.from_unit(hi_u),
                       "bound": [p.lo, p.hi], "at_bound": at, "nominal": p.nominal, "unit": p.unit}
        if at:
            notes.append(f"WARNING: rider parameter {p.name!r} = {values[p.name]:.3g} {p.unit} ends on "
                         f"its search bound [{p.lo:g}, {p.hi:g}]: the log wants a rider outside the range")
    return out, notes


def fit_rider(log, *, params: Params, motor: MotorPD | None = None,
              effects: Mapping[str, float] | None = None,
              drivetrain: Mapping[str, float] | None = None,
              assumptions: RideAssumptions = RideAssumptions(),
              channels: Sequence[str] | None = None, windows: int = 3, window_length: float = 60.0,
              plan_window: float = PLAN_WINDOW, max_gap: float = GAP_POLICY.rider, rounds: Sequence[int] = (14, 12, 10),
              n_boot: int = 200, repeats: int = 1, seed: int = 0, dt: float = 2e-3,
              progress: Callable[[str], None] | None = None) -> RiderFit:
    """Fit the simulated rider's delay, bandwidth and motor noise to a ride log.

    Parameters
    ----------
    log : Ride
        The fit ride (never the held-out one).
    params : Params
        The simulated ride's parameters.
    motor : MotorPD, optional
        The wheel's law (default the paper's PD).
    effects : mapping, optional
        Effects injected as physics (CONTRACT units).
    drivetrain : mapping, optional
        ``copper_loss`` (W/N²), ``drivetrain_idle_loss`` (W) of the battery-power model.
    assumptions : RideAssumptions
        For the torque constant.
    channels : sequence of str, optional
        Subset of ``P``, ``M``, ``pitch`` (default every one the log has).
    windows, window_length : int, float
        Stretches ridden at each evaluation, and their length, s.
    plan_window : float
        The rider's plan is the logged speed smoothed over this many s.
    max_gap : float
        Longest gap bridged in the log's readings, s.
    rounds : sequence of int
        Design points per response-surface round (:func:`_search`).
    n_boot : int
        Block-bootstrap replicates of the interval.
    repeats : int
        Motor-noise draws per design point, their mean squares averaged.
    seed : int
        Seed of the design and the bootstrap.
    dt : float
        Simulation step, s.
    progress : callable, optional
        Called with a short line per round.

    Raises
    ------
    RiderFitError
        No battery power or window to ride, a rider falling at every design point, or a bad
        setting (named before any simulation).
    """
    for name, value, least in (("windows", windows, 1), ("n_boot", n_boot, 2), ("repeats", repeats, 1)):
        if not (isinstance(value, Integral) and value >= least):
            raise RiderFitError(f"{name} must be an integer of at least {least}, got {value!r}")
    if not (math.isfinite(window_length) and window_length > 0):
        raise RiderFitError(f"window_length must be a positive number of seconds, got {window_length!r}")
    if not (len(rounds) > 0 and all(isinstance(n, Integral) and n >= 2 for n in rounds) and rounds[0] >= 10):
        raise RiderFitError(f"rounds must be design-point counts, the first at least 10 and the others "
                            f"at least 2, got {tuple(rounds)!r}")
    say = progress or (lambda s: None)
    motor = motor or MotorPD()
    dtv = {"copper_loss": 0.0, "drivetrain_idle_loss": 0.0} | dict(drivetrain or {})
    ch = log_channels(log, assumptions, max_gap=max_gap)
    have = [c for c in ("P", "M", "pitch") if c in ch]
    names = tuple(have if channels is None else channels)
    for c in names:
        if c not in have:
            raise RiderFitError(f"channels: {c!r} is not in the log {log.path} (it has {have})")
    wins = tuple(fit_windows(ch, windows, window_length))
    prof = speed_profile(log)
    plan = rider_plan(prof["t"].to_numpy(), prof["v"].to_numpy(), plan_window)
    setup = _Setup(ch, names, wins, (prof["t"].to_numpy(), plan), params, motor,
                   dict(effects or {}), dtv, seed, dt, 8.0, repeats)
    rows, block = _rows_and_blocks(setup)
    ms_log = _features(_windowed_log(setup), names, rows, block)   # (blocks, F) mean squares
    F_log = _log_rms(ms_log)
    feat_names = [f"{c}_band{k}" for c in names for k in range(len(BAND_WINDOWS))]
    rng = np.random.default_rng(seed)
    boot_idx = rng.integers(0, len(ms_log), size=(n_boot, len(ms_log)))
    d_log = 0.5 * np.log(ms_log[boot_idx].mean(axis=1)) - F_log   # (n_boot, F)
    # the log's variance + the simulation's (the same per draw, averaged over `repeats` draws)
    var = np.maximum((1.0 + 1.0 / repeats) * d_log.var(axis=0), 0.05 ** 2)
    w = 1.0 / var
    center, coef, hull, n_sims, fell = _search(setup, rows, block, F_log, w, rounds, rng, say)
    values = _values_of(center)
    rider = rider_from(values, params, motor)
    ms_sim = _simulated_mean_squares(setup, rider, rows, block)
    F_nom = _simulated_features(setup, {p.name: p.nominal for p in RIDER_PARAMS}, rows, block)
    if ms_sim is None:
        raise RiderFitError(f"rider fit: the rider nearest the log's features ({', '.join(f'{k} {v:.3g}' for k, v in values.items())}) "
                            f"falls along the windows ({_fall_note(fell, n_sims)}): this plant cannot carry the rider the log shows")
    F_fit = _log_rms(ms_sim)
    d_sim = 0.5 * np.log(ms_sim[boot_idx].mean(axis=1)) - F_fit
    hull = np.stack([np.minimum(hull[:, 0], center), np.maximum(hull[:, 1], center)], axis=1)
    boot = np.array([_minimise(coef, F_log + d_log[b] - d_sim[b], w, hull, center[None, :])
                     for b in range(n_boot)])
    out, notes = _param_table(center, boot)
    J = lambda f: float(np.sum(w * (f - F_log) ** 2)) if f is not None else math.inf  # noqa: E731
    notes.append(f"fitted on {len(wins)} window(s) of {window_length:g} s of {log.path}, channels "
                 f"{', '.join(names)}; the motor noise's correlation time is held at "
                 f"{rider.noise_tau:g} s")
    notes.append(_fall_note(fell, n_sims))
    feats = {"names": feat_names, "log": F_log.tolist(), "fitted": F_fit.tolist(),
             "nominal": None if F_nom is None else F_nom.tolist()}
    return RiderFit(rider=rider, params=out, objective=J(F_fit), objective_nominal=J(F_nom),
                    features=feats, windows=wins, simulations=(n_sims + 2) * repeats,
                    notes=tuple(notes), falls=tuple(_values_of(x) for x in fell))

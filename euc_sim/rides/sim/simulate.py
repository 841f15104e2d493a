"""The closed-loop simulator driven along a real ride's speed profile.

The simulator's rider rides the logged speed profile
(:func:`~euc_sim.rides.grids.profile.speed_profile`) once per modelled step
(:mod:`euc_sim.rides.sim.sim_steps`), predicting the motor torque M_d and the battery power

    P̂ = P₀ + M_d·(ẋ/R − γ̇) + k_cu·(M_d/R)²

with the accepted k_cu, P₀ of :func:`~euc_sim.rides.balance.crossride.cross_ride`.  Each step
is compared with the log on its grid after the same Savitzky–Golay smoothing the log gets:
battery power, torque and speed, and phase current (M_d/k_t), pitch (s·γ + tilt₀) and PWM
where logged.  A fall ends its run; every step is scored on the rows all of them rode.
See docs/ride_simulation.md.
"""

from __future__ import annotations

from concurrent.futures import ThreadPoolExecutor
from functools import partial
from pathlib import Path
from dataclasses import dataclass, field
from typing import Callable, Mapping, Sequence

import numpy as np
import pandas as pd

from euc_sim.diagnosis.localise import Localisation
from euc_sim.errors import InputError
from euc_sim.stats import rms
from euc_sim.model.parameters import TABLE3, Params
from euc_sim.rides.grids.profile import rider_plan, speed_profile
from euc_sim.rides.grids.law_signals import MAX_PITCH, V_MIN
from euc_sim.rides.grids.rider_features import BandRatio, RiderFitError, band_ratio_db, reading_step
from euc_sim.rides.grids.signals import RideAssumptions, RideSignals, sg
from euc_sim.rides.balance.residual import localise_residual
from euc_sim.rides.source.gaps import GAP_POLICY
from euc_sim.rides.sim.plan_learning import filter_band
from euc_sim.rides.sim.sim_steps import (CHANNELS, SIM_EFFECTS, LogChannels, SimStep, electrical_power,
                                     effects_to_inject, simulated_pwm)
from euc_sim.rides.grids.stops import find_stops
from euc_sim.rides.sim.envelope import LEAN_SHARE
from euc_sim.rides.sim.pool import run_threads
from euc_sim.rides.sim.reading import read_as_logged
from euc_sim.rides.sim.tracking import simulate_profile
from euc_sim.simulation.engine import default_rider
from euc_sim.simulation.native_core import available
from euc_sim.stats import one_blas_thread

__all__ = ["SIM_EFFECTS", "simulation_obstacle", "ride_params", "effects_to_inject",
           "battery_power", "StepScore", "RideSimulation", "simulate_ride", "LOG_COLUMNS"]

#: Optional log channels a step is scored on: table stem -> the resampled log's column.
LOG_COLUMNS = {"I": "phase_current", "pitch": "tilt", "pwm": "pwm"}

def simulation_obstacle(sig: RideSignals, max_gap: float = GAP_POLICY.simulate) -> str | None:
    """Why a ride cannot be simulated as one profile (a gap over ``max_gap`` s), or None."""
    t = sig.raw["t"].to_numpy(float)
    gaps = np.diff(t)
    long = np.flatnonzero(gaps > max_gap)
    if not long.size:
        return None
    listed = ", ".join(f"{gaps[i]:.0f} s at t = {t[i]:.0f} s" for i in long[:3])
    return (f"simulation skipped: {Path(sig.path).name} has {long.size} gap(s) longer than "
            f"{max_gap:g} s ({listed}); bridging them would simulate {t[-1] - t[0]:.0f} s of "
            f"ride: split the log into its rides to simulate one")


def ride_params(assumptions: RideAssumptions, base: Params = TABLE3) -> Params:
    """Simulator parameters with the ride's radius R and a rider mass m making m + m0 + mw the
    assumed total mass (m0, mw and the rest from ``base``); InputError when m ≤ 0.
    """
    m = assumptions.total_mass - base.m0 - base.mw
    if m <= 0:
        raise InputError(f"total mass {assumptions.total_mass:g} kg must exceed the EUC's own "
                         f"mass m0 + mw = {base.m0 + base.mw:g} kg")
    return base.replace(m=m, R=assumptions.R)


def battery_power(M_d: np.ndarray, x_dot: np.ndarray, gamma_dot: np.ndarray, R: float,
                  copper: float = 0.0, idle: float = 0.0) -> np.ndarray:
    """Battery power, W: P₀ + M_d·(ẋ/R − γ̇) + k_cu·(M_d/R)² in both regimes.

    ``M_d`` N·m (wheel on body, CONTRACT sign), ``x_dot`` m/s, ``gamma_dot`` rad/s, ``R`` m,
    ``copper`` k_cu W/N², ``idle`` P₀ W.
    """
    M = np.asarray(M_d, float)
    P_mech = M * (np.asarray(x_dot, float) / R - np.asarray(gamma_dot, float))
    return idle + P_mech + copper * (M / R) ** 2


@dataclass(frozen=True)
class StepScore:
    """A step and its score on the held-out log: RMS over the scored rows by channel key
    (:data:`CHANNELS`, the finite ones), band by band (:func:`_band_errors`; None when not run),
    the battery-power error over the balance fit's held-out error, and its first fall (``t`` s, ``cause``)."""

    step: SimStep
    heldout_rmse: dict[str, float]
    heldout_bands: dict[str, BandRatio] | None
    ratio_to_balance: float | None
    fell: Mapping | None


@dataclass(frozen=True)
class RideSimulation:
    """Simulated against logged ride, on the log's grid, consistently smoothed.

    Attributes
    ----------
    label : str
    table : pandas.DataFrame
        ``t`` s, ``scored`` (bool), and per source (``log`` and each step that ran):
        ``v_<src>`` m/s, ``M_<src>`` N·m, ``P_<src>`` W and where logged ``I_<src>`` A,
        ``pitch_<src>`` rad (the log's convention), ``pwm_<src>`` %.
    errors : dict of str -> dict of str -> float
        RMS over the scored rows per step that ran, by channel key (``P_W``, ``M_Nm``, ``v_mps``,
        ``I_phase_A``, ``pitch_rad``, ``pwm_pct``: those logged); the pitch on the riding rows.
    torque_method : str
        How the log's torque was inferred.
    effects : dict
        Effects injected into the last step.
    falls : list of dict
        ``{"t", "cause", "run"}`` per fall (CONTRACT ``simulation.falls``).
    localisation : Localisation
        :func:`euc_sim.diagnosis.localise.localise` of the last step's power error.
    steps : list of StepScore
        Every step, those not run too.
    notes : tuple of str
    """

    label: str
    table: pd.DataFrame
    errors: dict[str, dict[str, float]]
    torque_method: str
    effects: dict
    falls: list
    localisation: Localisation
    steps: list[StepScore] = field(default_factory=list)
    notes: tuple[str, ...] = field(default=())

    @property
    def ran(self) -> list[str]:
        """Names of the steps that ran, in order."""
        return [s.step.name for s in self.steps if s.step.why is None]

    @property
    def ratio_P(self) -> float:
        """The last step's battery-power error over the first's (NaN where the first's is 0)."""
        first, last = self.errors[self.ran[0]]["P_W"], self.errors[self.ran[-1]]["P_W"]
        return last / first if first > 0 else float("nan")

    @property
    def scored_rows(self) -> int:
        """Rows the errors are measured on."""
        return int(self.table["scored"].sum())

    @property
    def pitch_scored_rows(self) -> int:
        """Scored rows the pitch error is measured on (the riding ones; 0 without a logged pitch)."""
        if "pitch_log" not in self.table:
            return 0
        return int(_pitch_rows(self.table, self.table["scored"].to_numpy()).sum())


@dataclass(frozen=True)
class _StepRun:
    """One step ridden and read onto the log's grid (the 1 kHz frame dropped)."""

    falls: tuple
    notes: tuple
    cols: dict
    raw: dict


@dataclass(frozen=True)
class _StepJob:
    """Everything one step's run needs; shared inputs are read, never written."""

    index: int
    step: SimStep
    profile: tuple                 # the arguments of simulate_profile, in order
    sig: RideSignals
    R: float
    channels: LogChannels
    logged: Mapping[str, np.ndarray]
    stamps: np.ndarray
    quanta: Mapping[str, float]
    seed: int


def _ride_step(job: _StepJob, cancel=None, pool=None) -> _StepRun:
    """:func:`simulate_profile` along the step's plan, then :func:`_on_grid`; its draws come from
    ``default_rng([seed, index])``, so steps give the same results in any order.
    """
    res = simulate_profile(*job.profile, cancel=cancel, pool=pool)
    cols, raw = _on_grid(res.frame, job.sig, job.step, job.R, job.channels, job.logged, job.stamps,
                         job.quanta, np.random.default_rng([job.seed, job.index]), fell=bool(res.falls))
    return _StepRun(res.falls, res.notes, cols, raw)


def _prefixed(progress, name: str):
    """``progress`` with the run's name in front, or None."""
    return None if progress is None else (lambda msg: progress(f"{name}: {msg}"))


def _run_steps(jobs: Sequence[_StepJob], params: Params, workers: int,
               progress: Callable[[str], None] | None = None) -> list[_StepRun]:
    """:func:`_ride_step` on each job, the rides (stretches between stops) queued for ``workers``
    threads when more than 1 (the native loop releases the GIL).

    The callback is compiled and the default rider designed here once; BLAS is held to one
    thread, so the numbers do not depend on ``workers``.
    """
    say = progress or (lambda msg: None)
    riders = None
    if workers > 1 and len(jobs) > 0:
        available()                        # the callback compiled once, in this thread
        default_rider(params)              # designed once, not by each thread
        riders = ThreadPoolExecutor(workers, thread_name_prefix="euc-sim-ride")
    try:
        with one_blas_thread():
            return run_threads(partial(_ride_step, pool=riders), jobs, len(jobs) if riders else 1,
                               on_done=lambda i, k: say(f"simulation {k}/{len(jobs)} done "
                                                        f"({jobs[i].step.name})"))
    finally:
        if riders is not None:
            riders.shutdown(wait=True, cancel_futures=True)


def _pitch_rows(table: pd.DataFrame, ok: np.ndarray) -> np.ndarray:
    """Scored rows where the logged pitch is the riding pitch (as :func:`~euc_sim.rides.grids.law_signals.law_rows`)."""
    if "pitch_log" not in table:
        return ok
    pitch = table["pitch_log"].to_numpy()
    riding = ok & (np.abs(table["v_log"].to_numpy()) > V_MIN) & np.isfinite(pitch)
    if not riding.any():
        return riding
    return riding & (np.abs(pitch - np.median(pitch[riding])) < MAX_PITCH)


def _errors(table: pd.DataFrame, ok: np.ndarray, names: Sequence[str]) -> dict[str, dict[str, float]]:
    """RMS of log − simulation over the scored rows, per step and channel key.

    The pitch is scored on the riding rows only (:func:`_pitch_rows`).
    """
    errors = {}
    rows = {col: ok for col in CHANNELS} | {"pitch": _pitch_rows(table, ok)}
    for name in names:
        errors[name] = {key: rms((table[f"{col}_log"] - table[f"{col}_{name}"])[rows[col]])
                        for col, (key, _, _) in CHANNELS.items()
                        if f"{col}_log" in table and f"{col}_{name}" in table}
    return errors


def _localise_error(table: pd.DataFrame, a: np.ndarray, ok: np.ndarray, name: str) -> Localisation:
    """Where step ``name``'s battery-power error concentrates (:func:`localise_residual`)."""
    t = table["t"].to_numpy()
    r = (table["P_log"] - table[f"P_{name}"]).to_numpy()
    good = ok & np.isfinite(r)
    if good.sum() < 4:
        return Localisation(windows=[], share=None, correlations={})
    return localise_residual(t[good], r[good], {"speed": table["v_log"].to_numpy()[good],
                                                "acceleration": a[good]})


def _logged(sig: RideSignals) -> dict[str, np.ndarray]:
    """The log's channels on its grid, smoothed as :class:`RideSignals` smooths its own."""
    frame, raw = sig.frame, sig.raw
    out = {"t": frame["t"].to_numpy(), "v_log": frame["v"].to_numpy(), "M_log": frame["M"].to_numpy(),
           "P_log": frame["P"].to_numpy()}
    seg = raw["segment"].to_numpy()
    for col, name in LOG_COLUMNS.items():
        if name in raw and np.isfinite(raw[name].to_numpy(float)).mean() > 0.5:
            out[f"{col}_log"] = sg(raw[name].to_numpy(float), seg, sig.rate, sig.window, sig.polyorder)
    return out


def _on_grid(df: pd.DataFrame | None, sig: RideSignals, step: SimStep, R: float,
             channels: LogChannels, logged: Mapping[str, np.ndarray], stamps: np.ndarray,
             quanta: Mapping[str, float] | None = None, rng: np.random.Generator | None = None,
             fell: bool = False) -> tuple[dict, dict]:
    """A run's channels read as the log is written and put on its grid, smoothed like the log.

    Each channel is read at the log's ``stamps`` (s), in the log's steps ``quanta``
    (:func:`euc_sim.rides.sim.reading.read_as_logged`).  A run that ``fell`` is kept up to one
    window before the fall, NaN after.  Returns the smoothed columns and the unsmoothed reads
    (battery power, phase current, pitch) for the band errors.
    """
    t = sig.frame["t"].to_numpy()
    name = step.name
    want = ["v", "M", "P"] + [c for c in LOG_COLUMNS if f"{c}_log" in logged]
    if df is None:
        return {f"{col}_{name}": np.full(t.size, np.nan) for col in want}, {}

    P = battery_power(df["M_d"], df["x_dot"], df["gamma_dot"], R) + electrical_power(
        step.power, np.asarray(df["M_d"], float) / R, np.asarray(df["x_dot"], float))
    ts = df["t"].to_numpy()
    segment = sig.raw["segment"].to_numpy().copy()
    if fell:
        segment[t > ts[-1] - sig.window] = -1    # its own segment, NaN: the filter never crosses

    quanta = quanta or {}
    rng = rng if rng is not None else np.random.default_rng(0)

    def read(x, col=None):
        return read_as_logged(ts, np.asarray(x, float), stamps, t, quantum=quanta.get(col), rng=rng)

    def smooth(y):
        return sg(y, segment, sig.rate, sig.window, sig.polyorder)

    raw = {"P": read(P)}
    if "I_log" in logged and channels.k_t:
        raw["I"] = read(df["M_d"].to_numpy() / channels.k_t, "I")
    if "pitch_log" in logged:
        s, zero = channels.pitch_sign or 1.0, channels.pitch_zero or 0.0
        raw["pitch"] = read(s * df["gamma"].to_numpy() + zero, "pitch")
    out = {f"v_{name}": smooth(read(df["x_dot"])), f"M_{name}": smooth(read(df["M_d"]))}
    out |= {f"{col}_{name}": smooth(y) for col, y in raw.items()}
    if "pwm_log" in logged and channels.pwm and "voltage" in sig.raw:
        V = sg(sig.raw["voltage"].to_numpy(float), sig.raw["segment"].to_numpy(), sig.rate,
               sig.window, sig.polyorder)
        out[f"pwm_{name}"] = simulated_pwm(channels.pwm, out[f"v_{name}"], out[f"M_{name}"] / R, V)
    return out, raw


def _align_pitch(table: pd.DataFrame, ok: np.ndarray,
                 names: Sequence[str]) -> tuple[pd.DataFrame, str | None]:
    """Without the log's pitch convention, each simulated pitch moved to the log's riding mean;
    a new table and the note saying so (None without a logged pitch).
    """
    if "pitch_log" not in table:
        return table, None
    ok = _pitch_rows(table, ok)
    m_log = np.nanmean(table["pitch_log"].to_numpy()[ok]) if ok.any() else 0.0
    moved = {col: table[col] - np.nanmean(table[col].to_numpy()[ok]) + m_log
             for col in (f"pitch_{name}" for name in names) if col in table and ok.any()}
    return table.assign(**moved), ("pitch: the fit ride shows no balance law, so the log's pitch sign and "
                                   "zero are not known; sign +1 assumed and each simulated pitch moved "
                                   "to the logged riding mean")


def _band_errors(sig: RideSignals, reads: Mapping[str, Mapping[str, np.ndarray]],
                 rows: Mapping[str, np.ndarray]) -> dict[str, dict[str, BandRatio]]:
    """Each step's channels against the log's, band by band (level and spectrum), on the scored rows.

    Battery power, and phase current and pitch where both sides have them (pitch on the
    riding rows): the simulation as read at the log's stamps and the log as resampled,
    neither smoothed (:func:`euc_sim.rides.grids.rider_features.band_ratio_db`), keyed as
    ``heldout_rmse``; a channel without two rows to compare is left out.
    """
    seg = sig.raw["segment"].to_numpy()
    logged = {"P": "P"} | LOG_COLUMNS
    out = {}
    for name, read in reads.items():
        out[name] = {}
        for col, y in read.items():
            if logged[col] not in sig.raw:
                continue
            try:
                out[name][CHANNELS[col][0]] = band_ratio_db(y, sig.raw[logged[col]].to_numpy(float), seg,
                                                            sig.rate, rows[col])
            except RiderFitError:
                continue
    return out


def _scores(steps: Sequence[SimStep], errors: Mapping[str, Mapping[str, float]], falls: list,
            balance: float | None, bands: Mapping[str, dict]) -> list[StepScore]:
    """Each step's :class:`StepScore` (``balance``: the balance fit's held-out error, W)."""
    out = []
    for step in steps:
        ran = step.why is None
        rmse = {k: v for k, v in ((errors.get(step.name) if ran else None) or {}).items() if np.isfinite(v)}
        p = rmse.get("P_W")
        fell = [f for f in falls if f["run"] == step.name]
        out.append(StepScore(step, rmse, bands.get(step.name) if ran else None,
                             p / balance if p is not None and balance and balance > 0 else None,
                             fell[0] if fell else None))
    return out


def simulate_ride(sig: RideSignals, steps: Sequence[SimStep], log, scored: np.ndarray | None = None,
                  label: str | None = None, seed: int = 0, dt: float = 1e-3,
                  track_iterations: int = 1, workers: int = 1, channels: LogChannels = LogChannels(),
                  progress: Callable[[str], None] | None = None) -> RideSimulation:
    """Simulate a ride's speed profile once per modelled step and compare each with its log.

    Parameters
    ----------
    sig : RideSignals
    steps : sequence of SimStep
        In order (:func:`~euc_sim.rides.sim.sim_steps.build_steps`); those with a ``why`` are
        listed, not run.  At least one must run (else ValueError).
    log : Ride
        The same ride, for the speed profile.
    scored : array of bool, optional
        Grid rows the errors are measured on (default: where the log's signals are defined).
    label : str, optional
    seed, dt, track_iterations :
        See :func:`simulate_profile`.
    workers : int
        Threads for the steps; the results do not depend on it.
    channels : LogChannels
        How the simulated state maps onto the log's channels, and the balance fit's held-out error.
    progress : callable, optional
        Called with a short line as each run starts and ends.
    """
    run = [s for s in steps if s.why is None]
    if not run:
        raise ValueError(f"steps: expected at least one step that runs, got {[s.name for s in steps]}")
    params = ride_params(sig.assumptions)
    prof = speed_profile(log, sig.rate, sig.window, sig.polyorder, total_mass=sig.assumptions.total_mass)
    t_p, v_p = prof["t"].to_numpy(), prof["v"].to_numpy()
    notes = list(prof.attrs.get("notes", []))
    notes += [f"{s.name}: {n}" for s in steps for n in s.notes]
    notes += [f"{s.name} not run: {s.why}" for s in steps if s.why is not None]
    out = _logged(sig)
    falls, reads = [], {}
    names = [s.name for s in run]
    band = filter_band(sig.rate, sig.window, sig.polyorder)       # the plan learns what the log passes
    stops = find_stops(t_p, v_p)          # on the log's speed: a smoothed plan stands still for less
    data = log.data
    stamps = data["t"].to_numpy(float)
    quanta = {c: q for c, name in LOG_COLUMNS.items() if c != "pwm" and name in data
              for q in [reading_step(data[name].to_numpy(float))] if q}
    jobs = [_StepJob(i, s, (t_p, v_p if s.plan_window is None else rider_plan(t_p, v_p, s.plan_window),
                            params, dict(s.effects), seed, dt, track_iterations, band,
                            _prefixed(progress, s.name), s.name, i, s.motor, s.rider, LEAN_SHARE, None,
                            stops),
                     sig, params.R, channels, dict(out), stamps, quanta, seed)
            for i, s in enumerate(run)]
    for step, res in zip(run, _run_steps(jobs, params, workers, progress)):
        if not res.falls:            # a fall is said once, from ``falls`` (page.falls_sentence)
            notes += [f"{step.name}: {n}" for n in res.notes]
        falls += [{**f, "run": step.name} for f in res.falls]
        out.update(res.cols)
        reads[step.name] = res.raw
    table = pd.DataFrame(out)
    ok = sig.frame["interior"].to_numpy() & np.isfinite(table["P_log"].to_numpy())
    if scored is not None:
        ok &= np.asarray(scored, bool)
    if falls:                # every step scored where all rode: up to the first fall
        rode = np.logical_and.reduce([np.isfinite(table[f"P_{n}"].to_numpy()) for n in names])
        notes.append(f"every step is scored up to t = {min(f['t'] for f in falls):.1f} s, where the "
                     f"first fall ended a run ({int((ok & rode).sum())} of {int(ok.sum())} scored rows)")
        ok &= rode
    table["scored"] = ok
    if channels.pitch_sign is None:
        table, note = _align_pitch(table, ok, names)
        notes += [note] if note else []
    errors = _errors(table, ok, names)
    bands = _band_errors(sig, reads, {"P": ok, "I": ok, "pitch": _pitch_rows(table, ok)})
    loc = _localise_error(table, sig.frame["a"].to_numpy(), ok, names[-1])
    return RideSimulation(label=label or str(sig.path), table=table, errors=errors, torque_method=sig.torque_method,
                          effects=dict(run[-1].effects), falls=falls, localisation=loc,
                          steps=_scores(steps, errors, falls, channels.balance_heldout, bands), notes=tuple(notes))


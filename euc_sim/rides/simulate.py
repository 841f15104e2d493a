"""The closed-loop simulator driven along a real ride's speed profile.

A ride log gives the wheel speed v(t) and the battery power P(t), nothing about
the rider.  Here the simulator's rider (:func:`euc_sim.simulation.engine.simulate`,
maneuver ``profile``) rides the logged speed profile
(:func:`euc_sim.rides.profile.speed_profile`); the simulation then *predicts* the motor
torque M_d the ride needed and, through the drivetrain model of
:mod:`euc_sim.rides.design`, the battery power:

    P_mech = M_d·(ẋ/R − γ̇)                    (motor torque × wheel speed relative to the body)
    P̂ = P₀ + P_mech/η_m   (P_mech > 0),   P₀ + η_r·P_mech   (P_mech ≤ 0)

with η_m, η_r, P₀ fitted by :func:`euc_sim.rides.crossride.cross_ride` (on the fit ride: on
a compare ride the prediction is out of sample).  Two simulations are run:

``nominal``
    the paper's model alone (no resistance), efficiencies of the inertia-only fit;
``augmented``
    the accepted effects injected as physics (``simulate(effects=...)``:
    ``rolling_resistance`` C_rr, ``aerodynamic_drag`` k, ``road_slope`` α) and
    the augmented fit's efficiencies and idle drain P₀.

Both are compared with the log on the log's 10 Hz grid after the *same*
Savitzky–Golay smoothing the log gets (:meth:`RideSignals.filt`), so filtering
does not count as model error.

When the rider falls (:class:`~euc_sim.simulation.errors.FallError`), that run stops
at the fall, which is reported once (``falls``: time and cause); the profile is never
ridden again after a fall, and both runs are scored on the rows both of them rode.
"""

from __future__ import annotations

import math
import pickle
from functools import partial
from pathlib import Path
from dataclasses import dataclass, field
from typing import Callable, Mapping, Sequence

import numpy as np
import pandas as pd

from euc_sim.model.parameters import TABLE3, Params
from euc_sim.rides.profile import speed_profile
from euc_sim.rides.signals import RideAssumptions, RideSignals
from euc_sim.rides.tracking import ProfileRun, simulate_profile, to_grid

__all__ = ["SIM_EFFECTS", "MAX_BRIDGED_GAP", "simulation_obstacle", "ride_params", "effects_to_inject",
           "battery_power", "RideSimulation", "simulate_ride", "plot_ride_simulation"]

#: Fitted balance parameters that the simulator can inject as physics, and how.
SIM_EFFECTS = ("rolling_resistance", "aerodynamic_drag", "road_slope")


#: Longest gap in a log, s, that the simulation bridges (linearly, at the logged speeds);
#: a log with a longer one (the app left running for hours) is not simulated.
MAX_BRIDGED_GAP = 120.0


def simulation_obstacle(sig: RideSignals, max_gap: float = MAX_BRIDGED_GAP) -> str | None:
    """Why a ride cannot be simulated as one profile, or None.

    The simulation rides the whole log as one continuous profile, every gap
    bridged; a gap of hours would be hours of 1 kHz simulation (and memory).
    """
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
    """Simulator parameters matching a ride's assumed radius and total mass.

    The wheel radius is ``assumptions.R``; the rider's mass m is set so that
    m + m0 + mw equals ``assumptions.total_mass`` (the EUC's own m0, mw from
    ``base``).  Everything else is ``base`` (Table 3).

    Raises
    ------
    ValueError
        when the total mass does not exceed the EUC's own mass m0 + mw.
    """
    m = assumptions.total_mass - base.m0 - base.mw
    if m <= 0:
        raise ValueError(f"total mass {assumptions.total_mass:g} kg must exceed the EUC's own "
                         f"mass m0 + mw = {base.m0 + base.mw:g} kg")
    return base.replace(m=m, R=assumptions.R)


def effects_to_inject(estimates: Mapping[str, float], accepted: Sequence[str]) -> tuple[dict, list]:
    """The accepted balance effects as ``simulate(effects=...)`` values.

    Parameters
    ----------
    estimates : mapping
        Fitted values (units of :data:`euc_sim.rides.design.CANDIDATES`).
    accepted : sequence of str
        Accepted effect names.

    Returns
    -------
    effects : dict
        ``rolling_resistance`` C_rr (1), ``aerodynamic_drag`` k (kg/m),
        ``road_slope`` α (rad, from sin α).
    notes : list of str
        Accepted effects that are not physics of the simulator and how they are
        used instead.
    """
    eff, notes = {}, []
    for name in accepted:
        val = float(estimates[name])
        if name == "road_slope":
            eff[name] = math.asin(max(-1.0, min(1.0, val)))
        elif name in SIM_EFFECTS:
            eff[name] = val
        elif name == "drivetrain_idle_loss":
            notes.append(f"drivetrain_idle_loss P₀ = {val:.3g} W is electrical: added to the "
                         f"predicted battery power, not to the mechanics")
        else:
            notes.append(f"{name} is not a constant force the simulator can inject: left out "
                         f"of the augmented simulation")
    return eff, notes


def battery_power(M_d: np.ndarray, x_dot: np.ndarray, gamma_dot: np.ndarray, R: float,
                  eta_motor: float, eta_regen: float, idle: float = 0.0) -> np.ndarray:
    """Battery power, W, from the motor torque through :mod:`euc_sim.rides.design`'s drivetrain model.

    Parameters
    ----------
    M_d : array_like
        Motor torque, wheel on body, N·m (CONTRACT sign).
    x_dot : array_like
        Wheel-centre speed, m/s.
    gamma_dot : array_like
        Body pitch rate, rad/s.
    R : float
        Wheel radius, m.
    eta_motor, eta_regen : float
        Efficiencies, 1.
    idle : float
        Constant electrical drain P₀, W.

    Returns
    -------
    numpy.ndarray
        P₀ + P_mech/η_m where the motor drives (P_mech > 0), P₀ + η_r·P_mech
        where it brakes; P_mech = M_d·(ẋ/R − γ̇), W.
    """
    P_mech = np.asarray(M_d, float) * (np.asarray(x_dot, float) / R - np.asarray(gamma_dot, float))
    return idle + np.where(P_mech > 0, P_mech / eta_motor, eta_regen * P_mech)


@dataclass(frozen=True)
class RideSimulation:
    """Simulated against logged ride, on the log's grid, consistently smoothed.

    Attributes
    ----------
    label : str
        The simulated ride.
    table : pandas.DataFrame
        ``t`` s, ``v_log``, ``v_nominal``, ``v_augmented`` m/s, ``M_log`` (torque
        inferred from the log, see ``torque_method``), ``M_nominal``,
        ``M_augmented`` N·m, ``P_log``, ``P_nominal``, ``P_augmented`` W,
        ``scored`` (bool: the rows the errors are measured on).
    errors : dict
        RMS over the scored rows: ``{"nominal"|"augmented": {"P_W", "M_Nm",
        "v_mps"}}``; ``ratio_P`` = augmented / nominal battery-power error.
    effects : dict
        Effects injected into the augmented run.
    parameters : dict
        ``{"nominal"|"augmented": {eta_motor, eta_regen, drivetrain_idle_loss}}``.
    falls : list of dict
        ``{"t": s, "cause": str, "run": "nominal"|"augmented"}`` of each run that ended
        in a fall (CONTRACT's ``simulation.falls``).
    localisation : dict
        :func:`euc_sim.diagnosis.localise.localise` on the augmented power error (W):
        windows (s), share, correlations.
    notes : tuple of str
    """

    label: str
    table: pd.DataFrame
    errors: dict
    effects: dict
    parameters: dict
    falls: list
    localisation: dict
    notes: tuple[str, ...] = field(default=())

    def as_json(self) -> dict:
        """JSON-ready summary (the table goes to CSV)."""
        return {"ride": self.label, "errors": self.errors, "effects_injected": self.effects,
                "drivetrain": self.parameters, "falls": list(self.falls),
                "windows": self.localisation.get("windows", []),
                "windows_share": self.localisation.get("share"),
                "correlations": self.localisation.get("correlations", {}),
                "scored_rows": int(self.table["scored"].sum()), "notes": list(self.notes)}


def _drivetrain(est: Mapping[str, float]) -> dict:
    return {"eta_motor": float(est["eta_motor"]), "eta_regen": float(est["eta_regen"]),
            "drivetrain_idle_loss": float(est.get("drivetrain_idle_loss", 0.0))}


def _rms(x: np.ndarray) -> float:
    x = np.asarray(x, float)
    x = x[np.isfinite(x)]
    return float(np.sqrt(np.mean(x ** 2))) if x.size else float("nan")


def _simulate_job(job: tuple) -> ProfileRun:
    """:func:`simulate_profile` on a tuple of its arguments (picklable, for a process pool)."""
    return simulate_profile(*job)


def _say_prefixed(progress: Callable[[str], None], prefix: str, msg: str) -> None:
    progress(f"{prefix}: {msg}")


def _prefixed(progress, name: str, workers: int):
    """``progress`` with the run's name in front, or None when it cannot reach a worker."""
    if progress is None:
        return None
    out = partial(_say_prefixed, progress, name)
    if workers > 1:
        try:
            pickle.dumps(out)
        except (pickle.PicklingError, AttributeError, TypeError):
            return None                 # a lambda: progress from the parent only
    return out


def _run_jobs(jobs: list, names: Sequence[str], params: Params, workers: int,
              progress: Callable[[str], None] | None = None) -> list[ProfileRun]:
    """:func:`simulate_profile` on each job, in ``workers`` processes when more than 1.

    The workers die with this process, and an interruption kills them at once
    (:func:`euc_sim.rides.pool.run_jobs`).
    """
    from euc_sim.rides.pool import run_jobs

    say = progress or (lambda msg: None)
    if workers > 1:
        from euc_sim.simulation.engine import default_rider

        default_rider(params)              # designed once here, inherited by forked workers
    return run_jobs(_simulate_job, jobs, workers,
                    on_done=lambda i, k: say(f"simulation {k}/{len(jobs)} done ({names[i]})"))


def _errors(table: pd.DataFrame, ok: np.ndarray, names: Sequence[str]) -> dict:
    """RMS of log − simulation over the scored rows, per run, and the power-error ratio."""
    errors = {}
    for name in names:
        errors[name] = {"P_W": _rms((table["P_log"] - table[f"P_{name}"])[ok]),
                        "M_Nm": _rms((table["M_log"] - table[f"M_{name}"])[ok]),
                        "v_mps": _rms((table["v_log"] - table[f"v_{name}"])[ok])}
    nom_P = errors["nominal"]["P_W"]
    errors["ratio_P"] = errors["augmented"]["P_W"] / nom_P if nom_P > 0 else float("nan")
    return errors


def _localise_error(table: pd.DataFrame, a: np.ndarray, ok: np.ndarray, smooth: float,
                    min_len: float) -> dict:
    """Where the augmented simulation's battery-power error concentrates (windows in s)."""
    from euc_sim.diagnosis.localise import localise
    from euc_sim.rides.page import split_at_gaps

    t = table["t"].to_numpy()
    r = (table["P_log"] - table["P_augmented"]).to_numpy()
    good = ok & np.isfinite(r)
    if good.sum() < 4:
        return {"windows": [], "share": None, "correlations": {}}
    loc = localise(t[good], r[good], {"speed": table["v_log"].to_numpy()[good],
                                      "acceleration": a[good]},
                   smooth=smooth, min_len=min_len)
    return dict(loc, windows=split_at_gaps(loc["windows"], t[good], min_len))


def _on_grid(df: pd.DataFrame | None, sig: RideSignals, est: Mapping[str, float], R: float,
             name: str, fell: bool = False) -> dict:
    """A run's speed, torque and battery power on the log's grid, smoothed like the log.

    A run that ended in a fall (``fell``) is kept up to one smoothing window before the
    fall (the falling itself is not riding) and is NaN after it.
    """
    t = sig.frame["t"].to_numpy()
    if df is None:
        return {f"{col}_{name}": np.full(t.size, np.nan) for col in ("v", "M", "P")}
    from euc_sim.rides.signals import sg

    P = battery_power(df["M_d"], df["x_dot"], df["gamma_dot"], R, est["eta_motor"],
                      est["eta_regen"], est.get("drivetrain_idle_loss", 0.0))
    ts = df["t"].to_numpy()
    segment = sig.raw["segment"].to_numpy().copy()
    if fell:
        segment[t > ts[-1] - sig.window] = -1    # its own segment, NaN: the filter never crosses

    def filt(x):
        return sg(to_grid(ts, x, t), segment, sig.rate, sig.window, sig.polyorder)

    return {f"v_{name}": filt(df["x_dot"]), f"M_{name}": filt(df["M_d"]), f"P_{name}": filt(P)}


def simulate_ride(sig: RideSignals, nominal: Mapping[str, float], augmented: Mapping[str, float],
                  accepted: Sequence[str], log, scored: np.ndarray | None = None,
                  label: str | None = None, seed: int = 0, dt: float = 1e-3,
                  track_iterations: int = 1,
                  window_smooth: float = 5.0, window_min: float = 3.0,
                  workers: int = 1,
                  progress: Callable[[str], None] | None = None, rider=None,
                  plan_window: float | None = None) -> RideSimulation:
    """Simulate a ride's speed profile, nominal and augmented, and compare with its log.

    Parameters
    ----------
    sig : RideSignals
        The ride (:func:`euc_sim.rides.signals.ride_signals`).
    nominal, augmented : mapping
        Fitted parameters of the inertia-only and the augmented balance
        (``CrossRide.nominal.estimate``, ``CrossRide.augmented.estimate``).
    accepted : sequence of str
        Accepted effects (``CrossRide.accepted``).
    log : RideLog or path
        The same ride, for :func:`euc_sim.rides.profile.speed_profile`.
    scored : array of bool, optional
        Grid rows the errors are measured on (default: every row where the
        log's smoothed signals are defined).
    label : str, optional
    seed, dt, track_iterations :
        See :func:`simulate_profile`.
    workers : int
        Processes for the two simulations (2: nominal and augmented side by
        side; the results do not depend on it).  Workers die with this process
        and are killed when it is interrupted.
    progress : callable, optional
        Called with a short line as each run starts and ends (from the workers
        too when it can be pickled, e.g. a module-level function); when it reaches
        a run, a progress bar over the ride's seconds is shown on stderr too.
    rider : Rider, optional
        The simulated rider of both runs (default: the LQR rider of
        :func:`euc_sim.simulation.engine.default_rider`; a calibrated one:
        :func:`euc_sim.rides.rider_fit.fit_rider`).
    plan_window : float, optional
        s: the rider's plan is the logged speed smoothed over this window
        (:func:`euc_sim.rides.profile.rider_plan`, as the calibrated rider was fitted);
        default the profile itself.
    window_smooth, window_min : float
        s: ``smooth`` and ``min_len`` of :func:`euc_sim.diagnosis.localise.localise`
        (longer than its 1 s / 0.5 s defaults: a ride is minutes long and
        sampled at 5 Hz).

    Returns
    -------
    RideSimulation
    """
    A = sig.assumptions
    params = ride_params(A)
    prof = speed_profile(log, sig.rate, sig.window, sig.polyorder)
    t_p, v_p = prof["t"].to_numpy(), prof["v"].to_numpy()
    if plan_window is not None:
        from euc_sim.rides.profile import rider_plan

        v_p = rider_plan(t_p, v_p, plan_window)
    eff, notes = effects_to_inject(augmented, accepted)
    notes = list(prof.attrs.get("notes", [])) + notes
    frame = sig.frame
    t = frame["t"].to_numpy()
    out = {"t": t, "v_log": frame["v"].to_numpy(), "M_log": frame["M"].to_numpy(),
           "P_log": frame["P"].to_numpy()}
    runs = {"nominal": ({}, nominal), "augmented": (eff, augmented)}
    falls = []
    jobs = [(t_p, v_p, params, effects, seed, dt, track_iterations, 10.0,
             _prefixed(progress, name, workers), name, i, rider)
            for i, (name, (effects, _)) in enumerate(runs.items())]
    done = _run_jobs(jobs, list(runs), params, workers, progress)
    for (name, (effects, est)), run in zip(runs.items(), done):
        if not run.falls:            # a fall is said once, from ``falls`` (page.falls_sentence)
            notes += [f"{name}: {n}" for n in run.notes]
        falls += [{**f, "run": name} for f in run.falls]
        out.update(_on_grid(run.frame, sig, est, params.R, name, fell=bool(run.falls)))
    table = pd.DataFrame(out)
    ok = frame["interior"].to_numpy() & np.isfinite(table["P_log"].to_numpy())
    if scored is not None:
        ok &= np.asarray(scored, bool)
    if falls:                # both runs scored where both rode: up to the first fall
        rode = np.logical_and.reduce([np.isfinite(table[f"P_{name}"].to_numpy()) for name in runs])
        notes.append(f"both runs are scored up to t = {min(f['t'] for f in falls):.1f} s, where the "
                     f"first fall ended a run ({int((ok & rode).sum())} of {int(ok.sum())} scored rows)")
        ok &= rode
    table["scored"] = ok
    errors = _errors(table, ok, tuple(runs))
    errors["M_log_method"] = sig.torque_method
    loc = _localise_error(table, frame["a"].to_numpy(), ok, window_smooth, window_min)
    return RideSimulation(label=label or str(sig.path), table=table, errors=errors, effects=eff,
                          parameters={"nominal": _drivetrain(nominal),
                                      "augmented": _drivetrain(augmented)},
                          falls=falls, localisation=loc, notes=tuple(notes))


def plot_ride_simulation(sim: RideSimulation, path) -> "Path":
    """Write :func:`euc_sim.rides.simulation_figure.ride_simulation_figure` to ``path`` (PNG, atomically)."""
    from euc_sim.io import save_figure
    from euc_sim.rides.simulation_figure import ride_simulation_figure

    return save_figure(ride_simulation_figure(sim), path, dpi=100)

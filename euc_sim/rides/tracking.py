"""The simulated rider riding a logged speed profile: acceleration limits, plan corrections, the log's grid.

:func:`simulate_profile` drives the closed-loop simulator's rider
(:func:`euc_sim.simulation.engine.simulate`, maneuver ``profile``) along a ride's speed,
with a progress bar over the ride's seconds; when he falls, the run stops there and the
fall is reported once (the profile is never ridden again after a fall); otherwise his
plan is corrected so that the simulated speed tracks the logged one.
:func:`limit_acceleration` smooths a profile to a given acceleration.  :func:`to_grid`
brings the 1 kHz simulation onto the log's grid.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable, Mapping, Sequence

import numpy as np
import pandas as pd

from euc_sim.model.parameters import Params
from euc_sim.rides.signals import sg

__all__ = ["limit_acceleration", "to_grid", "ProfileRun", "simulate_profile"]


def limit_acceleration(t: np.ndarray, v: np.ndarray, a_max: float) -> np.ndarray:
    """A speed profile whose slope never exceeds ±``a_max``, close to ``v``.

    A rate limiter run forwards and one run backwards over time, averaged: each
    has |dv/dt| ≤ a_max, so their mean does too, and the lag of one cancels the
    lead of the other (no net time shift).  ``v`` is not modified.

    Parameters
    ----------
    t : array_like
        s, strictly increasing.
    v : array_like
        m/s.
    a_max : float
        m/s², positive.

    Returns
    -------
    numpy.ndarray
        m/s, same shape as ``v``.
    """
    if not (math.isfinite(a_max) and a_max > 0):
        raise ValueError(f"a_max must be a positive number of m/s², got {a_max!r}")
    t = np.asarray(t, float)
    v = np.asarray(v, float)
    dv = a_max * np.diff(t)

    def one_way(x: np.ndarray, steps: np.ndarray) -> np.ndarray:
        out = x.copy()
        for i in range(1, out.size):
            out[i] = min(max(out[i], out[i - 1] - steps[i - 1]), out[i - 1] + steps[i - 1])
        return out

    fwd = one_way(v, dv)
    bwd = one_way(v[::-1], dv[::-1])[::-1]
    return 0.5 * (fwd + bwd)


def to_grid(t_fine: np.ndarray, y: np.ndarray, t_grid: np.ndarray) -> np.ndarray:
    """Mean of a fine signal over each grid interval centred on ``t_grid``.

    Parameters
    ----------
    t_fine, y : array_like
        Uniformly sampled fine signal (s, any unit).
    t_grid : array_like
        Uniform grid, s, coarser than ``t_fine``.

    Returns
    -------
    numpy.ndarray
        Same unit as ``y``; NaN where the interval holds no fine sample.
    """
    t_fine = np.asarray(t_fine, float)
    y = np.asarray(y, float)
    t_grid = np.asarray(t_grid, float)
    step = float(np.median(np.diff(t_grid))) if t_grid.size > 1 else 1.0
    edges = np.concatenate([t_grid - step / 2, [t_grid[-1] + step / 2]])
    idx = np.searchsorted(edges, t_fine, side="right") - 1
    ok = (idx >= 0) & (idx < t_grid.size)
    s = np.bincount(idx[ok], weights=y[ok], minlength=t_grid.size)
    n = np.bincount(idx[ok], minlength=t_grid.size)
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(n > 0, s / np.maximum(n, 1), np.nan)


@dataclass(frozen=True)
class ProfileRun:
    """One closed-loop run along a speed profile.

    Attributes
    ----------
    frame : pandas.DataFrame or None
        :func:`euc_sim.simulation.engine.simulate`'s output (1/dt Hz), up to the fall
        when the rider fell; None when he fell before the first step.
    falls : tuple of dict
        ``{"t": s, "cause": str}`` of the fall that ended the run (at most one: the
        profile is never ridden again after a fall).
    notes : tuple of str
        The fall and the plan corrections, in order.
    """

    frame: pd.DataFrame | None
    falls: tuple[dict, ...]
    notes: tuple[str, ...]


class _RideClock:
    """A tqdm bar over the ride's seconds (stderr), fed by the engine's ``progress(t)``."""

    def __init__(self, total: float, desc: str, enabled: bool, position: int = 0):
        import sys

        from tqdm import tqdm

        self.bar = tqdm(total=round(total, 1), desc=desc, unit="s", unit_scale=False, file=sys.stderr,
                        disable=not enabled, position=position, mininterval=1.0, bar_format="{desc}: {percentage:3.0f}%|{bar}| "
                        "{n:.0f}/{total:.0f} s of ride [{elapsed}<{remaining}]")

    def __call__(self, t: float) -> None:
        self.bar.update(max(0.0, round(t, 1) - self.bar.n))

    def close(self) -> None:
        self.bar.close()


def _track(t, v_target, v_plan, params, effects, seed, dt, clock=None, motor=None):
    """One run along the plan v_plan; its speed on the profile grid, m/s, and RMS error."""
    from euc_sim.simulation.maneuvers import Maneuver
    from euc_sim.simulation.engine import default_rider, simulate

    man = Maneuver("profile", float(v_plan[0]), (), (tuple(t.tolist()), tuple(v_plan.tolist())))
    df = simulate(man, float(t[-1]), params=params, motor=motor, rider=default_rider(params, motor),
                  seed=seed, effects=dict(effects), dt=dt, progress=clock)
    if clock is not None:
        clock(float(t[-1]))                # the whole ride ridden
    v_sim = to_grid(df["t"].to_numpy(), df["x_dot"].to_numpy(), t)
    v_sim = np.where(np.isfinite(v_sim), v_sim, v_plan)
    return df, v_sim, float(np.sqrt(np.mean((v_target - v_sim) ** 2)))


def _correct_plan(t, target, run, params, effects, seed, dt, iterations: int, window: float,
                  notes: list, say, clock_of, motor=None) -> pd.DataFrame:
    """Iterative learning: add the slow speed error to the plan and ride again.

    Returns the frame of the run closest to ``target``; appends to ``notes``.
    """
    from euc_sim.simulation.errors import FallError

    df, v_sim, err = run
    rate = 1.0 / float(np.median(np.diff(t)))
    plan = target
    for it in range(iterations):
        plan = plan + sg(target - v_sim, np.zeros(t.size, int), rate, window, 2)
        say(f"tracking correction {it + 1} of {iterations}: riding the corrected plan")
        clock = clock_of(f"correction {it + 1}")
        try:
            df2, v2, err2 = _track(t, target, plan, params, effects, seed, dt, clock, motor)
        except FallError as exc:
            notes.append(f"tracking correction {it + 1}: rider fell ({exc}); kept the "
                         f"previous run")
            break
        finally:
            clock.close()
        notes.append(f"tracking correction {it + 1}: RMS speed error {err:.3f} -> "
                     f"{err2:.3f} m/s")
        if err2 >= err:
            break
        df, v_sim, err = df2, v2, err2
    return df


def simulate_profile(t: np.ndarray, v: np.ndarray, params: Params, effects: Mapping[str, float],
                     seed: int = 0, dt: float = 1e-3, track_iterations: int = 1,
                     track_window: float = 10.0, progress: Callable[[str], None] | None = None,
                     label: str = "ride", position: int = 0, motor=None) -> ProfileRun:
    """Ride the speed profile (t, v) in closed loop (MuJoCo); stop where the rider falls.

    The simulated rider has no integral action: a resisting force (drag, rolling
    resistance, a climb) can make it ride slower than planned.  A real rider
    corrects such a lag, so after a run the slow part of the speed error
    (Savitzky–Golay smoothed over ``track_window`` s, so that only the lag, not
    the rider's own sway, is corrected) is added to the plan and the ride is run
    again, ``track_iterations`` times (iterative learning); the run closest to
    the profile is kept, and the notes say what each correction did.

    When the rider falls, the run ends there: its frame stops at the fall, the fall's
    time and cause are reported once (``falls``), and the profile is not ridden again
    (no correction either).

    Parameters
    ----------
    t, v : array_like
        Profile, s and m/s, uniform, t starting at 0.
    params : Params
    effects : mapping
        CONTRACT effect values injected as physics.
    seed : int
        Seed of the simulation (the default rider has no motor noise).
    dt : float
        Control period and MuJoCo step, s.
    track_iterations : int
        Plan corrections after the first run (0: the plan is the profile).
    track_window : float
        s.
    progress : callable, optional
        Called with a short line before each closed-loop run; when given, a progress
        bar over the ride's seconds is shown on stderr too.
    label : str
        The bar's name (the run: ``nominal``, ``augmented``).
    position : int
        The bar's line (0 first): runs side by side in processes keep their own line.
    motor : MotorPD, optional
        The wheel's balance law (default: the paper's PD), e.g. a ride's measured law
        (:func:`controllers.firmware.firmware_motor`); the rider is designed for it.

    Returns
    -------
    ProfileRun
    """
    from euc_sim.simulation.errors import FallError

    say = progress or (lambda msg: None)
    t = np.asarray(t, float)
    v = np.asarray(v, float)
    notes: list[str] = []

    def clock_of(what: str) -> _RideClock:
        return _RideClock(float(t[-1] - t[0]), f"{label} {what}", progress is not None, position)

    say(f"riding {t[-1] - t[0]:.0f} s of the logged profile")
    clock = clock_of("ride")
    try:
        df, v_sim, err = _track(t, v, v, params, effects, seed, dt, clock, motor)
    except FallError as exc:
        cause = str(exc).split(": ", 1)[-1]
        notes.append(f"rider fell at t = {exc.t:.1f} s of {t[-1] - t[0]:.0f} s ({cause}): the "
                     f"simulation stops there and the profile is not ridden again")
        say(notes[-1])
        frame = exc.trajectory if exc.trajectory is not None and len(exc.trajectory) else None
        return ProfileRun(frame, ({"t": float(exc.t), "cause": cause},), tuple(notes))
    finally:
        clock.close()
    if t.size >= 5:
        df = _correct_plan(t, v, (df, v_sim, err), params, effects, seed, dt,
                           track_iterations, track_window, notes, say, clock_of, motor)
    return ProfileRun(df, (), tuple(notes))

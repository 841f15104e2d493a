"""The simulated rider riding a logged speed profile: acceleration limits, plan corrections, the log's grid.

:func:`simulate_profile` drives the closed-loop rider along a ride's speed, within his
acceleration envelope (:mod:`euc_sim.rides.sim.envelope`), standing foot down at the
log's stops (:mod:`euc_sim.rides.grids.stops`), stopping at a fall, and otherwise
correcting his plan until his speed tracks the logged one.  :func:`to_grid` brings the
1 kHz simulation onto the log's grid.
"""

from __future__ import annotations

import sys
import threading
from dataclasses import dataclass
from typing import Callable, Mapping, Sequence

import numpy as np
import pandas as pd
from tqdm import tqdm

from euc_sim.controllers.motor import MotorPD
from euc_sim.controllers.rider import trim
from euc_sim.model.parameters import Params
from euc_sim.rides.grids.law_signals import V_MIN
from euc_sim.rides.grids.stops import find_stops, moving_segments, rest_rows
from euc_sim.rides.sim.envelope import (LEAN_SHARE, limit_acceleration, moving_average, plan_band_limit,
                                        resisting_acceleration, rider_acceleration_limit)
from euc_sim.rides.sim.plan_learning import filter_band, inverse_correction
from euc_sim.simulation.engine import default_rider, simulate
from euc_sim.simulation.errors import FallError
from euc_sim.simulation.maneuvers import Maneuver

__all__ = ["to_grid", "ProfileRun", "simulate_profile", "RideCancelled"]

def to_grid(t_fine: np.ndarray, y: np.ndarray, t_grid: np.ndarray) -> np.ndarray:
    """Mean of the uniformly sampled ``y`` (at ``t_fine``, s) over each interval of the coarser
    uniform grid ``t_grid`` (s) centred on its points; NaN where an interval holds no sample.
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
        The simulator's output (1/dt Hz) up to the fall, rest rows at the stops; None when
        the rider fell before the first step.
    falls : tuple of dict
        ``{"t": s, "cause": str}`` of the fall that ended the run (at most one).
    notes : tuple of str
        The fall and the plan corrections, in order.
    """

    frame: pd.DataFrame | None
    falls: tuple[dict, ...]
    notes: tuple[str, ...]


class RideCancelled(Exception):
    """A run ended because its caller cancelled it (``simulate_profile(cancel=...)``)."""


class _RideClock:
    """A tqdm bar over the ride's seconds (stderr), fed by the engine's ``progress(t)``; raises
    :class:`RideCancelled` at its next tick once ``cancel`` (a :class:`threading.Event`) is set."""

    def __init__(self, total: float, desc: str, enabled: bool, position: int = 0, cancel=None):
        self.cancel = cancel
        self.bar = tqdm(total=round(total, 1), desc=desc, unit="s", unit_scale=False, file=sys.stderr,
                        disable=not enabled, position=position, mininterval=1.0, bar_format="{desc}: {percentage:3.0f}%|{bar}| "
                        "{n:.0f}/{total:.0f} s of ride [{elapsed}<{remaining}]")

    def __call__(self, t: float) -> None:
        if self.cancel is not None and self.cancel.is_set():
            raise RideCancelled(f"{self.bar.desc}: cancelled at t = {t:.1f} s")
        self.bar.update(max(0.0, round(t, 1) - self.bar.n))

    def close(self) -> None:
        self.bar.close()


class _Stretches:
    """The rides of a run's stretches between stops, each from rest with its own seed: ridden
    when asked for, or all submitted to ``pool`` and collected in order (the same rides).
    :meth:`abandon` (after a fall) cancels those not started and ends those riding.
    """

    def __init__(self, t, v_plan, segments, params, effects, seed, dt, clock, motor, rider, pool):
        self.quit = threading.Event()
        self.segments = segments

        def one(i: int) -> pd.DataFrame:
            a, b = segments[i]
            t0 = float(t[a])

            def seg_clock(s: float) -> None:
                if self.quit.is_set():
                    raise RideCancelled("a stretch after a fall: not ridden")
                if clock is not None:
                    clock(t0 + s)

            return _ride(t[a:b + 1] - t0, v_plan[a:b + 1], params, effects,
                         seed if i == 0 else int(np.random.SeedSequence((int(seed), i)).generate_state(1)[0]), dt,
                         None if clock is None and pool is None else seg_clock, motor, rider)

        self.one = one
        self.futures = None if pool is None else [pool.submit(one, i) for i in range(len(segments))]

    def ride(self, i: int) -> pd.DataFrame:
        """Stretch i's frame (its own clock, from 0), or its :class:`FallError`."""
        return self.one(i) if self.futures is None else self.futures[i].result()

    def abandon(self) -> None:
        self.quit.set()
        for fut in self.futures or ():
            fut.cancel()


def _track(t, v_target, v_plan, params, effects, seed, dt, clock=None, motor=None, rider=None, stops=(),
           pool=None):
    """One run along the plan ``v_plan``; its frame, its speed on the profile grid (m/s) and
    its RMS error to ``v_target``.

    With ``stops``, each stretch between them is ridden from rest by a fresh rider (stretch
    i > 0 seeded by one draw of SeedSequence((``seed``, i))) and the wheel stands through each stop;
    ``attrs["step_off"]`` is the largest |ẋ| (m/s) at which a stretch ended at a stop.  A
    fall raises :class:`FallError` at the ride's time with the ride up to it as ``trajectory``.
    """
    segments = moving_segments(t.size, list(stops)) if stops else [(0, t.size - 1)]
    pieces, x_end, t_end, step_off, attrs = [], 0.0, None, 0.0, {}
    rest_pose = _rest_pose(params, motor) if stops else (0.0, 0.0)

    def stand(t0: float, t1: float, closed: bool) -> None:
        """Rest rows after t0 up to t1 (t1 itself only when ``closed``)."""
        ts = np.arange(t0 + dt, t1 + (0.5 if closed else -0.5) * dt, dt)
        if ts.size:
            pieces.append(rest_rows(ts, x_end, *rest_pose, np.interp(ts, t, v_plan)))

    rides = _Stretches(t, v_plan, segments, params, effects, seed, dt, clock, motor, rider, pool)
    for i, (a, b) in enumerate(segments):
        if t_end is None and a > 0:
            stand(float(t[0]) - dt, float(t[a]), False)
        elif t_end is not None:
            stand(t_end, float(t[a]), False)
        t0 = float(t[a])
        try:
            df = rides.ride(i)
        except FallError as exc:
            rides.abandon()
            fell = FallError(t0 + exc.t, exc.quantity, exc.value, exc.bound)
            part = [] if exc.trajectory is None else [_shifted(exc.trajectory, t0, x_end)]
            fell.trajectory = pd.concat(pieces + part, ignore_index=True) if pieces or part else None
            raise fell from None
        except BaseException:
            rides.abandon()
            raise
        pieces.append(_shifted(df, t0, x_end))
        attrs = attrs or dict(df.attrs)
        x_end, t_end = float(pieces[-1]["x"].iloc[-1]), float(pieces[-1]["t"].iloc[-1])
        if stops and b < t.size - 1:
            step_off = max(step_off, abs(float(df["x_dot"].iloc[-1])))
    if t_end is None:                      # the whole profile is one stop
        stand(float(t[0]) - dt, float(t[-1]), True)
    elif t_end < t[-1] - dt / 2:
        stand(t_end, float(t[-1]), True)
    df = pd.concat(pieces, ignore_index=True) if len(pieces) > 1 else pieces[0]
    df.attrs.update(attrs, step_off=step_off)
    if clock is not None:
        clock(float(t[-1]))                # the whole ride ridden
    v_sim = to_grid(df["t"].to_numpy(), df["x_dot"].to_numpy(), t)
    v_sim = np.where(np.isfinite(v_sim), v_sim, v_plan)
    return df, v_sim, float(np.sqrt(np.mean((v_target - v_sim) ** 2)))


def _ride(t, v_plan, params, effects, seed, dt, clock, motor, rider) -> pd.DataFrame:
    """:func:`~euc_sim.simulation.engine.simulate` along the plan (t from 0, s; m/s) from its trim."""
    man = Maneuver("profile", float(v_plan[0]), (), (tuple(t.tolist()), tuple(v_plan.tolist())))
    df = simulate(man, float(t[-1]), params=params, motor=motor,
                  rider=rider if rider is not None else default_rider(params, motor), seed=seed,
                  effects=dict(effects), dt=dt, progress=clock)
    # the description without the profile's table (the plan, given here): pandas deep-copies
    # ``attrs`` at every operation on the frame, and an hour's table is 2 x 36,000 floats
    df.attrs["maneuver"] = {k: v for k, v in df.attrs["maneuver"].items() if k != "table"}
    return df


def _shifted(df: pd.DataFrame, t0: float, x0: float) -> pd.DataFrame:
    """A stretch's frame on the ride's clock and road: t + t0, x + x0 (a new frame)."""
    return df.assign(t=df["t"] + t0, x=df["x"] + x0)


def _rest_pose(params: Params, motor) -> tuple[float, float]:
    """(γ, φ) of the trim at rest, rad (:func:`euc_sim.controllers.rider.trim` at a = v = 0)."""
    gamma, phi, _, _ = trim(params, motor or MotorPD(), 0.0, 0.0)
    return float(gamma), float(phi)


def _correct_plan(t, target, plan, run, params, effects, seed, dt, iterations: int, band: float,
                  notes: list, say, clock_of, motor=None, rider=None, stops=(), pool=None) -> pd.DataFrame:
    """Iterative learning: the plan corrected through the inverted closed loop, ridden again.

    Each correction is :func:`~euc_sim.rides.sim.plan_learning.inverse_correction` of the speed
    error on the riding rows (|target| > ``V_MIN``) up to ``band`` Hz; a run that rides closer
    is kept, one that falls is discarded.  Returns the kept run's frame; appends to ``notes``.
    """
    df, v_sim, _ = run
    riding = np.abs(target) > V_MIN
    if not riding.any():
        return df

    def off(v):
        return float(np.sqrt(np.mean((target - v)[riding] ** 2)))

    err = off(v_sim)
    for it in range(iterations):
        plan = plan + inverse_correction(t, plan, v_sim, np.where(riding, target - v_sim, 0.0), band)
        say(f"tracking correction {it + 1} of {iterations}: riding the corrected plan")
        clock = clock_of(f"correction {it + 1}")
        try:
            df2, v2, _ = _track(t, target, plan, params, effects, seed, dt, clock, motor, rider, stops, pool)
        except FallError as exc:
            notes.append(f"tracking correction {it + 1}: rider fell ({exc}); kept the "
                         f"previous run")
            break
        finally:
            clock.close()
        err2 = off(v2)
        notes.append(f"tracking correction {it + 1}: RMS speed error while riding {err:.3f} -> "
                     f"{err2:.3f} m/s")
        if err2 >= err:
            break
        df, v_sim, err = df2, v2, err2
    return df


def simulate_profile(t: np.ndarray, v: np.ndarray, params: Params, effects: Mapping[str, float],
                     seed: int = 0, dt: float = 1e-3, track_iterations: int = 1,
                     learn_band: float | None = None, progress: Callable[[str], None] | None = None,
                     label: str = "ride", position: int = 0, motor=None, rider=None,
                     lean_share: float | None = LEAN_SHARE, band_limit: bool | None = None,
                     stops: Sequence[tuple[int, int]] | None = None, cancel=None, pool=None) -> ProfileRun:
    """Ride the speed profile (t, v) in closed loop (MuJoCo); stop where the rider falls.

    The first run rides the profile limited to the rider's envelope and band; the plan is
    then learned ``track_iterations`` times (:func:`_correct_plan`) aiming at the profile as
    logged, and the run closest to it while riding is kept.  A fall ends the run, is
    reported once, and the profile is not ridden again.

    Parameters
    ----------
    t, v : array_like
        Profile, s and m/s, uniform, t from 0.
    params : Params
    effects : mapping
        CONTRACT effect values injected as physics.
    seed : int
    dt : float
        Control period and MuJoCo step, s.
    track_iterations : int
        Plan corrections after the first run.
    learn_band : float, optional
        Highest frequency the plan learns, Hz (default :func:`plan_learning.filter_band`).
    progress : callable, optional
        Called with a short line before each run; a progress bar is then shown on stderr.
    label, position : str, int
        The bar's name and line.
    motor, rider : optional
        The wheel's balance law (default the paper's PD) and the rider (default the LQR rider
        designed for ``motor``).
    lean_share : float or None
        The profile's acceleration is first limited to :func:`rider_acceleration_limit` less
        :func:`resisting_acceleration`; None: the profile as logged.
    band_limit : bool or None
        Band-limit the first plan to ω_B = z/2, z the right-half-plane zero of the rider's
        speed response (:func:`plan_band_limit`); None: when ``lean_share`` is not None.
    stops : sequence of (int, int), optional
        The log's stops, (first, last) rows of ``t``; default found on ``v``; ``()``: none.
    cancel : threading.Event, optional
        Once set, the run raises :class:`RideCancelled` within one rider block.
    pool : concurrent.futures.ThreadPoolExecutor, optional
        The stretches between stops ride on it side by side.
    """
    say = progress or (lambda msg: None)
    t = np.asarray(t, float)
    v = logged = np.asarray(v, float)
    notes: list[str] = []

    def clock_of(what: str) -> _RideClock:
        return _RideClock(float(t[-1] - t[0]), f"{label} {what}", progress is not None, position, cancel)

    a_limit = None
    if lean_share is not None and t.size > 1:
        a_res = resisting_acceleration(params, effects)
        a_limit = rider_acceleration_limit(params, motor, lean_share) - a_res
        if a_limit <= 0:                     # he cannot even hold a speed against them
            cause = (f"the injected resistance ({a_res:.2f} m/s²) exceeds what the simulated rider "
                     f"can lean against ({a_limit + a_res:.2f} m/s²)")
            notes.append(f"rider cannot ride: {cause}; the profile is not ridden")
            return ProfileRun(None, ({"t": 0.0, "cause": cause},), tuple(notes))
        v = _within_envelope(t, v, a_limit, lean_share, notes)
    band_width = 0.0
    if band_limit is None:
        band_limit = lean_share is not None
    if band_limit and t.size > 1:
        band_width, z = plan_band_limit(params, motor)
        if band_width:
            v_band = moving_average(t, v, band_width)
            dev = np.abs(v_band - v)
            notes.append(f"rider's plan band-limited to z/2 = {0.5 * z:.2f} rad/s, half his speed "
                         f"response's right-half-plane zero z (a {band_width:.2f} s centred moving "
                         f"average): {np.sqrt(np.mean(dev ** 2)):.3f} m/s RMS, {dev.max():.2f} m/s at "
                         f"most from the {'limited' if a_limit is not None else 'logged'} profile")
            v = v_band
    if stops is None:
        stops = find_stops(t, logged) if t.size > 1 else ()
    stops = tuple((int(a), int(b)) for a, b in stops)
    ends = [i for stop in stops for i in stop]
    if ends and (ends != sorted(ends) or ends[0] < 0 or ends[-1] >= t.size):
        raise ValueError(f"stops: expected ordered (first, last) rows within 0…{t.size - 1}, got {list(stops)}")
    if stops:
        still = sum(float(t[b] - t[a]) for a, b in stops)
        notes.append(f"the log stands still at {len(stops)} stop{'s' * (len(stops) != 1)}, {still:.0f} s of {t[-1] - t[0]:.0f} s: the "
                     f"simulated rider stands there, foot down (no motor or ankle torque), and sets off "
                     f"from rest with his memory cleared")
    say(f"riding {t[-1] - t[0]:.0f} s of the logged profile")
    clock = clock_of("ride")
    try:
        df, v_sim, err = _track(t, v, v, params, effects, seed, dt, clock, motor, rider, stops, pool)
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
        band = filter_band() if learn_band is None else learn_band
        df = _correct_plan(t, logged, v, (df, v_sim, err), params, effects, seed, dt,
                           track_iterations, band, notes, say, clock_of, motor, rider, stops, pool)
    if any(a > 0 for a, _ in stops):          # a stretch ended at a stop
        notes.append(f"at the stops the simulated rider (the run kept) put his foot down from up to "
                     f"{df.attrs['step_off']:.2f} m/s")
    return ProfileRun(df, (), tuple(notes))


def _within_envelope(t: np.ndarray, v: np.ndarray, a_limit: float, lean_share: float,
                     notes: list) -> np.ndarray:
    """The profile limited to ±``a_limit`` m/s² where it exceeds it; a note says how much."""
    a = np.diff(v) / np.diff(t)
    over = np.abs(a) > a_limit * (1 + 1e-9)
    if not over.any():
        return v
    out = limit_acceleration(t, v, a_limit)
    dev = np.abs(out - v)
    notes.append(f"profile acceleration limited to ±{a_limit:.2f} m/s², what the simulated rider "
                 f"can ride (his steady lean within {lean_share:g} of the fall bound, less the "
                 f"rolling resistance and slope; the log "
                 f"reaches {np.abs(a).max():.2f} m/s²): {100 * over.mean():.1f} % of the ride "
                 f"exceeded it; the limited profile differs from the logged one by "
                 f"{np.sqrt(np.mean(dev ** 2)):.3f} m/s RMS, {dev.max():.2f} m/s at most")
    return out

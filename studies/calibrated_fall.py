"""Why the calibrated rider falls in a pair's ``drivetrain`` step (Lynx 0 -> 2, Blitz 2 -> 4): its window, measured.

    nice -n 10 python studies/calibrated_fall.py PAIR_DIR HELD_LOG SPEC [--start 541] [--end 600]
        [--variants as_stepped,seed1,rolling_cap=0.02,...] [--frames DIR]

``PAIR_DIR`` is a pair's folder of ``scripts/tables/ride_simulation_table.py`` run with
``--calibrate-rider`` (its ``ride.json``), ``HELD_LOG`` the held-out log and ``SPEC`` the wheel's
spec.  The ``drivetrain`` step is rebuilt from the JSON (its motor law with the voltage limit,
its injected effects, the calibrated rider's delay, bandwidth and motor noise, his 6 s plan
:func:`euc_sim.rides.grids.profile.rider_plan`; the total mass the page found), and a window of the
held-out profile is ridden from the trim at its first speed, as ``studies/nominal_falls.py``
does (:func:`euc_sim.rides.sim.tracking.simulate_profile`, envelope and band limit on, no plan
correction: the fall was the first run's).  Each variant changes one thing (``VARIANTS``).
Per variant it prints whether the rider fell, the largest |φ|, |M_h|, |M_d| and the voltage
limit's share of the window, and the rider's distance ahead of his plan ∫(ẋ − v_ref) dt (the
state his speed-error integral holds) at its largest and smallest, with the lowest speed.
``--frames DIR`` writes each variant's simulated frame (``DIR/<variant>.csv``, the ride's clock).

The rolling-resistance variants (docs/ride_simulation.md, Blitz 2 → 4) change the physics or
the rider's trim for that run only: ``rolling_cap=X`` injects C_rr capped at X,
``rolling_sign=X`` regularises sign(ẋ) of the rolling moment over X m/s instead of
:data:`euc_sim.simulation.effects.SIGN_SPEED` (run in the Python loop: the native loop's
compiled kernel froze the constant), ``rider_knows_rolling`` gives the rider a trim that holds
the rolling moment (:func:`trim_with_rolling`).
"""

from __future__ import annotations

import argparse
import contextlib
import json
import math
import sys
from pathlib import Path

#: name -> what the variant changes (one thing each).
VARIANTS = {
    "as_stepped": "the drivetrain step as the table ran it (noise seed 0)",
    "seed1": "motor-noise seed 1", "seed2": "motor-noise seed 2", "seed3": "motor-noise seed 3",
    "no_noise": "no motor noise",
    "no_rolling": "rolling resistance not injected",
    "no_drag": "aerodynamic drag not injected",
    "no_voltage_limit": "the measured law without the voltage limit (the measured_law step's motor)",
    "plan_10s": "the plan smoothed over 10 s (the rider study's) instead of 6 s",
    "no_integral": "the same rider designed without the speed-error integral",
    "default_rider": "the default rider (0.15 s, no noise) in the same step",
    "no_stop_model": "the rider balances through the log's stops (no stop model)",
    "rolling_plausible": "rolling resistance capped at the catalog's plausible upper bound (0.04), the rest not injected",
    "rolling_sign_0.1": "the rolling moment's tanh(ẋ/v_s) over v_s = 0.1 m/s instead of 0.01 (Python loop)",
    "rider_knows_rolling": "the rider's trim includes the injected rolling moment C_rr·N·R·sign(v_ref) (eq. (5) row 1)",
}

#: Parametric variants: prefix -> what the number sets (``rolling_cap=0.02``, ``rolling_sign=0.3``).
PARAMETRIC = {
    "rolling_cap=": "rolling resistance capped at C_rr = {}",
    "rolling_sign=": "the rolling moment's tanh(ẋ/v_s) over v_s = {} m/s (Python loop)",
}


def describe(name: str) -> str:
    """What a variant changes (one line), fixed or parametric; ValueError for an unknown one."""
    if name in VARIANTS:
        return VARIANTS[name]
    for prefix, text in PARAMETRIC.items():
        if name.startswith(prefix):
            try:
                value = float(name[len(prefix):])
            except ValueError:
                break
            if math.isfinite(value) and value >= 0 and (value > 0 or prefix == "rolling_cap="):
                return text.format(f"{value:g}")
    raise ValueError(f"--variants: unknown variant {name!r} (one of {', '.join(VARIANTS)}, "
                     f"or {', '.join(p + 'X' for p in PARAMETRIC)})")


def trim_with_rolling(C_rr: float, sign_speed: float):
    """:func:`euc_sim.controllers.rider.trim` with the rolling moment C_rr·N·R·tanh(v/v_s) in eq. (5) row 1.

    Row 1 becomes R·m11·a + C_rr·N·R·tanh(v/v_s) = M_d (N = :func:`normal_load`); rows 2-3 as in
    ``trim`` with the actual acceleration a: the rider holds the motor's extra reaction with
    his lean, he does not lean for an acceleration he does not have.  At v = 0 (the rest
    trim, the acceleration limit) it is ``trim``.

    Parameters
    ----------
    C_rr : float
        Rolling-resistance coefficient, 1.
    sign_speed : float
        v_s, m/s: the simulator's regularisation of sign(v).

    Returns
    -------
    callable
        ``trim(p, motor, a, v=0.0)`` → (γ*, φ*, M_d*, M_h*), rad and N·m.
    """
    import numpy as np

    from euc_sim.controllers.rider import trim

    def trimmed(p, motor, a, v=0.0):
        a = np.asarray(a, dtype=float)
        m11 = p.m + p.m0 + p.mw + p.Jw / p.R ** 2                          # eq. (6)
        a_rr = C_rr * p.total_mass * p.g * np.tanh(np.asarray(v, dtype=float) / sign_speed) / m11
        gamma, _, M_d, _ = trim(p, motor, a + a_rr, v)                     # M_d = R (m11 a + C_rr N)
        m21 = -(p.m * p.l0 - p.m0 * p.h0) * np.cos(gamma)
        M_h = M_d + m21 * a - (p.m0 * p.h0 - p.m * p.l0) * p.g * np.sin(gamma)   # eq. (5) row 2
        ratio = np.clip(M_h / (p.m * p.h * np.hypot(p.g, a)), -1.0, 1.0)
        return gamma, np.arctan2(a, p.g) + np.arcsin(ratio), M_d, M_h        # eq. (5) row 3

    return trimmed


@contextlib.contextmanager
def _swapped(module, name: str, value):
    """``module.name`` set to ``value`` inside the block (a study's one-off change), restored after."""
    old = getattr(module, name)
    setattr(module, name, value)
    try:
        yield
    finally:
        setattr(module, name, old)


def distance_ahead(t, x_dot, v_ref):
    """∫(ẋ − v_ref) dt from the window's start, m (trapezoid), on the frame's rows.

    Parameters
    ----------
    t, x_dot, v_ref : array_like
        Time (s), simulated speed and the rider's planned speed (m/s).

    Returns
    -------
    numpy.ndarray
    """
    import numpy as np
    from scipy.integrate import cumulative_trapezoid

    return cumulative_trapezoid(np.asarray(x_dot, float) - np.asarray(v_ref, float), np.asarray(t, float),
                                initial=0.0)


def _run_summary(res, m, t0: float, frames: Path | None, name: str) -> dict:
    """One variant's window: fall, largest |φ|, |M_h|, |M_d|, distance ahead, time at the voltage limit."""
    import numpy as np

    fr = res.frame
    d = distance_ahead(fr["t"], fr["x_dot"], fr["v_ref"])
    if frames is not None:
        frames.mkdir(parents=True, exist_ok=True)
        fr.assign(t=fr["t"] + t0, ahead=d).to_csv(frames / f"{name}.csv", index=False)
    at_limit = float("nan")
    if np.isfinite(m.voltage):        # the motor's torque the voltage leaves, against what it gives
        room = np.array([m.voltage_torque(x) for x in fr["x_dot"].to_numpy()])
        at_limit = float(np.mean((fr["M_d"] * fr["x_dot"] > 0) & (np.abs(fr["M_d"]) >= 0.95 * room)))
    return {
        "fall": (t0 + res.falls[0]["t"], res.falls[0]["cause"]) if res.falls else None,
        "max": {k: float(np.abs(fr[k]).max()) for k in ("phi", "M_h", "M_d")},
        "ahead": (float(d.max()), float(d.min())), "v_min": float(fr["x_dot"].min()),
        "voltage_share": at_limit, "t_phi": t0 + float(fr["t"].iloc[int(np.abs(fr["phi"]).argmax())])}


def window_runs(pair: Path, held: Path, spec_path: Path, t0: float, t1: float, names,
                frames: Path | None = None) -> dict:
    """Each variant's window: fall, largest |φ|, |M_h|, |M_d|, distance ahead of the plan.

    With ``frames`` (a folder), each variant's simulated frame is written there as
    ``<variant>.csv`` on the ride's clock, with the distance ahead of the plan (``ahead``, m).
    """
    from euc_sim.controllers.design import DEFAULT_SCALES, design_rider
    from euc_sim.rides.grids.profile import rider_plan, speed_profile
    from euc_sim.rides.grids.signals import RideAssumptions, with_found_values
    from euc_sim.rides.grids.stops import find_stops
    from euc_sim.rides.rider.rider_params import rider_from
    from euc_sim.rides.sim.sim_steps import motor_from_law
    from euc_sim.rides.sim.simulate import ride_params
    from euc_sim.rides.sim.tracking import simulate_profile
    from euc_sim.rides.source.logs import read_log
    from euc_sim.rides.source.spec import wheel_spec
    import functools

    import euc_sim.controllers.rider as rider_module
    from euc_sim.simulation import effects, engine
    from euc_sim.simulation.effects import CATALOG

    ride = json.loads((pair / "ride.json").read_text())
    steps = {s["step"]: s for s in ride["simulation"]["steps"]}
    if "calibrated_rider" not in steps or not isinstance(steps["drivetrain"]["rider"], dict):
        raise ValueError(f"{pair / 'ride.json'}: no calibrated rider in its drivetrain step")
    tm = ride["total_mass"]
    A = with_found_values(RideAssumptions(), wheel_spec(spec_path), tm.get("estimate"),
                          (tm.get("equivalent_mass") or {}).get("estimate"))
    params = ride_params(A)

    step = steps["drivetrain"]
    law, drive = motor_from_law(steps["calibrated_rider"]["motor"]), motor_from_law(step["motor"])
    fitted = {"delay": step["rider"]["delay"], "noise_std": step["rider"]["noise_std"],
              "bandwidth": step["rider"]["bandwidth"]}
    prof = speed_profile(read_log(held, emit_warnings=False), total_mass=A.total_mass)
    t, v = prof["t"].to_numpy(), prof["v"].to_numpy()
    w = (t >= t0) & (t <= t1)
    out = {"rider": fitted, "effects": dict(step["effects_injected"]), "runs": {}}
    for name in names:
        describe(name)
    for name in names:
        rider = rider_from(fitted, params, law)          # designed against the law, as rider_fit does
        m, eff, seed, window = drive, dict(step["effects_injected"]), 0, step["rider"]["plan_window"] or 6.0
        changes = contextlib.ExitStack()                  # the variant's one-off swaps, undone after its run
        stops = find_stops(t[w] - t0, v[w])               # on the log's speed, as simulate_ride finds them
        if name.startswith("seed"):
            seed = int(name[4:])
        elif name == "no_noise":
            rider = rider_from({**fitted, "noise_std": 0.0}, params, law)
        elif name == "no_rolling":
            eff.pop("rolling_resistance", None)
        elif name == "no_drag":
            eff.pop("aerodynamic_drag", None)
        elif name == "no_voltage_limit":
            m = law
        elif name == "plan_10s":
            window = 10.0
        elif name == "no_integral":
            rider = design_rider(params, law, delay=fitted["delay"], noise_std=fitted["noise_std"],
                                 scales={"M_h": DEFAULT_SCALES["M_h"] * fitted["bandwidth"] ** 0.5, "x_int": None})
        elif name == "default_rider":
            rider = None
        elif name == "no_stop_model":
            stops = ()
        elif name == "rolling_plausible" or name.startswith("rolling_cap="):
            cap = CATALOG["rolling_resistance"].plausible[1] if name == "rolling_plausible" else float(name[12:])
            eff["rolling_resistance"] = min(eff.get("rolling_resistance", 0.0), cap)
        elif name == "rolling_sign_0.1" or name.startswith("rolling_sign="):
            v_s = 0.1 if name == "rolling_sign_0.1" else float(name[13:])
            # held_forces reads SIGN_SPEED when called from the Python loop; numba froze it in the native one
            changes.enter_context(_swapped(effects, "SIGN_SPEED", v_s))
            changes.enter_context(_swapped(engine, "simulate", functools.partial(engine.simulate, native=False)))
        elif name == "rider_knows_rolling":
            changes.enter_context(_swapped(rider_module, "trim", trim_with_rolling(
                eff.get("rolling_resistance", 0.0), effects.SIGN_SPEED)))
        elif name != "as_stepped":
            raise ValueError(f"--variants: unknown variant {name!r}")
        plan = rider_plan(t, v, window)
        with changes:
            res = simulate_profile(t[w] - t0, plan[w], params, eff, seed=seed, track_iterations=0, motor=m,
                                   rider=rider, stops=stops)
        out["runs"][name] = _run_summary(res, m, t0, frames, name)
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("pair", type=Path)
    ap.add_argument("held", type=Path)
    ap.add_argument("spec", type=Path)
    ap.add_argument("--start", type=float, default=541.0, help="window start, s of the held-out ride")
    ap.add_argument("--end", type=float, default=600.0, help="window end, s")
    ap.add_argument("--variants", default=",".join(VARIANTS))
    ap.add_argument("--frames", type=Path, default=None,
                    help="folder: write each variant's simulated frame there as <variant>.csv")
    a = ap.parse_args(argv)
    for f in (a.pair / "ride.json", a.held, a.spec):
        if not f.is_file():
            print(f"calibrated_fall: {f}: no such file", file=sys.stderr)
            return 2
    try:
        r = window_runs(a.pair, a.held, a.spec, a.start, a.end, [s for s in a.variants.split(",") if s],
                        a.frames)
    except KeyError as exc:
        print(f"calibrated_fall: {a.pair / 'ride.json'}: no field {exc} (not a ride JSON with simulation steps)",
              file=sys.stderr)
        return 2
    except ValueError as exc:
        print(f"calibrated_fall: {exc}", file=sys.stderr)
        return 2
    print(f"rider {r['rider']}, effects {r['effects']}, window {a.start:g}-{a.end:g} s")
    print("| variant | fell | max abs phi rad (at s) | max abs M_h / M_d N·m | at the voltage limit | "
          "distance ahead of the plan, max / min m | lowest speed m/s |")
    print("| --- | --- | --- | --- | --- | --- | --- |")
    for name, run in r["runs"].items():
        fell = f"{run['fall'][0]:.2f} s ({run['fall'][1]})" if run["fall"] else "no"
        print(f"| `{name}`: {describe(name)} | {fell} | {run['max']['phi']:.3f} ({run['t_phi']:.1f}) | "
              f"{run['max']['M_h']:.0f} / {run['max']['M_d']:.0f} | {100 * run['voltage_share']:.1f} % | "
              f"{run['ahead'][0]:+.1f} / {run['ahead'][1]:+.1f} | {run['v_min']:.2f} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())

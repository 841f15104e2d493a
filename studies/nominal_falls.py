"""Showed why the paper's PD drops the simulated rider on two shared pairs, the fall windows measured: docs/ride_falls.md.

Why the paper's PD drops the simulated rider on two shared pairs: the fall windows, measured.

    nice -n 10 python studies/nominal_falls.py [--out docs/figures/nominal_falls.png]
        [--n-boot 20] [--no-spikes]
    nice -n 10 python studies/nominal_falls.py --own [--out docs/figures/nominal_falls_own.png]

The ``nominal`` step of ``euc-sim ride FIT --compare HELD`` (paper's PD 600 / 40 N·m/rad with
MotorPD's 250 N·m limit, the default LQR rider, no effects) fell on lynx 2 -> 0 at 1,819.6 s and
master_pro_V2 3 -> 6 at 306.1 s, and (in the Blitz run of 2026-11-26) blitz 2 -> 4 at 2,112.5 s
(docs/ride_simulation.md).  For each, this study finds the
total mass on FIT as the ride command does, takes HELD's speed profile (with the wheel-speed
spikes the battery cannot pay for bridged, :func:`euc_sim.rides.grids.profile.unpaid_spikes`, unless
``--no-spikes``), and rides a window of it from the trim at its first speed, 40 s before the fall
(:func:`euc_sim.rides.sim.tracking.simulate_profile`, no plan correction) with the paper's PD (the
three runs below).  It
prints, per run, whether the rider fell and the largest ankle torque M_h, motor torque M_d,
body pitch γ and lean φ, and plots the logged and simulated speed, the torques and γ.

``--own``: the two falls of ``scripts/tables/ride_falls.py`` (each log fitted and ridden on itself, as
``euc-sim ride LOG --wheel SPEC``): master_pro_V2/3 ``nominal`` at 1,164.2 s and apex/0
``firmware`` (the measured law as the motor) at 1,462.5 s.  The set-up is ride_falls's (mass,
balance fit, the filtered profile with spikes bridged, the measured law at ``--n-boot``
replicates, seed 0).  master_pro_V2/3 gets the same three paper-PD runs as the pairs; apex/0's
two runs are the measured law with its fitted torque limit (as the count found the fall) and
with the limit :func:`euc_sim.controllers.firmware.firmware_settings` now uses (the largest |torque| the
same log measured, where the fit's is lower), both with the plan band-limited.

Each paper-PD window is ridden three times: the plan not band-limited (as the falls were found),
band-limited to z/2 (:func:`euc_sim.rides.sim.envelope.plan_band_limit`, as simulated now), and not
band-limited at a 500 N·m limit (a diagnosis, not a model: nothing is chosen by it).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
DATA = ROOT.parent / "shared" / "data" / "euc_core"
#: name -> (fit log, held-out log, spec, window start, window end), s; the window starts 40 s
#: before the fall and ends 10 s past it.
CASES = {"lynx 2 -> 0": ("trips/leaperkim/lynx/2/2.csv", "trips/leaperkim/lynx/0/0.csv", "specs/lynx.csv",
                         1780.0, 1830.0),
         "master_pro_V2 3 -> 6": ("trips/begode/master_pro_V2/3/3.csv", "trips/begode/master_pro_V2/6/6.csv",
                                  "specs/master_pro_V2.csv", 266.0, 316.0),
         "blitz 2 -> 4": ("trips/begode/blitz/2/2.csv", "trips/begode/blitz/4/4.csv", "specs/blitz.csv",
                          2072.0, 2122.0)}

#: name -> (log, spec, window start, window end, run): the falls of scripts/tables/ride_falls.py.
OWN_CASES = {"master_pro_V2/3 nominal": ("trips/begode/master_pro_V2/3/3.csv", "specs/master_pro_V2.csv",
                                         1124.2, 1174.2, "nominal"),
             "apex/0 firmware": ("trips/nosfet/apex/0/0.csv", "specs/apex.csv", 1422.5, 1472.5, "firmware")}


def _pd_runs():
    """(label, motor, band_limit) of the paper-PD runs: the plan before and after the band limit."""
    from euc_sim.controllers.motor import MotorPD

    return (("paper PD, 250 N·m limit, plan not band-limited (before)", MotorPD(), False),
            ("paper PD, 250 N·m limit, plan band-limited to z/2 (as simulated now)", MotorPD(), True),
            ("paper PD, 500 N·m limit, plan not band-limited (diagnosis)", MotorPD(torque_limit=500.0), False))


def own_window(case: tuple, data: Path, n_boot: int) -> dict:
    """ride_falls's set-up on one log, its window ridden with the run's motor and a diagnosis."""
    import dataclasses

    import numpy as np

    from euc_sim.controllers.firmware import firmware_motor
    from euc_sim.rides.grids.profile import speed_profile
    from euc_sim.rides.law.controller_report import controller_fit, firmware_terms, torque_constant
    from euc_sim.rides.pipeline import balance_on_mass
    from euc_sim.rides.sim.simulate import ride_params
    from euc_sim.rides.sim.tracking import simulate_profile
    from euc_sim.rides.source.logs import read_log
    from euc_sim.rides.source.spec import wheel_spec

    log_path, spec_path, t0, t1, run = case
    log, spec = data / log_path, wheel_spec(data / spec_path)
    fitted = balance_on_mass(log, None, spec, n_boot=n_boot, seed=0)
    physics, sig = fitted.physics, fitted.analysis.sig_fit
    params = ride_params(sig.assumptions)
    prof = speed_profile(log, sig.rate, sig.window, sig.polyorder, total_mass=sig.assumptions.total_mass)
    t, v = prof["t"].to_numpy(), prof["v"].to_numpy()
    w = (t >= t0) & (t <= t1)
    lg = read_log(log, emit_warnings=False).data
    out = {"mass": sig.assumptions.total_mass, "R": params.R, "t0": t0, "t_prof": t[w], "v_prof": v[w],
           "log": lg, "runs": {}, "notes": [n for n in prof.attrs["notes"] if "spike" in n], "spikes": True,
           "ride": "ride (fitted on itself)"}
    if run == "firmware":
        ctrl = controller_fit(log, None, torque_constant(physics.terms), n_boot, 0)
        terms = firmware_terms(ctrl)
        motor, notes = firmware_motor(terms, params)
        out["notes"] += notes
        lim = terms["torque_limit"]
        fitted = lim.estimate
        above = int((np.abs(lg["phase_current"]) * ctrl.torque_constant > fitted).sum())
        out["notes"].append(f"measured law: K_p {motor.Kp:.0f} N·m/rad, K_d {motor.Kd:.1f} N·m·s/rad, fitted torque "
                            f"limit {fitted:.1f} N·m (95 % {lim.ci95[0]:.1f}-{lim.ci95[1]:.1f}); the log's "
                            f"largest |phase current| × K_t ({ctrl.torque_constant:.3f} N·m/A) is "
                            f"{lim.largest_measured:.1f} N·m, {above} of {len(lg)} rows above the fitted limit")
        motors = ((f"measured law, fitted {fitted:.0f} N·m limit (the fit's), plan band-limited",
                   dataclasses.replace(motor, torque_limit=fitted)),
                  (f"measured law, {motor.torque_limit:.0f} N·m limit (as simulated now), plan band-limited", motor))
    else:
        motors = _pd_runs()
    for label, m, *band in motors:
        res = simulate_profile(t[w] - t0, v[w], params, {}, seed=0, track_iterations=0, motor=m,
                               band_limit=band[0] if band else True)
        fr = res.frame
        out["runs"][label] = {"frame": fr, "limit": m.torque_limit,
                              "fall": (t0 + res.falls[0]["t"], res.falls[0]["cause"]) if res.falls else None,
                              "max": {k: float(np.abs(fr[k]).max()) for k in ("M_h", "M_d", "gamma", "phi")}}
    return out


def ride_window(case: tuple, data: Path, n_boot: int, spikes: bool) -> dict:
    """Mass on FIT, HELD's profile, and the window ridden with the paper's PD at two limits."""
    import numpy as np

    from euc_sim.rides.grids.profile import speed_profile
    from euc_sim.rides.grids.signals import RideAssumptions
    from euc_sim.rides.grids.signals import with_found_values
    from euc_sim.rides.drive.drivetrain_report import ride_drivetrain
    from euc_sim.rides.sim.simulate import ride_params
    from euc_sim.rides.sim.tracking import simulate_profile
    from euc_sim.rides.source.logs import read_log
    from euc_sim.rides.source.spec import wheel_spec

    fit, held, spec_path, t0, t1 = case
    spec = wheel_spec(data / spec_path)
    physics = ride_drivetrain(data / fit, None, spec, n_boot, 0)
    A = with_found_values(RideAssumptions(), spec, physics.mass.estimate,
                          (physics.mass.equivalent or {}).get("estimate"))
    params = ride_params(A)
    prof = speed_profile(data / held, total_mass=A.total_mass if spikes else None)
    t, v = prof["t"].to_numpy(), prof["v"].to_numpy()
    w = (t >= t0) & (t <= t1)
    out = {"mass": A.total_mass, "R": params.R, "t0": t0, "t_prof": t[w], "v_prof": v[w],
           "log": read_log(data / held, emit_warnings=False).data, "runs": {},
           "notes": [n for n in prof.attrs["notes"] if "spike" in n], "spikes": spikes}
    for label, motor, band in _pd_runs():
        res = simulate_profile(t[w] - t0, v[w], params, {}, seed=0, track_iterations=0, motor=motor,
                               band_limit=band)
        fr = res.frame
        out["runs"][label] = {"frame": fr, "fall": (t0 + res.falls[0]["t"], res.falls[0]["cause"])
                              if res.falls else None,
                              "limit": motor.torque_limit,
                              "max": {k: float(np.abs(fr[k]).max()) for k in ("M_h", "M_d", "gamma", "phi")}}
    return out


def _short(label: str) -> str:
    """A run's label for a legend: the limit and, where said, whether the plan is band-limited."""
    parts = label.split(", ")
    out = parts[1].replace(" limit", "") if len(parts) > 1 else label
    if "not band-limited" in label:
        out += ", raw plan"
    elif "band-limited" in label:
        out += ", band-limited plan"
    return out


def plot(results: dict, path: Path) -> Path:
    """Speed (log, plan, simulated), torques and body pitch of each fall window."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np

    fig, axes = plt.subplots(3, len(results), figsize=(6.5 * len(results), 9), sharex="col")
    axes = np.atleast_2d(axes).reshape(3, len(results))
    for c, (name, r) in enumerate(results.items()):
        t0, lg = r["t0"], r["log"]
        lw = lg[(lg["t"] >= r["t_prof"][0]) & (lg["t"] <= r["t_prof"][-1])]
        ax = axes[0, c]
        ax.plot(lw["t"], np.abs(lw["v"]), ".", color="0.5", label="logged wheel speed")
        if "gps_speed" in lw:
            ax.plot(lw["t"], lw["gps_speed"], "x", color="tab:green", ms=4, label="logged GPS speed")
        ax.plot(r["t_prof"], r["v_prof"], color="k", lw=1,
                label="profile, spikes bridged" if r["spikes"] else "profile, as logged")
        for (label, run), col, z in zip(r["runs"].items(), ("tab:red", "tab:blue", "0.6"), (3, 4, 2)):
            short = _short(label)
            fr = run["frame"].iloc[::20]
            tt = fr["t"] + t0
            ax.plot(tt, fr["x_dot"], color=col, lw=0.8, zorder=z, label=f"simulated, {_short(label)}")
            axes[1, c].plot(tt, fr["M_h"], color=col, lw=0.8, ls="--", zorder=z, label=f"ankle M_h, {short}")
            axes[1, c].plot(tt, fr["M_d"], color=col, lw=0.8, zorder=z, label=f"motor M_d, {short}")
            axes[2, c].plot(tt, fr["gamma"], color=col, lw=0.8, zorder=z, label=f"γ, {short}")
            if run["fall"]:
                for a in axes[:, c]:
                    a.axvline(run["fall"][0], color=col, ls=":", lw=1)
        lim = next(iter(r["runs"].values()))["limit"]
        axes[1, c].axhline(lim, color="0.3", lw=0.6, ls=":", label=f"{lim:.0f} N·m")
        axes[2, c].set_xlim(r["t_prof"][-1] - 24.0, r["t_prof"][-1])
        axes[2, c].axhline(0.5, color="0.3", lw=0.6, ls=":", label="bound 0.5 rad")
        ax.set_title(f"{name}: {r.get('ride', 'held-out ride')}'s window, total mass {r['mass']:.0f} kg")
        ax.set_ylabel("speed, m/s")
        axes[1, c].set_ylabel("torque, N·m")
        axes[2, c].set_ylabel("γ, rad")
        axes[2, c].set_xlabel(f"time in the {r.get('ride', 'held-out ride')}, s")
        for a in axes[:, c]:
            lo, hi = a.get_ylim()
            a.set_ylim(lo, hi + 0.6 * (hi - lo))          # headroom: the legend above the data
            a.legend(fontsize=7, loc="upper center", ncol=2, framealpha=0.9)
            a.grid(alpha=0.3)
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default=str(ROOT / "docs" / "figures" / "nominal_falls.png"))
    ap.add_argument("--data", default=str(DATA))
    ap.add_argument("--n-boot", type=int, default=20)
    ap.add_argument("--no-spikes", action="store_true", help="the speed profile as logged")
    ap.add_argument("--own", action="store_true", help="the two falls of scripts/tables/ride_falls.py instead")
    args = ap.parse_args(argv)
    data = Path(args.data)
    cases = OWN_CASES if args.own else CASES
    if args.own and args.out == ap.get_default("out"):
        args.out = str(ROOT / "docs" / "figures" / "nominal_falls_own.png")
    missing = [p for c in cases.values() for p in c[:(2 if args.own else 3)] if not (data / p).is_file()]
    if missing:
        print(f"nominal_falls: {data / missing[0]}: no such file", file=sys.stderr)
        return 2
    results = {}
    for name, case in cases.items():
        r = own_window(case, data, args.n_boot) if args.own else ride_window(case, data, args.n_boot,
                                                                             not args.no_spikes)
        results[name] = r
        for n in r["notes"]:
            print(f"{name}: {n}")
        for label, run in r["runs"].items():
            m = run["max"]
            fell = f"fell at {run['fall'][0]:.2f} s ({run['fall'][1]})" if run["fall"] else "rode"
            print(f"{name} [{case[-3 if args.own else 3]:g}, {case[-2 if args.own else 4]:g}] s, {label}: {fell}; max |M_h| {m['M_h']:.0f} N·m, "
                  f"|M_d| {m['M_d']:.0f} N·m, |γ| {m['gamma']:.3f} rad, |φ| {m['phi']:.3f} rad", flush=True)
    print(f"written {plot(results, Path(args.out))}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())

"""Showed which physical term makes a simulated ride's battery power differ from the balance fit's: docs/ride_simulation.md.

Which physical term makes a simulated ride's battery power differ from the balance fit's.

    python studies/power_error_terms.py PAIR_DIR HELD_LOG [--step drivetrain]

PAIR_DIR is one pair of ``scripts/tables/ride_simulation_table.py`` (``ride.json`` and
``report/ride_simulation.csv``, ``report/ride_balance.csv``); HELD_LOG is the held-out log it
simulated.  The simulated step and the balance fit share one battery-power model
(P₀ + P_mech/η_m driving, P₀ + η_r·P_mech braking, the fit ride's η and P₀), so their
difference is in the mechanical power.  On the scored rows, with that model (``conv``):

``acceleration``  conv(m_eq·a_sim·v_sim + F_res(v_sim)·v_sim) − conv(m_eq·a_log·v_sim + F_res(v_sim)·v_sim):
                  the simulated rider's acceleration differing from the logged one (a by the
                  log's own Savitzky–Golay derivative, on both);
``speed``         the balance model at the simulated speed less at the logged speed;
``grade``         the GPS-grade term the balance fit accepted (``road_slope_gps``), which the
                  simulator does not inject;
``body``          the step's power less the balance model on its own speed and acceleration
                  (the rider's and body's dynamics the balance model has not);
``high duty``     the logged power on rows above 80 % PWM (an efficiency that falls near the
                  voltage limit), where PWM is logged;
``time shift``    the logged power's rate, W/s (a lag between logged power and logged speed).

It prints each term's RMS (W), the step's error after removing the first four (unit
coefficients: they are the model's own), and a least-squares regression of the remaining error
on the last two, on all scored rows and on the rows where the simulated speed is within
0.2 m/s of the log.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("pair")
    ap.add_argument("held")
    ap.add_argument("--step", default="drivetrain")
    args = ap.parse_args(argv)
    import numpy as np
    import pandas as pd

    from euc_sim.rides.grids.signals import RideAssumptions, ride_signals, sg

    pair = Path(args.pair)
    try:
        rep = json.loads((pair / "ride.json").read_text())
        sim = pd.read_csv(pair / "report" / "ride_simulation.csv")
        bal = pd.read_csv(pair / "report" / "ride_balance.csv")
    except (OSError, ValueError) as exc:
        print(f"power_error_terms: {pair}: {exc}", file=sys.stderr)
        return 2
    step = args.step
    if f"P_{step}" not in sim or "P_augmented" not in bal:
        print(f"power_error_terms: {pair}: no column P_{step} or P_augmented", file=sys.stderr)
        return 2
    A, filt = rep["assumptions"], rep["filter"]
    try:
        sig = ride_signals(args.held, RideAssumptions(R=A["R"], total_mass=A["total_mass"], m_eq=A["m_eq"]),
                           rate=filt["rate_hz"], window=filt["window_s"], polyorder=filt["polyorder"])
    except (OSError, ValueError) as exc:
        print(f"power_error_terms: {args.held}: {exc}", file=sys.stderr)
        return 2
    for df in (sim, bal):
        df["t"] = df["t"].round(2)
    raw = sig.raw.assign(t=sig.raw["t"].round(2))
    seg = raw["segment"].to_numpy()
    f = lambda x, d=0: sg(np.asarray(x, float), seg, sig.rate, sig.window, sig.polyorder, d)  # noqa: E731
    extra = pd.DataFrame({"t": raw["t"], "a_log": sig.frame["a"].to_numpy(), "seg": seg,
                          "h": f(raw["gps_alt"]) if "gps_alt" in raw else np.nan})
    m = sim.merge(bal[["t", "P_augmented"]], on="t", how="left").merge(extra, on="t", how="left")
    ok = (m["scored"].astype(bool) & m["P_augmented"].notna() & m[f"P_{step}"].notna()).to_numpy()
    m["a_sim"] = sg(np.nan_to_num(m[f"v_{step}"].to_numpy()), m["seg"].fillna(-1).astype(int).to_numpy(),
                    sig.rate, sig.window, sig.polyorder, 1)
    pw = next(s for s in rep["simulation"]["steps"] if s["step"] == step)["power_model"]
    est = {k: v["estimate"] for k, v in rep["all_estimates"].items() if isinstance(v, dict) and "estimate" in v}
    acc = {e["name"] for e in rep["effects"]}
    g, m_eq, mt = 9.81, A["m_eq"], A["total_mass"]

    def conv(Pm):   # the energy balance: P₀ + P_mech (the copper loss needs the force: left out)
        return pw.get("drivetrain_idle_loss", 0.0) + Pm

    def res(v):
        return ((est.get("rolling_resistance", 0.0) if "rolling_resistance" in acc else 0.0) * mt * g * np.sign(v)
                + (est.get("aerodynamic_drag", 0.0) if "aerodynamic_drag" in acc else 0.0) * v * np.abs(v))

    v, vs = m["v_log"].to_numpy(), m[f"v_{step}"].to_numpy()
    a, a_s = m["a_log"].to_numpy(), m["a_sim"].to_numpy()
    hdot = np.gradient(m["h"].to_numpy(), 1.0 / sig.rate)
    grade = (est.get("road_slope_gps", 0.0) * mt * g * hdot) if "road_slope_gps" in acc else np.zeros(v.size)
    e = (m[f"P_{step}"] - m["P_log"]).to_numpy()
    terms = {"acceleration": conv(m_eq * a_s * vs + res(vs) * vs) - conv(m_eq * a * vs + res(vs) * vs),
             "speed": conv(m_eq * a * vs + res(vs) * vs) - conv(m_eq * a * v + res(v) * v),
             "grade": conv(m_eq * a * v + res(v) * v) - conv(m_eq * a * v + res(v) * v + grade),
             "body": m[f"P_{step}"].to_numpy() - conv(m_eq * a_s * vs + res(vs) * vs)}
    P = m["P_log"].to_numpy()
    duty = m["pwm_log"].to_numpy() if "pwm_log" in m else np.full(v.size, np.nan)
    extra_cols = {"high duty": np.where(np.nan_to_num(duty) > 80, P, 0.0), "time shift": np.gradient(P, 1.0 / sig.rate)}
    near = ok & (np.abs(vs - v) < 0.2)
    rms = lambda x, s: float(np.sqrt(np.nanmean(np.square(x[s]))))  # noqa: E731
    print(f"{pair.name} ({step}): error {rms(e, ok):.0f} W on {ok.sum()} rows, {rms(e, near):.0f} W on the "
          f"{100 * near.sum() / ok.sum():.0f} % where the speeds agree within 0.2 m/s; balance fit "
          f"{rms(m['P_augmented'].to_numpy() - P, ok):.0f} / {rms(m['P_augmented'].to_numpy() - P, near):.0f} W")
    print("| term | RMS W (all rows) | RMS W (speeds agree) | step error without it, W (all / agree) |")
    print("| --- | --- | --- | --- |")
    for name, x in terms.items():
        print(f"| {name} | {rms(x, ok):.0f} | {rms(x, near):.0f} | {rms(e - x, ok):.0f} / {rms(e - x, near):.0f} |")
    rest = e - sum(terms.values())
    print(f"| all four removed | | | {rms(rest, ok):.0f} / {rms(rest, near):.0f} |")
    for label, s in (("all rows", ok), ("speeds agree", near)):
        X = np.column_stack([extra_cols["high duty"], extra_cols["time shift"], np.ones(v.size)])
        good = s & np.isfinite(X).all(1) & np.isfinite(rest)
        b, *_ = np.linalg.lstsq(X[good], rest[good], rcond=None)
        print(f"remaining error on {label} regressed on high duty, time shift, 1: coefficients "
              f"{b[0]:+.3f}, {b[1]:+.3f} s, {b[2]:+.0f} W; RMS {rms(rest, good):.0f} -> {rms(rest - X @ b, good):.0f} W")
    return 0


if __name__ == "__main__":
    sys.exit(main())

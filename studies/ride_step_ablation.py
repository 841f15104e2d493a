"""Showed what makes a pair's simulated-step power error, by riding the step again with one thing changed: docs/ride_simulation.md.

One pair's simulated step ridden again with one thing changed: what makes its power error.

    nice -n 10 python studies/ride_step_ablation.py PAIR_DIR HELD_LOG [--step drivetrain]
        [--variants base noise3 no_preview no_delay lean0.4 lean0.5 no_limit learned]

PAIR_DIR is one pair of ``scripts/tables/ride_simulation_table.py`` (its ``ride.json`` and
``report/ride_balance.csv``); HELD_LOG the held-out log it simulated.  The pair's steps are
rebuilt from its ``ride.json`` (:func:`euc_sim.rides.sim.sim_steps.build_steps`, as ``euc-sim
ride`` builds them) and the named step is ridden along HELD_LOG with
:func:`euc_sim.rides.sim.simulate.simulate_ride`, seed 0, once per variant:

``base``        the step with its default rider, the plan not learned (``track_iterations`` 0);
``noise3``      base with 3 N·m of motor noise (OU, 0.05 s) on the rider;
``no_preview``  base with the rider's anticipation 0;
``no_delay``    base with the rider's reaction delay 0;
``lean0.4``, ``lean0.5``, ``no_limit``  base with the envelope's ``lean_share`` 0.4, 0.5, none;
``learned``     the step as the page rides it (one plan learned, :mod:`euc_sim.rides.sim.plan_learning`).

Per variant, on the rows the balance fit covers: the battery-power RMS error, its 2–20 s and
< 2 s parts and the fast-band RMS over the log's (:func:`power_error_parts.parts`), and the
speed's RMS error against the log.  One markdown row each.
"""

from __future__ import annotations

import argparse
import functools
import json
import sys
from dataclasses import replace
from types import SimpleNamespace
from pathlib import Path

VARIANTS = ("base", "noise3", "no_preview", "no_delay", "lean0.4", "lean0.5", "no_limit", "learned")


def _law(ctrl: dict):
    """The balance law of a ride JSON's ``controller`` object, as the steps take it."""
    from euc_sim.rides.law.controller_report import ControllerFit

    if ctrl.get("law") is None:
        return ControllerFit(None, ctrl.get("why"))
    w = ctrl["within_ride"]
    law = SimpleNamespace(terms={t["name"]: (t["estimate"], t.get("ci95"), t["unit"]) for t in ctrl["terms"]},
                          names=[t["name"] for t in ctrl["terms"]], sign=ctrl["sign"],
                          sign_share=ctrl["sign_share"], channel=ctrl["channel"], unit=w["unit"],
                          heldout_r2=w["r2"], nominal_r2=w["nominal_r2"], blind_r2=w["without_pitch_r2"],
                          heldout_rmse=w["rmse"], history=ctrl["selection"])
    top = next((t.get("largest_measured") for t in ctrl["terms"] if t["name"] == "torque_limit"), None)
    return ControllerFit(law, torque_constant=ctrl.get("torque_constant"), largest_measured=top)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("pair")
    ap.add_argument("held")
    ap.add_argument("--step", default="drivetrain")
    ap.add_argument("--variants", nargs="+", default=list(VARIANTS))
    args = ap.parse_args(argv)
    bad = [v for v in args.variants if v not in VARIANTS]
    if bad:
        print(f"ride_step_ablation: --variants {bad[0]}: not one of {', '.join(VARIANTS)}", file=sys.stderr)
        return 2
    import numpy as np
    import pandas as pd

    sys.path.insert(0, str(Path(__file__).resolve().parent))
    from power_error_parts import parts

    import euc_sim.rides.sim.simulate as simulate_module
    from euc_sim.rides.grids.signals import RideAssumptions, ride_signals
    from euc_sim.rides.drive.drivetrain import Term
    from euc_sim.rides.sim.sim_steps import STEP_BUILDERS, StepInputs, build_steps, log_channels
    from euc_sim.rides.sim.tracking import simulate_profile
    from euc_sim.simulation.engine import default_rider

    pair = Path(args.pair)
    try:
        rep = json.loads((pair / "ride.json").read_text())
        bal = pd.read_csv(pair / "report" / "ride_balance.csv")
        A, filt = rep["assumptions"], rep["filter"]
        sig = ride_signals(args.held, RideAssumptions(R=A["R"], total_mass=A["total_mass"], m_eq=A["m_eq"]),
                           rate=filt["rate_hz"], window=filt["window_s"], polyorder=filt["polyorder"])
    except (OSError, ValueError, KeyError) as exc:
        print(f"ride_step_ablation: {pair} / {args.held}: {exc}", file=sys.stderr)
        return 2
    est = lambda blk: {k: v["estimate"] for k, v in blk.items() if isinstance(v, dict) and "estimate" in v}  # noqa: E731
    params = simulate_module.ride_params(sig.assumptions)
    dt = {k: Term(v.get("estimate"), v.get("ci95"), v.get("unit")) for k, v in rep["drivetrain"].items()}
    voltage = (rep["envelope"].get("full") or {}).get("voltage") or (rep["drivetrain"].get("ocv_start") or {}).get("estimate")
    inp = StepInputs(params, est(rep["inertia_only_parameters"]), est(rep["all_estimates"]),
                     [e["name"] for e in rep["effects"]],
                     [SimpleNamespace(name=q["name"], accepted=q["accepted"]) for q in rep["parameters"]],
                     _law(rep["controller"]), dt, voltage)
    steps = [s for s in build_steps(inp, STEP_BUILDERS) if s.name == args.step and s.why is None]
    if not steps:
        print(f"ride_step_ablation: --step {args.step}: not a step that runs on {pair}", file=sys.stderr)
        return 2
    step, balance = steps[0], rep["heldout_error_augmented"]
    bal["t"] = bal["t"].round(2)
    rider = lambda **kw: default_rider(params, step.motor).replace(**kw)  # noqa: E731
    setting = {"noise3": dict(rider=rider(noise_std=3.0)), "no_preview": dict(rider=rider(anticipation=0.0)),
               "no_delay": dict(rider=rider(delay=0.0)), "lean0.4": dict(lean=0.4), "lean0.5": dict(lean=0.5),
               "no_limit": dict(lean=None), "learned": dict(learn=True)}
    print(f"{pair.name} `{step.name}`, balance fit {balance:.0f} W")
    print("| variant | total W | 2–20 s W | < 2 s W | fast-band RMS, simulated / logged | speed error m/s | notes |")
    print("| --- | --- | --- | --- | --- | --- | --- |")
    for name in args.variants:
        s = setting.get(name, {})
        simulate_module.simulate_profile = functools.partial(simulate_profile, lean_share=s.get("lean", 0.3)) \
            if "lean" in s else simulate_profile
        run = replace(step, rider=s["rider"]) if "rider" in s else step
        sim = simulate_module.simulate_ride(sig, [run], args.held, seed=0, workers=1,
                                            track_iterations=1 if s.get("learn") else 0,
                                            channels=log_channels(dt, inp.law, balance))
        tab = sim.table.assign(t=sim.table["t"].round(2)).merge(bal[["t", "P_augmented"]], on="t", how="left")
        ok = tab["scored"].astype(bool) & tab["P_augmented"].notna() & tab[f"P_{step.name}"].notna()
        d = tab.loc[ok]
        p = parts(d["P_log"].to_numpy(), d[f"P_{step.name}"].to_numpy())
        dv = float(np.sqrt(np.mean((d[f"v_{step.name}"] - d["v_log"]) ** 2)))
        said = "; ".join(n.split(": ", 1)[1][:60] for n in sim.notes if "correction" in n or "fell" in n)
        print(f"| {name} | {p['total']:.0f} | {p['mid']:.0f} | {p['fast']:.0f} | {p['fast_ratio']:.2f} | {dv:.2f} | "
              f"{said or '–'} |", flush=True)
    simulate_module.simulate_profile = simulate_profile
    return 0


if __name__ == "__main__":
    sys.exit(main())

"""Where the rider fit of a ride page falls: every design point it simulates, whether the rider fell, where.

Re-runs :func:`euc_sim.rides.rider.rider_fit.fit_rider` on a fit ride with what the ride page's
``calibrated_rider`` step gave it, read back from that page's JSON (``euc-sim ride FIT
--compare HELD --calibrate-rider --json RIDE.json``): the simulator's parameters from the
``assumptions`` (radius, total mass), the last step's motor before ``calibrated_rider``
(:func:`euc_sim.rides.sim.sim_steps.motor_from_law`), the ``drivetrain`` step's injected effects and
battery-power model, and K_t from the drivetrain fit.  Prints each design point (delay s,
bandwidth, noise N·m, fell: the seed and the time into the window's simulation, s) and the fit
or the reason it stops; writes the lot as JSON.

    PYTHONPATH=. nice -n 10 python studies/rider_fit_falls.py /tmp/lead/table3/lynx_2_to_0_calibrated/ride.json \\
        /work/shared/data/euc_core/trips/leaperkim/lynx/2/2.csv --out /tmp/h21rf/lynx_2.json

docs/rider_calibration.md, "where the rider cannot be calibrated".
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

from euc_sim.rides.source.gaps import GAP_POLICY


def fit_inputs(ride: dict) -> dict:
    """``fit_rider``'s keyword arguments as the ride page's ``calibrated_rider`` step gave them."""
    from euc_sim.rides.grids.signals import RideAssumptions
    from euc_sim.rides.drive.drivetrain import Term
    from euc_sim.rides.law.controller_report import torque_constant
    from euc_sim.rides.sim.sim_steps import motor_from_law
    from euc_sim.rides.sim.simulate import ride_params

    a = ride["assumptions"]
    steps = ride["simulation"]["steps"]
    names = [s["step"] for s in steps]
    if "calibrated_rider" not in names or "drivetrain" not in names:
        raise ValueError("simulation.steps: no 'calibrated_rider' and 'drivetrain' steps (run the page "
                         "with --calibrate-rider)")
    i = names.index("calibrated_rider")
    prev = [s for s in steps[:i] if s["ran"]][-1]
    dtv = steps[names.index("drivetrain")]
    dt = {k: Term(t.get("estimate"), t.get("ci95"), t.get("unit")) for k, t in (ride.get("drivetrain") or {}).items()}
    return {"params": ride_params(RideAssumptions(R=a["R"], total_mass=a["total_mass"], m_eq=a["m_eq"])),
            "motor": motor_from_law(prev["motor"]), "effects": dict(dtv["effects_injected"]),
            "drivetrain": dict(dtv["power_model"]),
            "assumptions": RideAssumptions(torque_constant=torque_constant(dt))}


def run(ride_json: Path, fit_log: Path, **kw) -> dict:
    """The fit with every design point recorded: ``points`` (values, ``fell``, ``fall``), ``fit`` or ``error``."""
    import euc_sim.simulation.engine as engine
    from euc_sim.report.ride.contract import rider_fit_json
    from euc_sim.rides.rider import rider_fit as rf
    from euc_sim.rides.source.logs import read_log
    from euc_sim.simulation.errors import FallError

    inputs = fit_inputs(json.loads(Path(ride_json).read_text()))
    points, last = [], {}
    simulate, features = engine.simulate, rf._simulated_features

    def recorded_simulate(*a, **k):
        try:
            return simulate(*a, **k)
        except FallError as e:
            last["fall"] = {"seed": k.get("seed"), "t": float(e.t), "quantity": e.quantity}
            raise

    def recorded_features(setup, values, rows, block):
        last.clear()
        f = features(setup, values, rows, block)
        points.append({**{k: float(v) for k, v in values.items()}, "fell": f is None, **last})
        print("   ", ", ".join(f"{k} {v:.3g}" for k, v in values.items()),
              f"fell ({last['fall']['quantity']} at {last['fall']['t']:.1f} s)" if f is None else "rode", flush=True)
        return f

    engine.simulate, rf._simulated_features = recorded_simulate, recorded_features
    t0 = time.time()
    out = {"ride": str(ride_json), "fit_log": str(fit_log), "settings": kw}
    try:
        fit = rf.fit_rider(read_log(fit_log, emit_warnings=False), progress=lambda s: print("  ", s, flush=True), **inputs, **kw)
        out["fit"] = rider_fit_json(fit)
    except rf.RiderFitError as exc:
        out["error"] = str(exc)
    finally:
        engine.simulate, rf._simulated_features = simulate, features
    out.update(points=points, seconds=round(time.time() - t0, 1))
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("ride_json", type=Path, help="the ride page's JSON (with --calibrate-rider)")
    ap.add_argument("fit_log", type=Path, help="the fit ride's log")
    ap.add_argument("--max-gap", type=float, default=GAP_POLICY.rider, help="gaps bridged, s (fit_rider's max_gap)")
    ap.add_argument("--out", type=Path, default=Path("/tmp/h21rf/rider_fit_falls.json"))
    args = ap.parse_args(argv)
    try:
        res = run(args.ride_json, args.fit_log, max_gap=args.max_gap)
    except (ValueError, OSError, KeyError) as exc:
        print(f"rider_fit_falls: {exc}", file=sys.stderr)
        return 2
    fell = sum(p["fell"] for p in res["points"])
    print(f"{fell} of {len(res['points'])} design simulations fell; "
          + (", ".join(f"{k} {v['value']:.3g} [{v['lo']:.3g}, {v['hi']:.3g}]" for k, v in res["fit"]["params"].items())
             if "fit" in res else f"no fit: {res['error']}"))
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps(res, indent=1, default=float))
    print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())

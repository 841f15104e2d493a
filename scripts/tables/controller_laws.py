"""The wheel's balance law on every shared ride: law, gains, held-out R².

    python scripts/tables/controller_laws.py [--n-boot 50] [--json OUT.json]

Reads ../shared/data/euc_core; the torque constant of each ride is the back-EMF
constant its own drivetrain fit identifies (with the wheel's spec for the radius);
the held-out R² is the other ride of the same wheel where there is one (the law
fitted on the first ride, scored on the second), else blocked within the ride.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT))

from euc_sim.rides.law.controller_report import controller_fit, torque_constant  # noqa: E402
from euc_sim.report.ride.contract import controller_json  # noqa: E402
from euc_sim.rides.drive.drivetrain_report import mass_drivetrain                  # noqa: E402
from euc_sim.rides.grids.power import MassSettings                                  # noqa: E402
from euc_sim.rides.source.logs import read_log                                        # noqa: E402
from euc_sim.rides.source.spec import wheel_spec                                      # noqa: E402

DATA = ROOT.parent / "shared" / "data" / "euc_core"


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n-boot", type=int, default=50)
    ap.add_argument("--json")
    args = ap.parse_args(argv)
    rides = sorted(DATA.glob("trips/*/*/*/[0-9].csv"))
    out = []
    for path in rides:
        wheel = path.parts[-3]
        same = [p for p in rides if p.parts[-3] == wheel and p != path]
        other = same[0] if same else None
        spec_path = DATA / "specs" / f"{wheel}.csv"
        spec = wheel_spec(str(spec_path) if spec_path.is_file() else None)
        k_t = None
        try:
            k_t = torque_constant(mass_drivetrain(read_log(path, emit_warnings=False), spec, None,
                                                  MassSettings(n_boot=20, seed=0)).terms)
        except ValueError as exc:
            print(f"{wheel}/{path.stem}: drivetrain not fitted ({exc})", file=sys.stderr)
        ctrl = controller_json(controller_fit(read_log(path, emit_warnings=False),
                                               other and read_log(other, emit_warnings=False), k_t,
                                               n_boot=args.n_boot, seed=0))
        out.append({"wheel": wheel, "ride": path.stem, "compare": other.stem if other else None,
                    "controller": ctrl})
        if ctrl["law"] is None:
            print(f"| {wheel} | {path.stem} | – | – | – | – | – | {ctrl['why'][:160]} |", flush=True)
            continue
        terms = {t["name"]: t for t in ctrl["terms"]}
        kp, kd = terms["K_p"], terms["K_d"]
        fmt = lambda t: f"{t['estimate']:,.0f} [{t['ci95'][0]:,.0f}, {t['ci95'][1]:,.0f}]"  # noqa: E731
        extra = ", ".join(n for n in terms if n not in ("K_p", "K_d", "pitch_zero"))
        h = ctrl["heldout"]
        print(f"| {wheel} | {path.stem} | {ctrl['sign']:+d} | {fmt(kp)} {kp['unit']} | {fmt(kd)} | "
              f"{extra or '–'} | {h['r2']:.3f} ({h['ride']}) | within {ctrl['within_ride']['r2']:.3f} |",
              flush=True)
    if args.json:
        Path(args.json).write_text(json.dumps(out, indent=1, default=str))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

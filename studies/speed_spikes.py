"""Found the wheel-speed spikes the battery cannot pay for on every shared log, where the simulated falls start: docs/ride_falls.md.

Wheel-speed spikes the battery cannot pay for, on every shared log.

    nice -n 10 python studies/speed_spikes.py [--n-boot 20] [--only lynx/0 ...]

For each of the 21 shared logs (``scripts/tables/ride_falls.py``'s list) it finds the total mass as
``euc-sim ride LOG --wheel SPEC`` does (the energy-balance fit, Table 3 where it gives none)
and lists :func:`euc_sim.rides.grids.profile.unpaid_spikes`: rises of the logged wheel speed whose
kinetic energy the battery and a 15 % descent cannot give (the wheel off the ground or
slipping), which the simulated ride's profile bridges.  One markdown row per log on stdout:
the mass, the spikes' count, their total span, the largest rise and the first times.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "scripts" / "tables"))


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n-boot", type=int, default=20, help="bootstrap replicates of the mass fit")
    ap.add_argument("--only", nargs="*", help="log names (e.g. lynx/0)")
    args = ap.parse_args(argv)
    import numpy as np

    from ride_falls import logs
    from euc_sim.rides.grids.profile import unpaid_spikes
    from euc_sim.rides.grids.signals import RideAssumptions
    from euc_sim.rides.grids.signals import with_found_values
    from euc_sim.rides.drive.drivetrain_report import ride_drivetrain
    from euc_sim.rides.source.logs import read_log
    from euc_sim.rides.source.spec import wheel_spec

    todo = [x for x in logs() if not args.only or x[0] in args.only]
    if args.only and len(todo) != len(args.only):
        known = {x[0] for x in logs()}
        print(f"speed_spikes: --only {next(n for n in args.only if n not in known)}: not a shared log",
              file=sys.stderr)
        return 2
    print("| log | total mass kg | spikes | span s | largest rise m/s | at t, s |")
    print("| --- | --- | --- | --- | --- | --- |")
    for name, path, spec_path in todo:
        spec = wheel_spec(spec_path) if spec_path else None
        try:
            physics = ride_drivetrain(path, None, spec, args.n_boot, 0)
            mass = with_found_values(RideAssumptions(), spec, physics[0]["total_mass"]).total_mass
        except ValueError as exc:
            print(f"| {name} | – | not read: {str(exc)[:80]} | | | |", flush=True)
            continue
        log = read_log(path, emit_warnings=False)
        sp = unpaid_spikes(log, mass)
        t, v = log.data["t"].to_numpy(), np.abs(log.data["v"].to_numpy())
        span = sum(t[b] - t[a] for a, b in sp)
        rise = max((v[a:b + 1].max() - v[a] for a, b in sp), default=0.0)
        at = ", ".join(f"{t[a]:.1f}" for a, _ in sp[:8]) + (", ..." if len(sp) > 8 else "")
        print(f"| {name} | {mass:.0f} | {len(sp)} | {span:.1f} | {rise:.2f} | {at or '–'} |", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())

"""The wheel's limit and the cut-out on every shared ride with a PWM (docs/cutout.md).

For every ride of ``../shared/data/euc_core/`` (with its wheel's spec) and the WheelLog
ride with a PWM column: the summary's ``limits`` (the log's ``speed_limit``, else the
spec's top speed) and the ride JSON's ``cutout`` as ``euc-sim ride`` computes them
(:func:`euc_sim.rides.drive.drivetrain_report.cutout_of`): the duty model's error on the
ride's second half when fitted on its first, the cut-out speeds at the ride's lowest
charge, and the danger sentence.

Usage::

    nice python scripts/tables/cutout_table.py [--only SUBSTR]
"""

from __future__ import annotations

import argparse
import warnings
from pathlib import Path

import numpy as np

SHARED = Path(__file__).resolve().parents[3] / "shared" / "data"


def row(log_path: Path, spec_path: Path | None) -> str | None:
    """One Markdown row, or None when the log has no PWM."""
    from euc_sim.rides.drive.cutout import ride_limits
    from euc_sim.rides.grids.power import MassSettings
    from euc_sim.rides.drive.drivetrain_report import analyse, cutout_of, mass_drivetrain
    from euc_sim.rides.source.logs import read_log
    from euc_sim.rides.source.spec import WheelSpec, read_spec

    log = read_log(log_path, emit_warnings=False)
    if "pwm" not in log.data:
        return None
    spec = read_spec(spec_path) if spec_path else WheelSpec()
    r = analyse(log, spec, MassSettings(n_boot=20))
    lim = ride_limits(log.counters.speed_limit_mps, spec.top_speed)
    c = cutout_of(mass_drivetrain(log, spec, fitted=r), lim)
    held = "–" if c.heldout_pwm_rmse_pct is None else f"{c.heldout_pwm_rmse_pct:.2f}"
    limit = f"{lim.speed_limit_mps * 3.6:.0f} ({lim.source})" if lim.speed_limit_mps else "–"
    if c.curves:
        lo, hi = c.charge_range or (0.0, 100.0)
        cuts = " / ".join(f"{np.interp(lo, cv.charge_pct, cv.speed_mps) * 3.6:.0f}" for cv in c.curves)
        charge = f"{lo:.0f}–{hi:.0f}"
    else:
        cuts, charge = "– (computed PWM)" if "computation" in (c.why or "") else f"– ({c.why})", "–"
    name = "/".join(log_path.parts[-4:-1]) if "trips" in log_path.parts else log_path.name
    danger = (c.danger or "–").replace(CUT_OUT, "cut-out")
    return f"| {name} | {log.layout} | {held} | {limit} | {charge} | {cuts} | {danger} |"


#: The page's words for a cut-out, shortened in the table (docs/cutout.md says so).
CUT_OUT = "the motor runs out of voltage (100 % PWM: a cut-out)"


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--only", default="", help="rides whose path contains this")
    args = ap.parse_args(argv)
    trips = sorted((SHARED / "euc_core" / "trips").glob("*/*/*/[0-9]*.csv"))
    logs = [(p, SHARED / "euc_core" / "specs" / f"{p.parts[-3]}.csv") for p in trips]
    logs += [(p, None) for p in sorted((SHARED / "wheellog").glob("*.csv"))]
    print("| ride | app | PWM held out, points | limit, km/h (source) | ride's charge, % "
          "| cut-out at the ride's lowest charge: level / 1 m/s² / 10 %, km/h | danger (the page's) |")
    print("| --- | --- | --- | --- | --- | --- | --- |")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        for log, spec in logs:
            if args.only in str(log):
                line = row(log, spec if spec is not None and spec.exists() else None)
                if line:
                    print(line, flush=True)


if __name__ == "__main__":
    main()

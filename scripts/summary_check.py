"""Agreement of the ride summary (euc_sim.rides.report.summary) with what each log itself says.

For every shared real ride (``../shared/data/euc_core`` and ``../shared/data/wheellog``)
it prints one Markdown row: our figure against the app's own counter where the log
carries one (EUC World: trip clock, trip and GPS distance, top speed, energy
counter; WheelLog: trip distance), the energy against the log's own ``power``
column, the battery used against the first and last rows' readings, and the
largest PWM against the log's column.  Usage::

    python scripts/summary_check.py [DATA_DIR]

Targets (issue text): distance 3 %, duration 1 %, energy 5 %, top speed 5 %,
PWM 1.5 points, battery 2 points.  The table is in docs/summary.md.
"""

from __future__ import annotations

import sys
import warnings
from pathlib import Path

from euc_sim.rides.report.summary import ride_summary
from euc_sim.rides.source.logs import read_log


def _pct(ours, theirs):
    if ours is None or theirs is None or theirs == 0:
        return "–"
    return f"{100.0 * (ours - theirs) / theirs:+.1f}"


def _row(path: Path, root: Path) -> str:
    log = read_log(path, emit_warnings=False)
    c = log.counters
    s = ride_summary(log)
    rel = path.relative_to(root)
    name = str(rel.parent if rel.stem.isdigit() else rel).replace("euc_core/trips/", "")
    # like with like: a GPS distance against the app's GPS counter, a wheel one against its trip counter
    same = c.gps_distance_m if s.distance_source == "gps" else c.distance_m
    bat_raw = (c.battery_start_pct - c.battery_end_pct
               if c.battery_start_pct is not None and c.battery_end_pct is not None else None)
    pwm_col = float(log.data["pwm"].max()) if "pwm" in log.data else None
    cells = [
        name, log.layout, f"{s.duration_s:.0f}", _pct(s.duration_s, c.duration_s),
        f"{s.distance_m / 1000:.2f} {s.distance_source}", _pct(s.distance_m, same),
        _pct(s.distance_speed_integral_m, c.distance_m),
        f"{s.speed_max_mps * 3.6:.1f}", _pct(s.speed_max_mps, c.speed_max_mps),
        f"{s.energy_drawn_Wh:.0f}" if s.energy_drawn_Wh is not None else "–",
        _pct(s.energy_drawn_Wh, c.power_Wh_drawn),
        _pct(None if s.energy_drawn_Wh is None else s.energy_drawn_Wh - (s.energy_regen_Wh or 0), c.energy_Wh),
        f"{s.Wh_per_km:.1f}" if s.Wh_per_km is not None else "–",
        f"{s.battery_used_pct:.0f}" if s.battery_used_pct is not None else "–",
        f"{s.battery_used_pct - bat_raw:+.0f}" if s.battery_used_pct is not None and bat_raw is not None else "–",
        f"{s.pwm_max_pct:.1f}" if s.pwm_max_pct is not None else "–",
        f"{s.pwm_max_pct - pwm_col:+.1f}" if pwm_col is not None else "–",
        str(s.alarms) if s.alarms is not None else "–", s.quality]
    return "| " + " | ".join(cells) + " |"


HEADER = ("| ride | app | duration s | vs app % | distance km | vs app (same source) % | speed integral vs trip counter % "
          "| top km/h | vs app % | drawn Wh | vs power column % | net vs energy counter % | Wh/km "
          "| battery used % | vs first−last row, points | PWM max % | vs column, points | alarms | quality |")


def main(argv: list[str]) -> int:
    root = Path(argv[0]) if argv else Path(__file__).resolve().parents[2] / "shared" / "data"
    if not root.is_dir():
        print(f"{root}: no such folder (the shared real rides)")
        return 2
    files = sorted(root.glob("euc_core/trips/*/*/*/[0-9]*.csv")) + sorted(root.glob("wheellog/*.csv"))
    print(HEADER)
    print("|" + " --- |" * (HEADER.count("|") - 1))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        for f in files:
            print(_row(f, root))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))

"""The ride summary's figures against every counter each shared log carries (docs/summary.md).

For every ride of ``../shared/data/euc_core/trips`` and ``../shared/data/wheellog`` one
Markdown row: our distance, duration, riding time, top speed, energy and PWM peak
(:func:`euc_sim.rides.summary.summary.ride_summary`, what the page and the terminal show)
and the % difference (points for the PWM) to each counter the app wrote, read here
from the CSV on its own, the way a rider checks the page against the app:

- EUC World: the trip's ``distance`` (the wheel's trip counter), ``gps_distance``,
  ``duration`` (trip clock) and ``duration_riding`` at the last row, km and s;
  ``speed_max``; ``energy_consumed`` where present; ``distance_total`` (odometer)
  last minus first; the PWM as 100 − ``safety_margin``.
- WheelLog: ``distance`` (m since the wheel's power-on), ``totaldistance`` (odometer) and
  ``gps_distance`` last minus first; the ``pwm`` column.
- Both: the log's ``power`` column integrated as the summary integrates V·I (not an
  independent check: the column is V·I); the battery reading of the first and last rows.

``follows`` is the counter the figure follows (``summary.distance_follows`` and
``duration_follows``).  Usage::

    nice python scripts/tables/counters_table.py [DATA_DIR]
"""

from __future__ import annotations

import sys
import warnings
from pathlib import Path

import numpy as np
import pandas as pd

from euc_sim.rides.summary.summary import ride_summary
from euc_sim.rides.source.logs import read_log

#: ../shared/data beside the clone (or beside the folder of worktrees)
SHARED = next((p / "shared" / "data" for p in Path(__file__).resolve().parents[3:5]
               if (p / "shared" / "data").is_dir()), Path("../shared/data"))


def _pct(ours, theirs):
    if ours is None or theirs is None or not theirs:
        return "–"
    return f"{100.0 * (ours - theirs) / theirs:+.1f}"


def _col(raw: pd.DataFrame, name: str) -> np.ndarray | None:
    if name not in raw.columns:
        return None
    x = pd.to_numeric(raw[name], errors="coerce").to_numpy(float)
    x = x[np.isfinite(x)]
    return x if x.size else None


def app_counters(path: Path, layout: str) -> dict:
    """The app's own counters of the CSV at ``path`` (m, s, m/s, Wh, %), ``None`` where absent."""
    raw = pd.read_csv(path, low_memory=False)
    raw.columns = [str(c).strip() for c in raw.columns]
    last = lambda n, k=1.0: None if (x := _col(raw, n)) is None else float(x[-1]) * k     # noqa: E731
    rise = lambda n, k=1.0: None if (x := _col(raw, n)) is None else float(x[-1] - x[0]) * k  # noqa: E731
    odo = _col(raw, "distance_total" if layout == "eucworld" else "totaldistance")
    odo = odo[odo > 0] if odo is not None else None
    out = {"odometer": float(odo[-1] - odo[0]) * (1000.0 if layout == "eucworld" else 1.0)
           if odo is not None and odo.size else None}
    if layout == "eucworld":
        sm = _col(raw, "safety_margin")
        out.update(trip=last("distance", 1000.0), gps=last("gps_distance", 1000.0),
                   clock=last("duration"), riding=last("duration_riding"),
                   top=last("speed_max", 1 / 3.6), energy=last("energy_consumed"),
                   pwm=None if sm is None else 100.0 - float(sm.min()))
    else:
        pwm = _col(raw, "pwm")
        out.update(trip=rise("distance"), gps=rise("gps_distance"), clock=None, riding=None,
                   top=None, energy=None, pwm=None if pwm is None else float(pwm.max()))
    return out


#: The ``*_follows`` sentences as the table's short words (docs/summary.md gives the legend).
SHORT = {"the app's GPS distance": "GPS", "the wheel's trip counter": "trip",
         "the wheel's speed integrated, gaps up to 60 s bridged": "speed",
         "the app's trip and riding clocks": "clocks", "the wheel's first turn to the last row": "turn",
         ", pauses left out": "−pauses"}


def _short(follows: str) -> str:
    for long, short in SHORT.items():
        follows = follows.replace(long, short)
    return follows


def row(path: Path, root: Path) -> str:
    """One Markdown row for the log at ``path``."""
    log = read_log(path, emit_warnings=False)
    c = log.counters
    s = ride_summary(log)
    a = app_counters(path, log.layout)
    rel = path.relative_to(root)
    name = str(rel.parent if rel.stem.isdigit() else rel).replace("euc_core/trips/", "")
    net = None if s.energy_drawn_Wh is None else s.energy_drawn_Wh - (s.energy_regen_Wh or 0.0)
    top = s.speed_max_mps
    bat = (c.battery_start_pct - c.battery_end_pct
           if c.battery_start_pct is not None and c.battery_end_pct is not None else None)
    if s.free_spin and a["top"] is not None:       # the app's top speed counts the wheel off the ground
        top = max(top, s.free_spin.speed_max_mps)
    cells = [
        name, log.layout,
        f"{s.distance_m / 1000:.2f}", _short(getattr(s, "distance_follows", None) or s.distance_source),
        _pct(s.distance_m, a["trip"]), _pct(s.distance_m, a["odometer"]), _pct(s.distance_m, a["gps"]),
        f"{s.duration_s:.0f}", _short(getattr(s, "duration_follows", None) or "–"),
        _pct(s.duration_s, a["clock"]),
        f"{s.moving_s:.0f}", _pct(s.moving_s, a["riding"]),
        f"{s.speed_max_mps * 3.6:.1f}", _pct(top, a["top"]),
        f"{s.energy_drawn_Wh:.0f}" if s.energy_drawn_Wh is not None else "–",
        _pct(s.energy_drawn_Wh, c.power_Wh_drawn), _pct(net, a["energy"]),
        f"{s.pwm_max_pct:.1f}" if s.pwm_max_pct is not None else "–",
        f"{s.pwm_max_pct - a['pwm']:+.1f}" if s.pwm_max_pct is not None and a["pwm"] is not None else "–",
        f"{s.battery_used_pct:.0f}" if s.battery_used_pct is not None else "–",
        f"{s.battery_used_pct - bat:+.0f}" if s.battery_used_pct is not None and bat is not None else "–"]
    return "| " + " | ".join(cells) + " |"


HEADER = ("| ride | app | km | follows | vs trip % | vs odo % | vs GPS % | s | follows | vs clock % "
          "| riding s | vs riding % | top km/h | vs app % | drawn Wh | vs power % | net vs energy % "
          "| PWM % | vs col., pt | battery % | vs rows, pt |")


def main(argv: list[str]) -> int:
    root = Path(argv[0]) if argv else SHARED
    if not root.is_dir():
        print(f"{root}: no such folder (the shared real rides)", file=sys.stderr)
        return 2
    files = sorted(root.glob("euc_core/trips/*/*/*/[0-9]*.csv")) + sorted(root.glob("wheellog/*.csv"))
    print(HEADER)
    print("|" + " --- |" * (HEADER.count("|") - 1))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        for f in files:
            print(row(f, root), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))

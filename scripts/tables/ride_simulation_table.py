"""The simulated ride step by step on every shared pair of one wheel: runs the pairs and writes the table of docs/ride_simulation.md.

    nice -n 10 python scripts/tables/ride_simulation_table.py --out /tmp/ridesim [--workers 2]
        [--n-boot 50] [--pairs lynx,v9] [--doc docs/ride_simulation.md]
        [--calibrate-rider lynx_0_to_2,v9_0_to_1]

For each ordered pair of rides of one wheel (Lynx 0↔2, V9 0↔1↔2, Blitz 1↔2↔4,
Master Pro 3↔6; both directions) it runs ``euc-sim ride FIT --compare HELD --wheel
W.csv`` (fit on one ride, simulated along the other) into ``OUT/WHEEL_FIT_to_HELD/``
(``ride.json``, the ride page), each pair in its own process (``--workers`` at a time),
and writes the table of ``simulation.steps`` (held-out battery-power error of each
step, its ratio to the balance fit's held-out error against the 1.2× target, phase
current, pitch and PWM errors, falls) to ``--doc`` (default ``OUT/ride_simulation.md``).
A pair whose ``ride.json`` already exists is read, not run again (``--again`` reruns).
Rows of an existing ``--doc`` whose pairs this run does not produce (other wheels, or pairs
not run) are kept as they are, in their place, and so are the commands that made them: a
run of one wheel (``--pairs blitz``) adds its rows to the table of the others.
``--calibrate-rider PAIRS`` also runs the named pairs with ``euc-sim ride --calibrate-rider``
(into ``OUT/PAIR_calibrated/``, an extra row each: minutes per ride).  A hand-written
section of ``--doc`` from its ``## Reading the table`` heading on is kept as it is.
Reads ``../shared/data/euc_core`` (``--data``).
"""

from __future__ import annotations

import argparse
import json
import math
import os
import re
import subprocess
import sys
import time
from concurrent.futures import ThreadPoolExecutor, as_completed
from itertools import permutations
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
DATA = ROOT.parent / "shared" / "data" / "euc_core"

#: wheel -> (trip folder under trips/, spec file stem, rides).
WHEELS = {"lynx": ("leaperkim/lynx", "lynx", ("0", "2")),
          "v9": ("inmotion/v9", "v9", ("0", "1", "2")),
          "blitz": ("begode/blitz", "blitz", ("1", "2", "4")),
          "master_pro_V2": ("begode/master_pro_V2", "master_pro_V2", ("3", "6"))}
STEPS = ("nominal", "measured_law", "calibrated_rider", "drivetrain")
TARGET = 1.2


def pairs(data: Path, wheels) -> list[dict]:
    """Every ordered pair (fit, held-out) of the wheels' shared rides."""
    out = []
    for w in wheels:
        folder, spec, rides = WHEELS[w]
        for a, b in permutations(rides, 2):
            out.append({"wheel": w, "fit": a, "held": b, "name": f"{w}_{a}_to_{b}",
                        "fit_log": data / "trips" / folder / a / f"{a}.csv",
                        "held_log": data / "trips" / folder / b / f"{b}.csv",
                        "spec": data / "specs" / f"{spec}.csv"})
    return out


def calibrated(todo: list[dict], names) -> list[dict]:
    """Copies of the named pairs run with ``--calibrate-rider`` (name ``PAIR_calibrated``).

    Raises
    ------
    ValueError
        naming a pair not among ``todo``.
    """
    by = {p["name"]: p for p in todo}
    bad = [n for n in names if n not in by]
    if bad:
        raise ValueError(f"--calibrate-rider {bad[0]}: not a pair of the wheels run "
                         f"(valid: {', '.join(by)})")
    return [dict(by[n], name=f"{n}_calibrated", calibrated=True) for n in names]


def command(p: dict, out: Path, n_boot: int, seed: int) -> list[str]:
    """The ``euc-sim ride`` command of one pair."""
    d = out / p["name"]
    return [sys.executable, "-m", "euc_sim.cli", "ride", str(p["fit_log"]), "--compare",
            str(p["held_log"]), "--wheel", str(p["spec"]), "--report", str(d / "report"),
            "--json", str(d / "ride.json"), "--n-boot", str(n_boot), "--seed", str(seed),
            "--workers", "1", "--simulate"] + (["--calibrate-rider"] if p.get("calibrated") else [])


def run_pair(p: dict, out: Path, n_boot: int, seed: int, again: bool, run: bool = True) -> dict:
    """Run (or read) one pair; returns ``{"pair", "seconds", "json" | "error"}``."""
    d = out / p["name"]
    js = d / "ride.json"
    if js.is_file() and not again:
        return {"pair": p, "seconds": None, "json": json.loads(js.read_text())}
    if not run:
        return {"pair": p, "seconds": None, "error": "not run (no ride.json yet)"}
    d.mkdir(parents=True, exist_ok=True)
    env = dict(os.environ, PYTHONPATH=str(ROOT), MPLBACKEND="Agg")
    t0 = time.perf_counter()
    with open(d / "stderr.txt", "w") as err:
        rc = subprocess.run(command(p, out, n_boot, seed), stdout=subprocess.DEVNULL, stderr=err,
                            env=env, cwd=str(ROOT)).returncode
    sec = time.perf_counter() - t0
    if rc != 0 or not js.is_file():
        tail = (d / "stderr.txt").read_text().strip().splitlines()[-1:] or ["no output"]
        return {"pair": p, "seconds": sec, "error": f"failed, exit {rc}: {tail[0][:200]}"}
    return {"pair": p, "seconds": sec, "json": json.loads(js.read_text())}


def _f(x, fmt: str, unit: str = "", scale: float = 1.0) -> str:
    return "–" if x is None or not math.isfinite(x) else f"{x * scale:{fmt}}{unit}"


def rows(results: list[dict]) -> list[str]:
    """The markdown table: one row per pair, the steps' battery-power errors and ratios."""
    head = ("| wheel | fit → held out | balance fit W | " + " | ".join(
        f"{s} W (×)" for s in STEPS) + " | best step: phase current A / pitch ° / PWM pts | "
        "scored (share of the held-out ride) | falls |")
    md = [head, "|" + " --- |" * (6 + len(STEPS))]
    for r in results:
        p = r["pair"]
        label = f"{p['fit']} → {p['held']}" + (" (calibrated rider)" if p.get("calibrated") else "")
        if "error" in r:
            md.append(f"| {p['wheel']} | {label} | {r['error']} |"
                      + " |" * (3 + len(STEPS)))
            continue
        rep = r["json"]
        sim = rep.get("simulation") or {}
        bal = rep.get("heldout_error_augmented")
        by = {s["step"]: s for s in sim.get("steps", [])}
        share = next((re.search(r"\((\d+) of (\d+) scored rows\)", n) for n in sim.get("notes", [])
                      if "first fall ended a run" in n), None)
        cells = []
        for name in STEPS:
            st = by.get(name)
            if st is None:
                cells.append("–")
            elif not st["ran"]:
                cells.append("skipped")
            else:
                e, ratio = st["heldout_rmse"].get("P_W"), st.get("ratio_to_balance")
                mark = "**" if ratio is not None and ratio <= TARGET and share is None else ""
                cells.append(f"{_f(e, ',.0f')} ({mark}{_f(ratio, '.2f')}{mark})")
        ran = [s for s in sim.get("steps", []) if s["ran"] and "P_W" in s["heldout_rmse"]]
        best = min(ran, key=lambda s: s["heldout_rmse"]["P_W"]) if ran else None
        pitch = _f(best['heldout_rmse'].get('pitch_rad'), '.2f', '', 180 / math.pi) if best else "–"
        if "pitch_scored_rows" not in sim and pitch != "–":
            pitch = "(all rows, not riding rows)"       # run before the riding-row scoring
        other = "–" if best is None else (
            f"{best['step']}: {_f(best['heldout_rmse'].get('I_phase_A'), '.1f')} / {pitch} / "
            f"{_f(best['heldout_rmse'].get('pwm_pct'), '.1f')}")
        falls = "; ".join(f"{f['run']} at {f['t']:.0f} s ({f['cause'].split(' exceeds')[0].replace('|', '')})"
                          for f in sim.get("falls", [])) or ("none" if sim else "not simulated")
        scored = (f"{int(share[1]) / 10:.0f} s ({100 * int(share[1]) / max(int(share[2]), 1):.0f} %)"
                  if share else f"{sim.get('scored_rows', 0) / 10:.0f} s (100 %)")
        md.append(f"| {p['wheel']} | {label} | {_f(bal, ',.0f')} | "
                  + " | ".join(cells) + f" | {other} | {scored} | {falls} |")
    return md


def band_rows(results: list[dict]) -> list[str]:
    """The level-and-spectrum table: per pair and step, the band ratios to the log's."""
    from euc_sim.rides.grids.rider_features import BandRatio
    from euc_sim.report.ride.page import bands_cell

    md = ["| wheel | fit → held out | " + " | ".join(f"{s} dB" for s in STEPS) + " |",
          "|" + " --- |" * (2 + len(STEPS))]
    for r in results:
        p = r["pair"]
        label = f"{p['fit']} → {p['held']}" + (" (calibrated rider)" if p.get("calibrated") else "")
        by = {s["step"]: s for s in ((r.get("json") or {}).get("simulation") or {}).get("steps", [])}
        cells = []
        for name in STEPS:
            bands = (by.get(name) or {}).get("heldout_bands")
            cells.append(bands_cell(bands and {k: BandRatio(**b) for k, b in bands.items()}))
        md.append(f"| {p['wheel']} | {label} | " + " | ".join(cells) + " |")
    return md


BAND_MARK = "**Level and spectrum**"
BAND_TEXT = (
    BAND_MARK + " (`simulation.steps[].heldout_bands`): each step's battery power against the "
    "log's, on the scored rows read at the log's stamps, split into the rider fit's eight bands "
    "(Savitzky–Golay windows 0.5 … 6 s, ~2 Hz to ~0.1 Hz; `rider_features.band_ratio_db`). A cell is "
    "the RMS over the bands of 20·log10(simulated / logged band RMS), dB, of battery power (P; in "
    "brackets the fastest and slowest band's ratio), phase current (I) and pitch (riding rows) "
    "where HELD logs them: 0 dB is the log's level and spectrum, ±6 dB twice or half its swing. "
    "Unlike the RMS error it does not penalise noise that is right but drawn independently.")


HAND = "## Reading the table"


COMMAND = "    nice -n 10 python scripts/tables/ride_simulation_table.py "


def _row_key(line: str) -> tuple[str, str] | None:
    """(wheel, 'fit → held[ (calibrated rider)]') of a table row, None for other lines."""
    cells = [c.strip() for c in line.strip().strip("|").split("|")]
    if not line.startswith("| ") or len(cells) < 3 or not re.match(r"\d+ → \d+", cells[1]):
        return None                         # not a row of a pair (the header: "fit → held out")
    return cells[0], cells[1]


def merge_rows(old_text: str, new_rows: list[str]) -> list[str]:
    """The table rows: ``old_text``'s rows in their order, each replaced by the new row of the
    same pair unless that one says 'not run' (then the old row is kept); new pairs appended."""
    new = {_row_key(r): r for r in new_rows if _row_key(r)}
    order, old = [], {}
    for line in old_text.splitlines():
        k = _row_key(line)
        if k and k not in old:
            order.append(k)
            old[k] = line
    order += [k for k in new if k not in old]

    def pick(k):
        if k in new and not (k in old and "| not run" in new[k]):
            return new[k]
        return old[k]
    return [pick(k) for k in order]


def _met(rows_: list[str]) -> list[str]:
    """'PAIR step' of every bold (within-target, whole-ride) cell of the rows."""
    out = []
    for line in rows_:
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        fit, _, held = cells[1].split(" (")[0].partition(" → ")
        name = f"{cells[0]}_{fit}_to_{held}" + ("_calibrated" if "calibrated" in cells[1] else "")
        out += [f"{name} {s}" for s, c in zip(STEPS, cells[3:3 + len(STEPS)]) if "**" in c]
    return out


def write_doc(path: Path, results: list[dict], argv: list[str], seconds: float = 0.0) -> None:
    """``docs/ride_simulation.md``: the table, its commands, what the figures are.

    Rows of the existing doc that this run does not produce are kept (:func:`merge_rows`),
    with the commands that made them."""
    old_text = path.read_text(encoding="utf-8") if path.is_file() else ""
    cut = old_text.find(HAND)
    table_text = old_text if cut < 0 else old_text[:cut]
    table_text, _, band_text = table_text.partition(BAND_MARK)
    table = rows(results)
    merged = merge_rows(table_text, table[2:])
    bands = band_rows(results)
    merged_bands = merge_rows(band_text, bands[2:])
    cmd = COMMAND + " ".join(argv)
    commands = [ln for ln in table_text.splitlines() if ln.startswith(COMMAND) and ln != cmd] + [cmd]
    met = _met(merged)
    n_ok = sum(not any(w in r for w in ("| not run", "| failed")) for r in merged)
    text = "\n".join([
        "# The simulated ride against the log, step by step", "",
        "Each row: `euc-sim ride FIT --compare HELD --wheel W.csv`: the balance fit, the wheel's "
        "law and the drivetrain fitted on FIT, then the MuJoCo rider riding HELD's logged speed "
        "profile once per step (`simulation.steps`, `euc_sim/rides/sim/sim_steps.py`). A cell is the "
        "step's held-out battery-power RMS error (W) and its ratio to the balance fit's held-out "
        f"error on HELD (bold: within {TARGET}× over the whole held-out ride; never bold after a fall). "
        "Steps: `nominal` (paper PD 600 / 40, default rider, no effects), `measured_law` (the firmware "
        "law measured on FIT), `calibrated_rider` (delay, bandwidth and motor noise fitted on FIT; "
        "rows marked 'calibrated rider', `--calibrate-rider`), `drivetrain` (voltage-limited motor, "
        "accepted effects as physics and losses added to the battery power). The rider rides the "
        "band-limited profile (`envelope.plan_band_limit`), then the plan learned through his "
        "inverted loop (`plan_learning.py`); each channel is read as the log is written "
        "(`reading.py`). Phase current, pitch (riding rows, > 1 m/s) and PWM errors are the best "
        "step's. All steps are scored on the rows all rode (`scored`: up to the first fall).", "",
        "Command" + ("s (a later run adds its rows to the earlier ones; the rows it "
                     "does not run are kept):" if len(commands) > 1 else ":"), "",
        *commands, "",
        f"{n_ok} of {len(merged)} rows ran; {len(met)} cells within the target (bold).", "",
        "**Tuning figures.** Every model is fitted on FIT and scored on HELD. The law's thresholds "
        "were set on synthetic rides (docs/controller.md); the plan learning on Lynx 0 → 2 (the Lynx "
        "rows are tuning figures; V9, Blitz, Master Pro chose none of its constants); the band limit "
        "has no fitted constant but was written after looking at the falls of Master Pro 3 → 6, "
        "6 → 3, Blitz 1 → 4, 2 → 4 and Lynx 2 → 0 (docs/ride_falls.md). Held-back rides are the test.", "",
    ] + table[:2] + merged + ["", BAND_TEXT, "", *bands[:2], *merged_bands, ""]) + (
        "" if cut < 0 else "\n" + old_text[cut:])
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_suffix(path.suffix + ".tmp")
    tmp.write_text(text, encoding="utf-8")
    os.replace(tmp, path)


def main(argv=None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", required=True, help="folder for the pairs' JSON and pages")
    ap.add_argument("--data", default=str(DATA), help="the euc_core data folder")
    ap.add_argument("--workers", type=int, default=1, help="pairs run at a time (processes)")
    ap.add_argument("--n-boot", type=int, default=50)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--pairs", default=",".join(WHEELS), help=f"wheels, of {', '.join(WHEELS)}")
    ap.add_argument("--doc", help="markdown table to write (default OUT/ride_simulation.md)")
    ap.add_argument("--again", action="store_true", help="rerun pairs whose ride.json exists")
    ap.add_argument("--calibrate-rider", default="",
                    help="pairs (e.g. lynx_0_to_2,v9_0_to_1) also run with --calibrate-rider")
    ap.add_argument("--no-run", action="store_true",
                    help="run nothing: write the table of the pairs whose ride.json exists")
    args = ap.parse_args(argv)
    wheels = [w for w in args.pairs.split(",") if w]
    bad = [w for w in wheels if w not in WHEELS]
    if bad or args.workers < 1:
        print(f"ride_simulation_table: --pairs {','.join(bad)} unknown (valid: {', '.join(WHEELS)})"
              if bad else f"ride_simulation_table: --workers must be at least 1, got {args.workers}",
              file=sys.stderr)
        return 2
    data, out = Path(args.data), Path(args.out)
    todo = pairs(data, wheels)
    try:
        todo += calibrated(todo, [n for n in args.calibrate_rider.split(",") if n])
    except ValueError as exc:
        print(f"ride_simulation_table: {exc}", file=sys.stderr)
        return 2
    missing = [str(p[k]) for p in todo for k in ("fit_log", "held_log", "spec") if not p[k].is_file()]
    if missing:
        print(f"ride_simulation_table: {missing[0]}: no such file", file=sys.stderr)
        return 2
    from tqdm import tqdm

    t0 = time.perf_counter()
    done = {}
    with ThreadPoolExecutor(args.workers) as pool, \
            tqdm(total=len(todo), desc="pairs", unit="pair", file=sys.stderr) as bar:
        futs = {pool.submit(run_pair, p, out, args.n_boot, args.seed, args.again, not args.no_run): p
                for p in todo}
        for fut in as_completed(futs):
            r = fut.result()
            done[r["pair"]["name"]] = r
            sec = "" if r["seconds"] is None else f" in {r['seconds']:.0f} s"
            bar.write(f"{r['pair']['name']}: " + ("error " + r["error"] if "error" in r else "done")
                      + sec, file=sys.stderr)
            bar.update(1)
    results = [done[p["name"]] for p in todo]
    doc = Path(args.doc) if args.doc else out / "ride_simulation.md"
    write_doc(doc, results, [a for a in argv if a not in ("--again", "--no-run")], time.perf_counter() - t0)
    print("\n".join(rows(results)))
    print(f"written {doc}", file=sys.stderr)
    return 0 if all("json" in r for r in results) else 1


if __name__ == "__main__":
    sys.exit(main())

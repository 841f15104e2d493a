"""Real pairs of rides of one wheel: what ``ride A --compare B`` says differs, against the logs' metadata.

For every pair of shared rides of the same wheel (euc_core ``trips/BRAND/MODEL/N``,
each with its ``meta.csv``: rider weight, tyre pressure, temperature, wind; and
the WheelLog pair, which records none of these) the command::

    nice euc-sim ride A --compare B --no-simulate --wheel SPEC --rider-weight KG_A --json F

is run (a JSON already in ``--work`` is read, not redone) and each difference is
set against what the metadata record (B minus A):

- ``total_mass``: the recorded rider weights' difference (kg);
- ``internal_resistance``: the ambient temperatures' difference (the WheelLog
  pair: its logged ``system_temp``, the controller's, a proxy), and, where both
  logs have it (``internal_resistance@pack``), the logged pack temperature's
  (EUC World ``temp_batt``, median over the ride) through the
  pack's Arrhenius law (:func:`euc_sim.rides.drive.battery.to_25C`), from A's fitted
  resistance (a colder ride needs more);
- ``rolling_resistance``: the tyre pressures through C_rr ∝ p^(−1/2) (a rough
  law for pneumatic tyres, from A's fitted C_rr; a softer tyre rolls harder);
- ``aerodynamic_drag``: the recorded wind (low / mid; no direction), direction only;
- ``speed_scale``: the tyre pressures, direction only (a softer tyre rolls on a
  smaller radius: less ground per logged metre);
- ``current_delay``: the logging app.

Verdict per parameter, on what the tool says (named or not): **agree** when a
named difference's interval holds the recorded change (or it goes the recorded
direction: "direction only"), or nothing is named and nothing changed;
**disagree** when a named difference's interval misses the recorded change or
goes against it, or a recorded change larger than what the pair resolves was
not named and lies outside the interval; "interval only" where nothing is named
but an interval excluding zero holds (agree) or excludes (disagree) the recorded
change; **cannot tell** otherwise: the recorded change smaller than what the
pair resolves, nothing recorded that sizes it, or a difference named that
nothing recorded would cause.  What the pair resolves is the JSON's
``resolvable`` for the difference (the larger of the interval's half-width and
the naming test's 80 %-power size, :mod:`euc_sim.rides.compare.resolution`), read, never
recomputed here.

Usage::

    python studies/real_pairs.py --work /tmp/real_pairs [--rides v9 blitz wheellog] [--out docs/real_pairs.md]

Progress lines go to the terminal only (stderr, when it is one).  Written up in
docs/real_pairs.md.
"""

from __future__ import annotations

import argparse
import csv
import itertools
import json
import math
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path

from euc_sim.rides.drive.battery import to_25C
from euc_sim.rides.grids.power import RHO_AIR

#: The shared data beside the repository (``--data`` elsewhere).
DATA = Path(__file__).resolve().parents[2] / "shared" / "data"
#: Parameters tabulated, in order.
SHOWN = ("total_mass", "internal_resistance", "internal_resistance@pack", "rolling_resistance",
         "aerodynamic_drag", "speed_scale", "current_delay")
#: Wind words of meta.csv, ordered.
WIND = {"none": 0, "low": 1, "mid": 2, "high": 3}


@dataclass(frozen=True)
class Ride:
    """One shared ride and what its metadata record (None where not recorded)."""

    label: str
    wheel: str
    path: Path
    spec: Path | None
    date: str
    rider_kg: float | None = None
    pressure_bar: float | None = None
    temperature_C: float | None = None
    wind: str | None = None
    app: str | None = None
    pack_C: float | None = None


def _first_date(path: Path) -> str:
    with open(path, newline="") as f:
        row = next(csv.DictReader(f))
    return (row.get("datetime") or row.get("date") or "")[:10]


def _logged_temperature(path: Path, column: str = "system_temp") -> float | None:
    """The median of a logged temperature (°C; zeros and blanks left out), None where not logged."""
    import numpy as np

    with open(path, newline="") as f:
        t = [float(r[column]) for r in csv.DictReader(f) if r.get(column) not in (None, "", "0", "0.0")]
    return float(np.median(t)) if t else None


def _meta(folder: Path) -> dict:
    with open(folder / "meta.csv", newline="") as f:
        m = next(csv.DictReader(f))
    num = (lambda k: float(m[k]) if m.get(k) not in (None, "") else None)
    return {"rider_kg": num("rider_weight"), "pressure_bar": num("tire_pressure"),
            "temperature_C": num("temperature"), "wind": m.get("wind") or None, "app": m.get("app") or None}


def shared_rides(data: Path) -> list[Ride]:
    """Every euc_core ride with its meta.csv, and the two WheelLog rides of one wheel."""
    out = []
    for log in sorted((data / "euc_core" / "trips").glob("*/*/*/*.csv")):
        if log.name == "meta.csv":
            continue
        wheel = log.parents[1].name
        spec = data / "euc_core" / "specs" / f"{wheel}.csv"
        out.append(Ride(f"{wheel}_{log.parent.name}", wheel, log, spec if spec.exists() else None,
                        _first_date(log), **_meta(log.parent), pack_C=_logged_temperature(log, "temp_batt")))
    wl = data / "wheellog"
    for name in ("2020_05_16_08_02_06.csv", "2020_05_28_07_52_00.csv"):
        if (wl / name).exists():
            out.append(Ride(f"wheellog_{name[5:10]}", "wheellog", wl / name, None, _first_date(wl / name),
                            temperature_C=_logged_temperature(wl / name), app="wheel_log"))
    return out


def pairs(rides: list[Ride], wheels=None) -> list[tuple[Ride, Ride]]:
    """Every pair (earlier label first) of rides of one wheel, optionally of ``wheels`` only."""
    by: dict[str, list[Ride]] = {}
    for r in rides:
        if wheels is None or r.wheel in wheels:
            by.setdefault(r.wheel, []).append(r)
    return [p for rs in by.values() for p in itertools.combinations(rs, 2)]


def command(a: Ride, b: Ride, out: Path) -> list[str]:
    """The ``euc-sim ride`` command of one pair (nice'd)."""
    cmd = ["nice", sys.executable, "-m", "euc_sim.cli", "ride", str(a.path), "--compare", str(b.path),
           "--no-simulate", "--quiet", "--json", str(out)]
    if a.spec is not None:
        cmd += ["--wheel", str(a.spec)]
    if a.rider_kg is not None:
        cmd += ["--rider-weight", f"{a.rider_kg:g}"]
    return cmd


def _progress(msg: str) -> None:
    if sys.stderr.isatty():
        print(msg, file=sys.stderr, flush=True)


def run_pair(a: Ride, b: Ride, work: Path) -> dict:
    """The pair's ride JSON (run once; read from ``work`` after)."""
    js = work / f"{a.label}__{b.label}.json"
    if not js.exists():
        _progress(f"real_pairs: {a.label} --compare {b.label} ...")
        subprocess.run(command(a, b, js), check=True, stdout=subprocess.DEVNULL)
    return json.loads(js.read_text())


# ---------------------------------------------------------------- what the metadata expect
def _log_estimate(rep: dict, name: str) -> float | None:
    for p in rep.get("parameters") or []:
        if p.get("name") == name and p.get("estimate") is not None:
            return float(p["estimate"])
    if name == "internal_resistance":
        return ((rep.get("drivetrain") or {}).get("internal_resistance") or {}).get("estimate")
    return None


def expected(name: str, a: Ride, b: Ride, rep: dict) -> tuple[float | None, int | None, str]:
    """(expected B − A in the difference's unit or None, expected sign or None, what the metadata record)."""
    if name == "total_mass" and a.rider_kg is not None and b.rider_kg is not None:
        return b.rider_kg - a.rider_kg, None, f"rider {a.rider_kg:g} → {b.rider_kg:g} kg"
    if name == "internal_resistance" and a.temperature_C is not None and b.temperature_C is not None:
        r = _log_estimate(rep, name)
        said = (("logged controller " if a.wheel == "wheellog" else "ambient ")
                + f"{a.temperature_C:g} → {b.temperature_C:g} °C")
        if r is None or r <= 0:
            return None, None, said
        # R(T) from A's fitted R at A's temperature (both through 25 °C, Arrhenius)
        r_b = r * to_25C(1.0, a.temperature_C) / to_25C(1.0, b.temperature_C)
        return r_b - r, None, said
    if name == "internal_resistance@pack" and a.pack_C is not None and b.pack_C is not None:
        r = _log_estimate(rep, "internal_resistance")
        said = f"logged pack {a.pack_C:.0f} → {b.pack_C:.0f} °C (median)"
        if r is None or r <= 0:
            return None, None, said
        return r * to_25C(1.0, a.pack_C) / to_25C(1.0, b.pack_C) - r, None, said
    if name == "rolling_resistance" and a.pressure_bar and b.pressure_bar:
        c = _log_estimate(rep, name)
        said = f"tyre {a.pressure_bar:g} → {b.pressure_bar:g} bar"
        if c is None:
            return None, None, said
        return c * (math.sqrt(a.pressure_bar / b.pressure_bar) - 1.0), None, said
    if name == "speed_scale" and a.pressure_bar and b.pressure_bar:
        s = b.pressure_bar - a.pressure_bar      # a softer tyre rolls on a smaller radius: less ground
        return None, (s > 0) - (s < 0), f"tyre {a.pressure_bar:g} → {b.pressure_bar:g} bar"
    if name == "aerodynamic_drag" and a.wind and b.wind:
        s = WIND.get(b.wind, 0) - WIND.get(a.wind, 0)
        return None, (s > 0) - (s < 0), f"wind {a.wind} → {b.wind}"
    if name == "current_delay" and a.app and b.app:
        return None, None, f"app {a.app} → {b.app}"
    return None, None, "not recorded"


def verdict(d: dict, exp: float | None, sign: int | None, said: str) -> str:
    """agree / disagree / cannot tell for what the tool says (named or not), with the reason."""
    est, ci, named, res = d.get("estimate"), d.get("ci95"), bool(d.get("named")), d.get("resolvable")
    if est is None or not ci:
        return "cannot tell: " + ("not estimated on both rides" if est is None else "no interval")
    inside = exp is not None and ci[0] <= exp <= ci[1]
    if exp == 0.0 or (exp is None and sign == 0):
        return ("cannot tell: named, while the metadata record no change (a cause they do not record?)"
                if named else "agree: no change recorded, none named")
    if named and exp is not None:
        return "agree: the recorded change lies inside the interval" if inside else \
            "disagree: the recorded change lies outside the interval"
    if named and sign:
        return ("agree (direction only): named the way the recorded change goes" if sign * est > 0 else
                "disagree: named opposite to the recorded change")
    if named:
        return f"cannot tell: named, but nothing recorded ({said}) would cause it"
    if exp is not None and inside and (ci[0] > 0 or ci[1] < 0):
        return "agree (interval only): not named, but its interval excludes zero and holds the recorded change"
    if exp is not None and res is None:
        return "cannot tell: the JSON gives no resolution for this difference"
    if exp is not None and abs(exp) > res:
        return ("cannot tell: not named, the recorded change inside the interval" if inside else
                "disagree: not named, the recorded change should have been seen")
    if exp is not None and not inside and (ci[0] > 0 or ci[1] < 0):
        return "disagree (interval only): not named, but its interval excludes both zero and the recorded change"
    if exp is not None:
        return f"cannot tell: the recorded change is below what the pair resolves (±{res:.3g})"
    return "cannot tell: " + ("a change recorded without a size, none named" if sign else "nothing recorded sizes it")


def pair_rows(a: Ride, b: Ride, rep: dict) -> list[dict]:
    """One row per tabulated parameter of one pair."""
    diffs = {d["name"]: d for d in rep.get("differences") or []}
    rows = []
    for name in SHOWN:
        d = diffs.get(name.split("@")[0])
        if d is None or (name.endswith("@pack") and (a.pack_C is None or b.pack_C is None)):
            continue
        exp, sign, said = expected(name, a, b, rep)
        ci = d.get("ci95")
        rows.append({"pair": f"{a.label} → {b.label}", "dates": f"{a.date} → {b.date}", "name": name,
                     "estimate": d.get("estimate"), "ci95": ci, "unit": d.get("unit"),
                     "named": bool(d.get("named")), "aliases": d.get("aliases") or [],
                     "resolvable": d.get("resolvable"), "resolution": d.get("resolution"),
                     "excludes_zero": bool(ci) and (ci[0] > 0 or ci[1] < 0),
                     "recorded": said, "expected": exp, "verdict": verdict(d, exp, sign, said)})
    return rows


# ---------------------------------------------------------------- the write-up
def _g(x, nd: int = 3) -> str:
    return "–" if x is None else f"{x:+.{nd}g}"


def table(rows: list[dict]) -> list[str]:
    """The Markdown table of :func:`pair_rows` rows."""
    out = ["| pair (A → B) | dates | parameter | B − A | 95 % interval | resolves | named | aliases | metadata | "
           "expected from metadata | verdict |", "|" + " --- |" * 11]
    rows = [r for r in rows if r["estimate"] is not None]
    for r in rows:
        ci = r["ci95"]
        out.append(f"| {r['pair']} | {r['dates']} | {r['name']} | {_g(r['estimate'])} {r['unit']} | "
                   + (f"{ci[0]:+.3g} to {ci[1]:+.3g}" + (" (excl. 0)" if r["excludes_zero"] else "") if ci else "–")
                   + f" | {'±' + _u(r['resolvable']) if r.get('resolvable') is not None else '–'}"
                   + f" | {'**yes**' if r['named'] else 'no'} | {', '.join(r['aliases']) or '–'} | "
                   f"{r['recorded']} | {_g(r['expected'])} | {r['verdict']} |")
    return out


#: Verdicts the doc's table leaves out (the counts keep them): nothing to compare.
QUIET = ("agree: no change recorded, none named", "cannot tell: nothing recorded sizes it")


def doc_table(rows: list[dict]) -> list[str]:
    """:func:`table` without its dates column and without the rows whose verdict is in :data:`QUIET`."""
    keep = [r for r in rows if r["verdict"] not in QUIET]
    return [ln.replace(" dates |", "", 1).replace(" --- |", "", 1) if i < 2 else
            "|".join(c for k, c in enumerate(ln.split("|")) if k != 2)
            for i, ln in enumerate(table(keep))]


def tally(rows: list[dict]) -> dict:
    """Verdicts counted: over every row and over the named differences."""
    out: dict = {"all": {}, "named": {}}
    for r in rows:
        v = r["verdict"].split(":")[0]
        out["all"][v] = out["all"].get(v, 0) + 1
        if r["named"]:
            out["named"][v] = out["named"].get(v, 0) + 1
    return out


def _u(x) -> str:
    return "–" if x is None else f"{x:.3g}"


def resolution_table(rows: list[dict], name: str = "total_mass") -> list[str]:
    """Per pair: the smallest ``name`` difference the pair can name (``resolvable``: the larger of the
    interval's half-width and the naming test's 80 %-power size), beside the estimate and the recorded change."""
    out = ["| pair (A → B) | B − A | 95 % interval | resolvable | of which: half-width; 80 %-power size | named | "
           "recorded change |", "|" + " --- |" * 7]
    for r in rows:
        if r["name"] != name or r["estimate"] is None or not r["ci95"]:
            continue
        det = r.get("resolution") or {}
        out.append(f"| {r['pair']} | {_g(r['estimate'])} {r['unit']} | {r['ci95'][0]:+.3g} to {r['ci95'][1]:+.3g} | "
                   + (f"±{r['resolvable']:.3g} {r['unit']}" if r.get("resolvable") is not None else "–")
                   + f" | {_u(det.get('interval_halfwidth'))}; {_u(det.get('gate'))} | "
                   f"{'**yes**' if r['named'] else 'no'} | {_g(r['expected'])} |")
    return out


#: Per-pair resolution columns: (parameter, header, factor from the JSON's unit to the shown one).
RESOLVES = (("total_mass", "mass (kg)", 1.0), ("aerodynamic_drag", "C_dA (m²)", 2.0 / RHO_AIR),
            ("rolling_resistance", "C_rr", 1.0), ("internal_resistance", "battery R (mΩ)", 1e3),
            ("speed_scale", "speed scale (%)", 100.0), ("current_delay", "current delay (s)", 1.0))


def resolves_table(rows: list[dict]) -> list[str]:
    """Per pair, what it can resolve (the JSON's ``resolvable``, ±) of each parameter, in the shown units
    (C_dA = 2k/ρ from the drag coefficient k = ½ρC_dA, kg/m)."""
    by: dict[str, dict] = {}
    for r in rows:
        by.setdefault(r["pair"], {})[r["name"]] = r.get("resolvable")
    out = ["| pair (A → B) | " + " | ".join(h for _, h, _ in RESOLVES) + " |", "|" + " --- |" * (len(RESOLVES) + 1)]
    for pair, res in by.items():
        out.append(f"| {pair} | " + " | ".join("–" if res.get(n) is None else f"±{f * res[n]:.3g}"
                                               for n, _, f in RESOLVES) + " |")
    return out


BEGIN, END = "<!-- generated by studies/real_pairs.py -->", "<!-- end of the generated part -->"


def write_doc(rows: list[dict], cmds: list[str], path: Path) -> None:
    """docs/real_pairs.md's generated part (counts, the table, the commands), written between
    :data:`BEGIN` and :data:`END`; the text around them is kept."""
    t = tally(rows)
    md = [BEGIN, "",
          f"Pairs: {len({r['pair'] for r in rows})}; rows: {len(rows)}; verdicts over every row: "
          + ", ".join(f"{k} {v}" for k, v in sorted(t['all'].items()))
          + "; over the named differences: "
          + (", ".join(f"{k} {v}" for k, v in sorted(t['named'].items())) or "none named") + ".", ""]
    md += ["What each pair can resolve: the smallest difference it can name (the JSON's `resolvable`, the "
           "larger of the 95 % interval's half-width and the naming test's 80 %-power size):", ""]
    md += resolves_table(rows) + [""]
    md += ["Each difference of each pair but those with nothing to compare (no change recorded and none "
           "named, or nothing recorded that sizes it; counted above):", ""]
    md += doc_table(rows) + ["", "One run per pair (run from the repository, the shared data beside it), "
                             "the first of them:", "", "```"]
    md += cmds[:1] + ["```", "", END]
    old = path.read_text() if path.exists() else f"{BEGIN}\n{END}\n"
    head, _, rest = old.partition(BEGIN)
    path.write_text(head + "\n".join(md) + rest.partition(END)[2])


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--data", default=str(DATA), help="the shared data folder (euc_core/, wheellog/)")
    p.add_argument("--work", required=True, help="folder for the runs' JSON")
    p.add_argument("--rides", nargs="+", help="wheels to run (e.g. v9 blitz wheellog; default every one)")
    p.add_argument("--out", help="write the table and commands here (Markdown)")
    args = p.parse_args(argv)
    work = Path(args.work)
    work.mkdir(parents=True, exist_ok=True)
    rows, cmds = [], []
    for a, b in pairs(shared_rides(Path(args.data)), args.rides):
        rep = run_pair(a, b, work)
        rows += pair_rows(a, b, rep)
        cmd = command(a, b, Path(f"{a.label}__{b.label}.json"))[4:]
        cmds.append(" ".join(["euc-sim"] + cmd).replace(str(Path(args.data)), "../shared/data"))
    (work / "rows.json").write_text(json.dumps(rows, indent=1))
    if args.out:
        write_doc(rows, cmds, Path(args.out))
    print("\n".join(table(rows)))
    print("\n".join(["", "Mass: what each pair resolves", ""] + resolution_table(rows)))
    print("\n".join(["", "What each pair resolves", ""] + resolves_table(rows)))
    return 0


if __name__ == "__main__":
    sys.exit(main())

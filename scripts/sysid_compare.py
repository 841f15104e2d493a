#!/usr/bin/env python
"""h by three methods on the same recordings: equation error, our rollout, ``mujoco.sysid``.

Each seed S is the recording of ``euc-sim simulate --maneuver deceleration --duration 15
--seed S`` (paper noise; the rider's own 3 N·m motor noise, so every seed is its own
ride; truth h = 0.6 m).  Each file is then identified

- by the equation error of eqs. 9-10 (``euc-sim identify``'s default, with its
  block-bootstrap-plus-noise interval),
- by :func:`euc_sim.identification.rollout_fit.fit_rollout` (``--method rollout``),
- by :func:`euc_sim.identification.sysid_fit.fit_sysid` (MuJoCo's ``mujoco.sysid``,
  the same 1 s windows with free initial states; interval from its
  ``calculate_intervals``), with the model memoised by h (``--sysid-build spec``:
  recompiled for every finite-difference column, the toolbox's default).

Prints one line per recording and method as it goes, then per method: mean and sd of
the error, coverage of 0.6 m, mean width, mean and largest time, and how often each
rollout h lies inside the equation-error interval.

    python scripts/sysid_compare.py [--seeds 1 2 3 4 5 6] [--json F] [--sysid-build memo|spec]

Needs the ``mujoco[sysid]`` extra (``pip install -e '.[sysid]'``).  Times are wall
clock of one process; report the load average beside them.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

H_TRUE = 0.6
METHODS = ("equation", "rollout", "sysid")


def record(seed: int, folder: Path) -> Path:
    """``euc-sim simulate --maneuver deceleration --duration 15 --seed S`` into ``folder``."""
    out = folder / f"decel-{seed}.csv"
    env = dict(os.environ, PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    subprocess.run([sys.executable, "-m", "euc_sim.cli", "simulate", "--maneuver", "deceleration",
                    "--duration", "15", "--seed", str(seed), "--out", str(out)],
                   check=True, stdout=subprocess.DEVNULL, env=env)
    return out


def compare(path: Path, build: str = "memo") -> dict:
    """The three fits of one recording: {method: {h, ci, seconds}}."""
    from euc_sim.identification.h_fit import load
    from euc_sim.identification.processing import DEFAULT_SMOOTHING
    from euc_sim.identification.h_fit import identify_recordings
    from euc_sim.identification.rollout_fit import fit_rollout
    from euc_sim.identification.sysid_fit import fit_sysid

    rec = load(path, DEFAULT_SMOOTHING)
    t0 = time.perf_counter()
    eq = identify_recordings([rec])["pooled"]["3dof"]          # the CLI's defaults
    out = {"equation": {"h": eq.h, "ci": list(eq.h_ci95), "seconds": time.perf_counter() - t0}}
    ro = fit_rollout(rec.df, rec.kin, rec.params, h0=eq.h)
    out["rollout"] = {"h": ro.h, "ci": list(ro.h_ci95), "seconds": ro.seconds, "at_bound": ro.at_bound}
    sy = fit_sysid(rec.df, rec.kin, rec.params, h0=eq.h, fast=(build == "memo"))
    out["sysid"] = {"h": sy.h, "ci": list(sy.h_ci95), "seconds": sy.seconds, "at_bound": sy.at_bound}
    return out


def summarize(rows: list[dict]) -> dict:
    """Per method: error mean/sd (mm), coverage of H_TRUE, mean width (mm), time (s)."""
    import numpy as np

    out = {}
    for m in METHODS:
        h = np.array([r[m]["h"] for r in rows])
        ci = np.array([r[m]["ci"] for r in rows])
        s = np.array([r[m]["seconds"] for r in rows])
        out[m] = {"n": len(rows), "mean_err_mm": 1e3 * float(np.mean(h - H_TRUE)),
                  "sd_mm": 1e3 * float(np.std(h, ddof=1)) if len(h) > 1 else float("nan"),
                  "covered": int(np.sum((ci[:, 0] <= H_TRUE) & (H_TRUE <= ci[:, 1]))),
                  "width_mm": 1e3 * float(np.mean(ci[:, 1] - ci[:, 0])),
                  "seconds_mean": float(np.mean(s)), "seconds_max": float(np.max(s))}
        if m != "equation":
            eq = np.array([r["equation"]["ci"] for r in rows])
            out[m]["inside_equation_ci"] = int(np.sum((eq[:, 0] <= h) & (h <= eq[:, 1])))
            out[m]["overlap_equation_ci"] = int(np.sum((ci[:, 0] <= eq[:, 1]) & (eq[:, 0] <= ci[:, 1])))
    d = np.array([r["sysid"]["h"] - r["rollout"]["h"] for r in rows])
    out["sysid_minus_rollout_mm"] = {"max_abs": 1e3 * float(np.max(np.abs(d)))}
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--seeds", type=int, nargs="+", default=[1, 2, 3, 4, 5, 6])
    ap.add_argument("--sysid-build", choices=("memo", "spec"), default="memo",
                    help="memo: compiled model memoised by h (default); spec: the toolbox's "
                         "default, the spec recompiled for every finite-difference column")
    ap.add_argument("--json", default=None, metavar="F")
    args = ap.parse_args(argv)
    from euc_sim.identification.sysid_fit import MISSING_EXTRA, sysid_available

    if not sysid_available():
        print(f"error: {MISSING_EXTRA}", file=sys.stderr)
        return 2
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for seed in args.seeds:
            path = record(seed, Path(tmp))
            r = compare(path, args.sysid_build)
            r["seed"] = seed
            rows.append(r)
            for m in METHODS:
                f = r[m]
                hit = "holds" if f["ci"][0] <= H_TRUE <= f["ci"][1] else "MISSES"
                print(f"seed {seed:>4} {m:<8} h = {f['h']:.4f} m [{f['ci'][0]:.4f}, {f['ci'][1]:.4f}] "
                      f"{hit} 0.6  {f['seconds']:6.1f} s", flush=True)
    summ = summarize(rows)
    print(f"\n{'method':<9} {'n':>3} {'mean err mm':>11} {'sd mm':>6} {'holds 0.6':>9} "
          f"{'width mm':>8} {'s mean':>6} {'s max':>6} {'in eq. CI':>9}")
    for m in METHODS:
        s = summ[m]
        inside = f"{s['inside_equation_ci']}/{s['n']}" if "inside_equation_ci" in s else "-"
        print(f"{m:<9} {s['n']:>3} {s['mean_err_mm']:>+11.2f} {s['sd_mm']:>6.2f} "
              f"{s['covered']:>5}/{s['n']:<3} {s['width_mm']:>8.2f} {s['seconds_mean']:>6.1f} "
              f"{s['seconds_max']:>6.1f} {inside:>9}")
    print(f"largest |h_sysid − h_rollout|: {summ['sysid_minus_rollout_mm']['max_abs']:.3f} mm; "
          f"load average {os.getloadavg()[0]:.1f} on {os.cpu_count()} cores")
    if args.json:
        Path(args.json).write_text(json.dumps({"rows": rows, "summary": summ}, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())

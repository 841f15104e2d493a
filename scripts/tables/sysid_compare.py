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
  recompiled for every finite-difference column, the toolbox's default; ``plain``: the
  toolbox's documented path with only the hook free initial states need, :func:`plain_sysid`).

Prints one line per recording and method as it goes, then per method: mean and sd of
the error, coverage of 0.6 m, mean width, mean and largest time, and how often each
rollout h lies inside the equation-error interval.

    python scripts/tables/sysid_compare.py [--seeds 1 2 3 4 5 6] [--json F] [--sysid-build memo|spec|plain]

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

ROOT = Path(__file__).resolve().parents[2]
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
    if build == "plain":
        out["sysid"] = plain_sysid(rec, eq.h)
        return out
    sy = fit_sysid(rec.df, rec.kin, rec.params, h0=eq.h, fast=(build == "memo"))
    out["sysid"] = {"h": sy.h, "ci": list(sy.h_ci95), "seconds": sy.seconds, "at_bound": sy.at_bound}
    return out


def plain_sysid(rec, h0: float) -> dict:
    """The toolbox's documented path with only the hook free initial states require.

    ``build_residual_fn`` (its ``residual`` loops over the windows), one ``Parameter`` per
    window state, the spec recompiled per column, every window rolled out for every
    column (no memo), the default BLAS threads.  The residual is still (q_sim − q_rec)/σ
    (``modify_residual``), so the estimator is the one of ``fit_sysid``: only the
    engineering differs.
    """
    import io

    import mujoco.sysid as ms
    import numpy as np
    from mujoco import rollout as mj_rollout

    from euc_sim.identification import sysid_fit as sf
    from euc_sim.model.mujoco_model import from_mujoco

    from absl import logging as absl_logging
    absl_logging.set_verbosity(absl_logging.ERROR)      # one warning per window otherwise

    t0 = time.perf_counter()
    prob = sf._Problem(ms, rec.df, rec.kin, rec.params, h0, 0.1, 1.5, sf.WINDOW, fast=False)
    s0 = prob.params["window_states"].value
    params = ms.ParameterDict()
    params.add(prob.params["h"])
    for w in range(prob.n_win):
        params.add(ms.Parameter(f"s{w:02d}", s0[w], s0[w] - sf.STATE_SPAN, s0[w] + sf.STATE_SPAN))

    def rollout_hook(models, datas, control_signal, initial_states, param_dicts, **kw):
        n_chunk = len(models) // len(param_dicts)
        ws = [prob.window_of[id(u)] for u in control_signal]
        x0 = np.stack([prob.full_state(param_dicts[i // n_chunk][f"s{w:02d}"].value, prob.t[prob.idx[w, 0]])
                       for i, w in enumerate(ws)])
        state, _ = mj_rollout.rollout(list(models), datas, x0, np.stack([u.data[:-1] for u in control_signal]))
        out = []
        for m, u, w, st, x in zip(models, control_signal, ws, state, x0):
            full = np.concatenate([x[None, :], st], axis=0)
            q, _, _ = from_mujoco(prob.index, full[:, 1:1 + prob.model0.nq])
            times = prob.t[prob.idx[w]]
            out.append(ms.SystemTrajectory(model=m, control=u, sensordata=ms.TimeSeries(times, q),
                                           initial_state=x, state=ms.TimeSeries(times, full)))
        return out

    fn = ms.build_residual_fn(models_sequences=[prob.seqs], custom_rollout=rollout_hook,
                              modify_residual=prob.modify_residual, resample_true=False)
    x_scale = np.concatenate([[sf._SCALE_H], np.tile(sf._SCALE_S, prob.n_win)])
    opt, res = ms.optimize(params, fn, optimizer="mujoco", verbose=False, max_iters=sf.MAX_ITER,
                           x_scale=x_scale, output=io.StringIO())
    r_star, _, _ = fn(opt.as_vector(), opt.copy())
    _, half = ms.calculate_intervals(r_star, np.asarray(res.jac))
    h = float(opt["h"].value[0])
    return {"h": h, "ci": [h - float(half[0]), h + float(half[0])], "seconds": time.perf_counter() - t0}


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
    ap.add_argument("--sysid-build", choices=("memo", "spec", "plain"), default="memo",
                    help="memo: fit_sysid, compiled model memoised by h (default); spec: "
                         "fit_sysid with the toolbox's default build, the spec recompiled for "
                         "every finite-difference column; plain: the toolbox's documented "
                         "path with only the free-initial-state hook (plain_sysid)")
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

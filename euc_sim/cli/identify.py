"""The ``euc-sim torques`` and ``euc-sim identify`` commands (registered in :mod:`euc_sim.cli.app`)."""

from __future__ import annotations

import argparse
import math
from pathlib import Path

import numpy as np

from euc_sim import api
from euc_sim.cli.common import UsageError, param_values, parse_params, seed
from euc_sim.cli.options import bounded
from euc_sim.identification.base_params import identify_base_parameters
from euc_sim.identification.controller_fit import identify_controller, identify_rider_delay
from euc_sim.identification.h_fit import BOOTSTRAP_BLOCK, load
from euc_sim.identification.processing import MAX_ORDER, Smoothing
from euc_sim.identification.recordings import params_from_meta, read_sidecar
from euc_sim.identification.torques import torques
from euc_sim.io import FLOAT_FORMAT, atomic_write, check_writable, save_figure, sidecar_paths, write_json
from euc_sim.model.parameters import PLAUSIBLE

__all__ = ["add_torques_parser", "add_identify_parser", "cmd_torques", "cmd_identify"]


def _add_smoothing_arguments(p: argparse.ArgumentParser) -> None:
    """Options shared by ``torques`` and ``identify``."""
    g = p.add_argument_group("smoothing and processing")
    g.add_argument("--smoothing", choices=("consistent", "savgol"), default="consistent",
                   help="consistent: short Savitzky-Golay derivatives + one Gaussian filter on "
                        "every torque term (default); savgol: the paper's recipe")

    g.add_argument("--window", type=bounded(0.005, 10.0, unit="s"), metavar="S",
                   help="Savitzky-Golay window, s (default 0.25 consistent, 1.0 savgol)")
    g.add_argument("--order", type=bounded(2, MAX_ORDER, integer=True), metavar="N",
                   help="Savitzky-Golay order (default 5 consistent, 3 savgol)")
    g.add_argument("--term-sigma", type=bounded(0.0, 10.0, unit="s"), default=0.3, metavar="S",
                   help="Gaussian term filter's standard deviation, s (consistent; default 0.3)")
    g.add_argument("--source", choices=("auto", "state", "mocap"), default="auto",
                   help="use x, gamma, phi (state) or the motion-capture columns (Section 2)")
    g.add_argument("--phi-from", choices=("A", "C"), default="A",
                   help="Section 2: phi as the direction ankle A -> G (exact, CONTRACT's phi; "
                        "default) or by the paper's eq. (3) from the wheel centre C")
    g.add_argument("--d-ce", type=bounded(0.01, 2.0, unit="m"), metavar="M",
                   help="C-E distance for motion-capture files without C columns, m")
    g.add_argument("--param", action="append", metavar="NAME=VALUE",
                   help="override a parameter (else the sidecar's, else Table 3)")


def _load(path: str, args: argparse.Namespace, h: float | None = None):
    meta = read_sidecar(path)
    params_from_meta(meta, sidecar_paths(path)[0])     # the sidecar's values, naming it
    parse_params(args.param)                          # --param's, naming the parameter
    values = dict(meta.get("params") or {})
    values.update(param_values(args.param))
    if h is not None:
        values["h"] = h
    p = params_from_meta({"params": values}, path)
    smoothing = Smoothing(method=args.smoothing, window=args.window, order=args.order, term_sigma=args.term_sigma)
    return load(path, smoothing, params=p, d_CE=args.d_ce,
                phi_from=args.phi_from, source=args.source)


# --- torques -----------------------------------------------------------------------------
def add_torques_parser(sub) -> argparse.ArgumentParser:
    p = sub.add_parser("torques", help="driving and ankle torques from a recording (eqs. 9, 10, 13)")
    p.add_argument("recording", help="CONTRACT recording (CSV or Parquet)")

    p.add_argument("--h", type=bounded(*PLAUSIBLE["h"], unit="m"), metavar="M",
                   help="rider's CoG height, m (default: the sidecar's h, else Table 3's 0.6 m)")
    p.add_argument("--out", required=True, metavar="FILE",
                   help="CSV with t, M_d1, M_d2, M_h, M_d1_2dof, M_d2_2dof (N·m) and valid "
                        "(0 on the edge samples where the filters lack support, 1 elsewhere)")
    _add_smoothing_arguments(p)
    p.set_defaults(func=cmd_torques)
    return p


def cmd_torques(args: argparse.Namespace) -> int:
    """Write the five torque estimates of one recording as CSV, ``valid`` 0 within a filter's half-width of either
    end (:attr:`Kinematics.interior`)."""
    check_writable(args.out)
    rec = _load(args.recording, args, h=args.h)
    T = torques(rec.kin, rec.params)
    sl = rec.kin.interior
    valid = np.zeros(len(T), dtype=int)
    valid[sl] = 1                      # 0: within a filter's half-width of either end
    T = T.assign(valid=valid)
    atomic_write(args.out, lambda path: T.to_csv(path, index=False, float_format=FLOAT_FORMAT))
    d = (T["M_d1"] - T["M_d2"]).to_numpy()[sl]
    print(f"{rec.name}: h = {rec.params.h:.4g} m, {len(T)} samples; "
          f"RMSE(M_d1 - M_d2) = {float((d**2).mean() ** 0.5):.4g} N·m on the "
          f"{len(d)} interior samples (valid = 1; the {len(T) - len(d)} edge samples, valid = 0, "
          f"lack filter support); wrote {args.out}")
    return 0


# --- identify ------------------------------------------------------------------------------
def add_identify_parser(sub) -> argparse.ArgumentParser:
    p = sub.add_parser("identify", help="identify the rider's CoG height h (and more) from recordings")
    p.add_argument("recordings", nargs="+", help="CONTRACT recordings (CSV or Parquet)")
    p.add_argument("--json", metavar="FILE", help="write the results (CONTRACT's identify form)")
    p.add_argument("--report", metavar="DIR",
                   help="write the figures into DIR: Fig. 8 (RMSE against h) as identify.png; "
                        "ALSO writes Figs. 6/7 beside it, identify-torques.png (one recording) "
                        "or identify-torques-REC.png (one per recording); every file written "
                        "is printed")

    p.add_argument("--h-min", type=bounded(*PLAUSIBLE["h"], unit="m"), default=0.1, metavar="M",
                   help="search bound, m")
    p.add_argument("--h-max", type=bounded(*PLAUSIBLE["h"], unit="m"), default=1.5, metavar="M",
                   help="search bound, m")
    p.add_argument("--n-boot", type=bounded(0, 100_000, integer=True), default=400, metavar="N",
                   help="block-bootstrap replicates for the 95%% interval (default 400, at most 100000)")
    p.add_argument("--block", type=bounded(0.01, 3600.0, unit="s"), default=None, metavar="S",
                   help="bootstrap block, s (default 1 s, about the correlation time of the "
                        "filtered residual)")
    p.add_argument("--seed", type=seed, default=0,
                   help="seed of the bootstrap draws, a non-negative integer (default 0)")
    p.add_argument("--noise-replicates", type=bounded(0, 1000, integer=True), default=None, metavar="N",
                   help="replicates with fresh measurement noise that widen the 95%% interval "
                        "(default 40, at most 1000; 0: the block bootstrap alone)")
    p.add_argument("--method", choices=("equation", "rollout", "sysid"), default="equation",
                   help="equation: h by the equation error of eqs. 9-10 (default); rollout: "
                        "also h by the simulation error of 1 s MuJoCo rollouts with free initial "
                        "states, where the recordings carry M_d and M_h (3-DoF model); sysid: the "
                        "same fit done by MuJoCo's mujoco.sysid (needs the euc-sim[sysid] extra)")
    _add_smoothing_arguments(p)
    p.set_defaults(func=cmd_identify)
    return p


def _figure_paths(report: Path, names: list[str]) -> list[Path]:
    """Figs. 6/7 in ``--report DIR``: ``identify-torques.png`` for one recording, ``identify-torques-REC.png``
    (numbered where two recordings share a name) for several."""
    if len(names) == 1:
        return [report / "identify-torques.png"]
    stems = [Path(n).stem for n in names]
    tags = [s if stems.count(s) == 1 else f"{s}-{i + 1}" for i, s in enumerate(stems)]
    return [report / f"identify-torques-{t}.png" for t in tags]


def cmd_identify(args: argparse.Namespace) -> int:
    """Identify h (both models, per recording and pooled), the controller and the rider."""
    if args.json:
        check_writable(args.json)
    report = Path(args.report) if args.report else None
    if report:
        check_writable(report / "identify.png")
    from euc_sim.identification.noise_bootstrap import N_REPLICATES  # deferred: loads scipy.signal (1.0 s)
    n_noise = N_REPLICATES if args.noise_replicates is None else args.noise_replicates
    block = BOOTSTRAP_BLOCK if args.block is None else args.block
    if not args.h_min < args.h_max:
        raise UsageError(f"need 0 < --h-min < --h-max, got {args.h_min} and {args.h_max}")
    if args.method == "sysid":
        from euc_sim.identification.sysid_fit import MISSING_EXTRA, sysid_available  # deferred: loads scipy.signal (0.9 s)

        if not sysid_available():
            raise UsageError(MISSING_EXTRA)
    names = [str(r) for r in args.recordings]
    if len(set(names)) != len(names):
        raise UsageError("a recording is given twice")
    recs = [_load(n, args) for n in names]
    res = api.identify(recs, bounds=(args.h_min, args.h_max), n_boot=args.n_boot,
                       block=block, seed=args.seed, n_noise=n_noise)
    pooled, per = res.models, list(res.per_recording)

    per_json, riders, figures = _per_recording(report, names, recs, per)
    if report:
        from euc_sim.identification.plots import rmse_curves_figure  # deferred: loads matplotlib (0.2 s)

        figures.insert(0, str(save_figure(rmse_curves_figure(names, per, pooled), report / "identify.png")))

    h_per = [rec.params.replace(h=fits["3dof"].h) for rec, fits in zip(recs, per)]
    controller = identify_controller([r.kin for r in recs], h_per)
    bound_hits = _at_bound(names, per, pooled, riders)
    out = {
        "recordings": names,
        "models": {m: f.as_json() for m, f in pooled.items()},
        "controller": controller.as_json(),
        "per_recording": per_json,
        "smoothing": recs[0].kin.smoothing.describe(),
        "bounds": [args.h_min, args.h_max],
        "bootstrap": {"replicates": args.n_boot, "block_s": block, "seed": args.seed,
                      "noise_replicates": n_noise},
        "figures": figures,
        "at_bound": [key for key, _ in bound_hits],
    }
    if args.method in ("rollout", "sysid"):
        _rollout(args, report, recs, per, per_json, out)
        for prefix, entry in [(f"per_recording[{i}].", e) for i, e in enumerate(per_json)] + [("", out)]:
            out["at_bound"] += [f"{prefix}models.3dof.{q}" for q in entry["models"]["3dof"]["at_bound"]
                                if q.startswith(f"{args.method}.")]
    _print_results(names, recs, per, pooled, per_json, controller, riders)
    for sentence in dict.fromkeys(s for _, s in bound_hits):
        print(f"WARNING: {sentence}")
    if args.json:
        write_json(args.json, out)
    for f in figures:
        print(f"wrote {f}")
    return 0


def _per_recording(report: Path | None, names: list[str], recs: list, per: list[dict]):
    """Each recording's JSON entry (models, controller, rider, base parameters), its rider
    fit, and the Figs. 6/7 written into ``report``: (entries, rider fits, figure paths)."""
    per_json, riders, figures = [], [], []
    fig_paths = _figure_paths(report, names) if report else [None] * len(recs)
    for rec, fits, fig_path in zip(recs, per, fig_paths):
        p_h = rec.params.replace(h=fits["3dof"].h)
        riders.append(identify_rider_delay(rec.kin, p_h))
        entry = {"recording": rec.name,
                 "models": {m: f.as_json() for m, f in fits.items()},
                 "controller": identify_controller(rec.kin, p_h).as_json(),
                 "rider": riders[-1].as_json()}
        if "M_d" in rec.df.columns:
            M_h = rec.df["M_h"].to_numpy() if "M_h" in rec.df.columns else None
            entry["base_parameters"] = identify_base_parameters(
                rec.kin, rec.df["M_d"].to_numpy(), M_h, rec.params).as_json()
        per_json.append(entry)
        if fig_path is not None:
            from euc_sim.identification.plots import recording_figure  # deferred: loads matplotlib (0.2 s)

            figures.append(str(save_figure(recording_figure(rec, torques(rec.kin, p_h), fits["3dof"]), fig_path)))
    return per_json, riders, figures


def _at_bound(names: list[str], per: list[dict], pooled: dict, riders: list) -> list[tuple[str, str]]:
    """Every fitted quantity that ends on its search bound: (JSON path, e.g. ``models.3dof.h``, a sentence)."""
    hits = []
    what = {"h": "h = {h:.3f} m lies on the search bound [{lo:g}, {hi:g}] m: it is a bound, "
                 "not a minimum (widen --h-min/--h-max or use a ride that identifies h)",
            "h_ci95": "the 95% interval of h [{c0:.3f}, {c1:.3f}] m is cut off by the search bound "
                      "[{lo:g}, {hi:g}] m: the true interval is wider"}

    def h_hits(prefix: str, label: str, fits: dict) -> None:
        for m, f in fits.items():
            for q in f.at_bound():
                text = what[q].format(h=f.h, c0=f.h_ci95[0], c1=f.h_ci95[1],
                                      lo=float(f.h_grid[0]), hi=float(f.h_grid[-1]))
                hits.append((f"{prefix}models.{m}.{q}", f"{label} {m}: {text}"))

    for i, (name, fits, rider) in enumerate(zip(names, per, riders)):
        label = Path(name).name
        h_hits(f"per_recording[{i}].", label, fits)
        if rider.at_bound:
            lo, hi = float(rider.delay_curve[0][0]), float(rider.delay_curve[0][-1])
            hits.append((f"per_recording[{i}].rider.delay",
                         f"{label}: rider delay {rider.delay:.3f} s lies on the search bound "
                         f"[{lo:g}, {hi:g}] s: it is a bound, not an estimate, and the rider's "
                         f"law (R² {rider.r2:.3f}) is the bounded fit's"))
    h_hits("", "pooled" if len(names) > 1 else Path(names[0]).name, pooled)
    return hits


def _rollout(args, report: Path | None, recs: list, per: list[dict], per_json: list[dict], out: dict) -> None:
    """``--method rollout`` / ``sysid``: h by simulation error per recording, pooled by inverse variance, into the
    JSON, printed and drawn into ``report``."""
    from euc_sim.identification.rollout_fit import fit_rollout  # deferred: loads scipy.signal (1.0 s)
    from euc_sim.identification.sysid_fit import fit_sysid  # deferred: loads scipy.signal (0.9 s)

    key = args.method
    fit = fit_rollout if key == "rollout" else fit_sysid
    label = "rollout" if key == "rollout" else "mujoco.sysid"

    for rec in recs:
        missing = [c for c in ("M_d", "M_h", "x", "gamma", "phi") if c not in rec.df.columns]
        if missing:
            raise UsageError(f"{rec.name}: --method {key} needs column {missing[0]!r} "
                             f"(both recorded torques M_d, M_h and the states x, gamma, phi)")
    fits = []
    for rec, f, entry in zip(recs, per, per_json):
        r = fit(rec.df, rec.kin, rec.params, h0=f["3dof"].h, bounds=(args.h_min, args.h_max))
        fits.append(r)
        m = entry["models"]["3dof"]
        m[key] = r.as_json()
        m.setdefault("at_bound", []).extend(f"{key}.{q}" for q in r.at_bound)
        warn = f"  WARNING: h ends on its search bound [{args.h_min}, {args.h_max}] m" if r.at_bound else ""
        print(f"{Path(rec.name).name}: {label} h = {r.h:.4f} m [{r.h_ci95[0]:.4f}, {r.h_ci95[1]:.4f}] "
              f"({r.windows} windows of 1 s, {r.seconds:.1f} s; largest |correlation| of h with a "
              f"window state {m[key]['max_abs_correlation_h']:.2f}){warn}")
        if report:
            from euc_sim.identification.plots import rollout_figure  # deferred: loads matplotlib (0.2 s)

            tag = "" if len(recs) == 1 else f"-{Path(rec.name).stem}"
            fig = save_figure(rollout_figure(rec.name, r, tool="MuJoCo" if key == "rollout" else "mujoco.sysid"),
                              report / f"identify-{key}{tag}.png")
            out["figures"].append(str(fig))
    w = [1.0 / max(((r.h_ci95[1] - r.h_ci95[0]) / 3.92) ** 2, 1e-18) for r in fits]
    h = sum(wi * r.h for wi, r in zip(w, fits)) / sum(w)
    sd = math.sqrt(1.0 / sum(w))
    pooled_json = {"h": h, "h_ci95": [h - 1.96 * sd, h + 1.96 * sd],
                   "seconds": sum(r.seconds for r in fits), "windows": sum(r.windows for r in fits),
                   "at_bound": sorted({q for r in fits for q in r.at_bound})}
    m = out["models"]["3dof"]
    m[key] = pooled_json
    m.setdefault("at_bound", []).extend(f"{key}.{q}" for q in pooled_json["at_bound"])


def _print_results(names: list[str], recs: list, per: list[dict], pooled: dict, per_json: list[dict],
                   controller, riders: list) -> None:
    """The table of h per recording and pooled, and the controller and rider laws, on stdout."""
    print(f"{'recording':<32} {'model':<5} {'h [m]':>7} {'95% interval [m]':>18} "
          f"{'RMSE [N·m]':>10}  identifiable")
    rows = [(Path(n).name, f) for n, f in zip(names, per)]
    if len(recs) > 1:
        rows.append(("pooled", pooled))
    for label, fits in rows:
        for m, f in fits.items():
            ci = f"[{f.h_ci95[0]:.3f}, {f.h_ci95[1]:.3f}]"
            print(f"{label[:32]:<32} {m:<5} {f.h:7.3f} {ci:>18} {f.rmse:10.4g}  "
                  f"{'yes' if f.identifiable else 'NO: ' + f.reason}")
    for rec, e, rider in zip(recs, per_json, riders):
        g = e["controller"]["gains"]
        r = e["rider"]
        print(f"{Path(rec.name).name}: controller K_p = {g['gamma']:.4g} N·m/rad, "
              f"K_d = {g['gamma_d']:.4g} N·m·s/rad (R² {e['controller']['r2']:.3f}); "
              f"rider delay {r['delay']:.3f} s (R² {r['r2']:.3f})"
              f"{' AT THE SEARCH BOUND' if rider.at_bound else ''}")
    if len(recs) > 1:
        g = controller.gains
        print(f"pooled: controller K_p = {g['gamma']:.4g} N·m/rad, K_d = {g['gamma_d']:.4g} "
              f"N·m·s/rad (R² {controller.r2:.3f})")

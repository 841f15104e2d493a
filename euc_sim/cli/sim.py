"""``euc-sim simulate``, ``euc-sim dataset`` and ``euc-sim stability`` (registered by :func:`add_commands`)."""

from __future__ import annotations

import argparse
import json
import math
import time
from pathlib import Path

import numpy as np

from euc_sim import api
from euc_sim.cli.common import parse_params, say, seed
from euc_sim.cli.options import bounded, deprecated, one_of, workers
from euc_sim.cli.spatial import simulate_3d_command
from euc_sim.controllers.motor import MotorPD
from euc_sim.controllers.rider import DEFAULT_RIDER_NOISE
from euc_sim.errors import InputError
from euc_sim.io import check_writable, write_json
from euc_sim.model.mujoco_model import VARIANTS
from euc_sim.model.parameters import PLAUSIBLE
from euc_sim.rides.source.sanity import SPEC_RANGE
from euc_sim.simulation import effects as fx
from euc_sim.simulation.drift import cog_height, parse_drift_shape
from euc_sim.simulation.effects import bounds_text, names as effect_names
from euc_sim.simulation.engine import ENGINES, default_rider
from euc_sim.simulation.maneuvers import MANEUVERS, load_speed_profile, make_maneuver
from euc_sim.simulation.mocap import NOISE_LEVELS
from euc_sim.simulation.spatial import PATHS

__all__ = ["add_commands", "DURATION", "RIDER_NOISE"]

#: ``--duration`` of a simulated recording: from a tenth of a second (a few control steps)
#: to an hour (a recording's rows grow with it, and its run time).
DURATION = bounded(0.1, 3600.0, unit="s")
#: ``--rider-noise``: the rider's motor noise, N·m; beyond 100 N·m (a third of the motor's
#: torque) no rider stays on the wheel.
RIDER_NOISE = bounded(0.0, 100.0, unit="N·m")


def format_eigenvalues(ev, digits: int = 3) -> str:
    """Eigenvalues (complex, or (re, im) pairs), 1/s, for people: ``-4.22, 0, ±5.86j, -30.1 ± 5.41j``.

    Parts below 1e-9 of the largest magnitude print as 0; a conjugate pair prints once, with ±.
    """
    z = np.array([complex(*e) if isinstance(e, (tuple, list)) else complex(e) for e in ev])
    tol = 1e-9 * max(1.0, float(np.abs(z).max(initial=0.0)))
    re = np.where(np.abs(z.real) < tol, 0.0, z.real) + 0.0     # + 0.0 turns -0.0 into 0.0
    im = np.where(np.abs(z.imag) < tol, 0.0, z.imag) + 0.0
    out, used = [], np.zeros(len(z), bool)
    for i in np.argsort(re, kind="stable"):
        if used[i] or im[i] < 0 and any(not used[j] and im[j] == -im[i] and re[j] == re[i]
                                        for j in range(len(z)) if j != i):
            continue
        used[i] = True
        r = f"{re[i]:.{digits}g}"
        if im[i] == 0:
            out.append(r)
            continue
        pair = [j for j in range(len(z)) if not used[j] and re[j] == re[i] and im[j] == -im[i]]
        sign = "±" if pair else ("+" if im[i] > 0 else "−")
        for j in pair[:1]:
            used[j] = True
        mag = f"{abs(im[i]):.{digits}g}j"
        out.append(f"{sign}{mag}" if re[i] == 0 else f"{r} {sign} {mag}")
    return ", ".join(out)


def _effects(items) -> dict[str, float]:
    out: dict[str, float] = {}
    for item in items or ():
        name, value = fx.parse_assignment(item)
        if name in out:
            raise InputError(f"--effect {name} given twice")
        out[name] = value
    return out


def _check_choice(option: str, value: str, valid) -> None:
    if value not in valid:
        raise InputError(f"{option}: unknown value {value!r}; valid: {', '.join(valid)}")


def _motor(args, R: float = 0.2, p=None):
    """The balance law: the options' PD or, with ``--drivetrain RIDE.json``, the PD under the ride's voltage limit
    (:func:`euc_sim.controllers.firmware.voltage_limit_settings`), replaced by the wheel's measured law where the
    ride shows one (its ``controller``, :func:`euc_sim.controllers.firmware.firmware_motor`)."""
    lim = {}
    if getattr(args, "drivetrain", None):
        from euc_sim.controllers.firmware import FirmwareError, firmware_motor, law_terms, voltage_limit_settings  # deferred: loads scipy.optimize (0.4 s)

        path = args.drivetrain
        try:
            rep = json.loads(Path(path).read_text(encoding="utf-8"))
        except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
            raise InputError(f"--drivetrain {path}: not a readable ride JSON ({exc})") from None
        try:
            lim = voltage_limit_settings(rep, R, args.battery_voltage)
            ctrl = rep.get("controller")
            law = isinstance(ctrl, dict) and ctrl.get("law") is not None
            motor, notes = firmware_motor(law_terms(ctrl), p, **lim) if law else (None, ())
        except FirmwareError as exc:
            raise InputError(f"--drivetrain {path}: {exc}") from None
        if motor is not None:
            say(f"simulate: the wheel's measured law replaces the PD gains: K_p = {motor.Kp:.0f} N·m/rad, "
                f"K_d = {motor.Kd:.0f} N·m·s/rad" + "".join(f"; {n}" for n in notes))
            return motor
    elif getattr(args, "battery_voltage", None) is not None:
        raise InputError("--battery-voltage needs --drivetrain RIDE.json")
    return MotorPD(Kp=args.kp, Kd=args.kd, torque_limit=args.motor_limit,
                   tiltback_speed=math.inf if args.tiltback_speed is None else args.tiltback_speed,
                   **lim)


def _cmd_simulate(args: argparse.Namespace) -> int:
    out = Path(args.out)
    if out.suffix.lower() not in (".csv", ".parquet"):
        raise InputError(f"--out must end in .csv or .parquet, got {str(out)!r}")
    check_writable(out)
    _check_choice("--model", args.model, ("planar", "3d"))
    _check_choice("--noise", args.noise, tuple(NOISE_LEVELS))
    if args.model == "3d":          # the spatial model
        return simulate_3d_command(args, _motor(args))
    _check_choice("--engine", args.engine, ENGINES)
    _check_choice("--variant", args.variant, VARIANTS)
    _check_choice("--rolling-model", args.rolling_model, ("moment", "contact"))
    if args.rolling_model == "contact" and (args.variant != "contact" or args.engine != "mujoco"):
        raise InputError("--rolling-model contact needs --variant contact and --engine mujoco")
    if args.profile:
        if args.maneuver not in (None, "profile"):
            raise InputError(f"--profile replaces --maneuver, got --maneuver {args.maneuver!r} too")
        man = load_speed_profile(args.profile)
    else:
        name = args.maneuver or "constant_speed"
        if name == "profile":
            raise InputError("--maneuver profile needs --profile FILE (a CSV with columns t, v)")
        _check_choice("--maneuver", name, MANEUVERS)
        man = make_maneuver(name)
    eff = _effects(args.effect)
    params = parse_params(args.param)
    motor = _motor(args, params.R, params)
    rec = api.simulate(man, float(args.duration), seed=int(args.seed), params=params, effects=eff,
                       noise=args.noise, engine=args.engine, variant=args.variant,
                       hide_torques=bool(args.hide_torques), motor=motor, rider_noise=args.rider_noise,
                       rider_delay=args.rider_delay, rolling_model=args.rolling_model,
                       drift_shape=_drift_shape(args.drift_shape, eff, params.h, args.duration), name=out.with_suffix("").name)
    path = api.write_recording(rec, out)
    say(f"simulate: wrote {path} ({man.name}, {args.duration:g} s, {args.engine}, seed {args.seed})")
    return 0


def _drift_shape(text, eff, h: float = 0.6, duration: float = 15.0):
    """``--drift-shape`` (needs ``--effect cog_height_drift=VALUE``), or None; h(t) must stay above the plausible
    least h over ``duration`` s."""
    if text is not None and "cog_height_drift" not in eff:
        raise InputError("--drift-shape shapes the cog_height_drift effect; add --effect cog_height_drift=VALUE")
    shape = None if text is None else parse_drift_shape(text)
    if "cog_height_drift" in eff:
        lowest = float(np.min(cog_height(h, eff["cog_height_drift"], np.linspace(0.0, duration, 2001), shape)))
        if lowest < PLAUSIBLE["h"][0]:
            raise InputError(f"effect cog_height_drift={eff['cog_height_drift']:g} m takes h from {h:g} m "
                             f"down to {lowest:.3g} m; h must stay at least {PLAUSIBLE['h'][0]:g} m")
    return shape


def _cmd_dataset(args: argparse.Namespace) -> int:
    from euc_sim.simulation.dataset import dataset_plan, run_dataset  # deferred: loads multiprocessing, tqdm (0.02 s)

    _check_choice("--noise", args.noise, tuple(NOISE_LEVELS))
    _check_choice("--engine", args.engine, ENGINES)
    _check_choice("--format", args.format, ("csv", "parquet"))
    from euc_sim.simulation.runner import check_backend  # deferred: loads multiprocessing, tqdm (0.02 s)
    check_backend(args.scheduler, args.workers)
    effects, params = _effects(args.effect), parse_params(args.param)
    _drift_shape(None, effects, params.h, args.duration)
    specs = dataset_plan(args.seed, args.duration, params=params, noise=args.noise,
                         rider_noise=args.rider_noise, engine=args.engine, effects=effects)
    settings = {"seed": args.seed, "duration": args.duration, "noise": args.noise, "engine": args.engine,
                "rider_noise": args.rider_noise, "effects": effects, "param": list(args.param or ()),
                "format": args.format}
    t0 = time.perf_counter()
    report = run_dataset(args.out_dir, specs, workers=args.workers, progress=not args.quiet,
                         ext="." + args.format, scheduler=args.scheduler, settings=settings)
    say(report.table())
    say(f"dataset: wrote {len(report.results)} of {len(specs)} recordings to {args.out_dir} "
        f"in {time.perf_counter() - t0:.1f} s")
    if report.failed:       # the rest are written; the request was not met in full
        say(f"dataset: {len(report.failed)} recording(s) failed, named above and in "
            f"{Path(args.out_dir) / 'dataset.json'} ('failed'): {', '.join(report.failed)}")
        return 2
    return 0


def _cmd_stability(args: argparse.Namespace) -> int:
    from euc_sim.simulation.stability import stability_report  # deferred: loads scipy.linalg (0.2 s)
    from euc_sim.controllers.design import delay_tolerance  # deferred: loads scipy.linalg (0.2 s)

    if args.json:
        check_writable(args.json)
    p = parse_params(args.param)
    motor = _motor(args)
    rider = default_rider(p, motor, delay=args.rider_delay)
    rep = stability_report(p, motor, rider, speed=args.speed, check_mujoco=True)
    lo, hi = delay_tolerance(p, motor, rider)
    rep["rider_loop"]["tolerated_actual_delay"] = [lo, hi]
    jc = rep["jacobian_check"]
    jac_ok = jc["analytic_vs_central_difference"] < 1e-5 and \
        jc["analytic_vs_mjd_transitionFD"]["relative_error"] < 1e-4
    stable = rep["max_real_part"]["motor_pd_and_rider"] < 0 and rep["rider_loop"]["stable_with_delay"]
    rep["ok"] = bool(jac_ok and stable)

    print(f"operating point: upright at {args.speed:g} m/s; motor Kp = {motor.Kp:g} N·m/rad, "
          f"Kd = {motor.Kd:g} N·m·s/rad")
    print(f"rider gains K on (ẋ−v, γ−γ*, φ−φ*, γ̇, φ̇, ∫(ẋ−v)): {', '.join(f'{k:.4g}' for k in rider.K)}")
    for key, label in (("open_loop", "open loop (no torques)"), ("motor_pd", "motor PD only"),
                       ("motor_pd_and_rider", "motor PD + rider, no delay")):
        print(f"eigenvalues, {label} [1/s]: {format_eigenvalues(rep['eigenvalues'][key])}")
    rl = rep["rider_loop"]
    print(f"rider loop: delay margin without prediction {rl['delay_margin_without_predictor']:.3f} s "
          f"(crossover {rl['crossover_frequency']:.2f} rad/s); reaction delay {rl['reaction_delay']:g} s")
    print(f"with the rider's predictor: spectral radius {rl['discrete_spectral_radius_with_delay']:.5f} "
          f"(sampled at 5 ms, {'stable' if rl['stable_with_delay'] else 'UNSTABLE'}); "
          f"stable for actual delays {lo:.3f}-{hi:.3f} s")
    print(f"Jacobians: analytic vs central differences {jc['analytic_vs_central_difference']:.2e}; "
          f"vs mjd_transitionFD (relative) {jc['analytic_vs_mjd_transitionFD']['relative_error']:.2e}")
    print("ok" if rep["ok"] else "NOT OK: see above")
    if args.json:
        write_json(args.json, rep)
    return 0 if rep["ok"] else 1


def _controller_options(p: argparse.ArgumentParser) -> None:
    p.add_argument("--kp", type=bounded(1.0, 1e5, unit="N·m/rad"), default=600.0, metavar="KP",
                   help="motor PD K_p, N·m/rad (default 600)")
    p.add_argument("--kd", type=bounded(0.0, 1e4, unit="N·m·s/rad"), default=40.0, metavar="KD",
                   help="motor PD K_d, N·m·s/rad (default 40)")
    p.add_argument("--motor-limit", type=bounded(1.0, 5000.0, unit="N·m"), default=250.0, metavar="N·m",
                   help="motor torque limit, N·m (default 250)")
    p.add_argument("--tiltback-speed", type=bounded(0.5, 40.0, unit="m/s"), default=None, metavar="M/S",
                   help="speed above which the EUC tilts back, m/s (default none)")
    p.add_argument("--rider-delay", type=bounded(0.0, 1.0, unit="s"), default=0.15,   # the rider's MAX_DELAY
                   help="rider reaction delay, s (default 0.15; at most 1)")
    p.add_argument("--param", action="append", metavar="NAME=VALUE", help="override a Table 3 value")


def add_commands(sub) -> None:
    """Register ``simulate``, ``dataset`` and ``stability`` on the subparsers ``sub``."""
    effect_help = f"NAME one of {', '.join(effect_names())}; VALUE within: {bounds_text()}"
    p = sub.add_parser("simulate", help="closed-loop simulation of a maneuver, written as a recording")
    p.add_argument("--maneuver", default=None, metavar="NAME",
                   help=f"{', '.join(m for m in MANEUVERS if m != 'profile')} (default constant_speed; "
                        f"profile with --profile); with --model 3d: {', '.join(PATHS)} (default figure_eight)")
    p.add_argument("--model", default="planar", metavar=one_of(("planar", "3d")),
                   help="planar (default) or 3d (mjcf/euc_3d.xml)")
    p.add_argument("--profile", metavar="CSV", help="speed profile with columns t (s), v (m/s)")
    p.add_argument("--duration", type=DURATION, default=15.0, metavar="S", help="s (default 15)")
    p.add_argument("--seed", type=seed, default=0, metavar="N",
                   help="seed of the rider and sensor noise, a non-negative integer (default 0)")
    p.add_argument("--out", required=True, metavar="NAME.csv", help="recording (.csv or .parquet)")
    p.add_argument("--effect", action="append", metavar="NAME=VALUE",
                   help=f"inject an effect of CONTRACT's catalog (repeatable); {effect_help}")
    p.add_argument("--drift-shape", metavar="KIND[,start=S,length=S,sign=±1,seed=N]",
                   help="shape of h(t) for cog_height_drift: sine (default, period 12 s), ramp, dip "
                        "or wander, e.g. ramp,start=5,length=4,sign=-1 (crouch by VALUE m over 5-9 s)")
    p.add_argument("--noise", default="paper", metavar=one_of(NOISE_LEVELS),
                   help="measurement noise: paper (default) or none")
    p.add_argument("--engine", default="mujoco", metavar=one_of(ENGINES), help="mujoco (default) or analytic")
    p.add_argument("--variant", default="ideal", metavar=one_of(VARIANTS),
                   help="MuJoCo ground: ideal (default) or contact")
    p.add_argument("--hide-torques", action="store_true", help="leave M_d, M_h out of the recording")
    p.add_argument("--drivetrain", metavar="RIDE.json",
                   help="voltage-limited motor from a ride's identified drivetrain "
                        "(euc-sim ride --json): its torque falls with speed and battery voltage")
    p.add_argument("--battery-voltage", type=bounded(*SPEC_RANGE["battery_voltage"][:2], unit="V"), metavar="V",
                   help="battery voltage for --drivetrain, V (default: the ride's full charge)")
    p.add_argument("--rolling-model", default="moment", metavar=one_of(("moment", "contact")),
                   help="rolling_resistance as an applied moment (default) or as MuJoCo's own rolling "
                        "friction of the tyre (contact; needs --variant contact)")
    p.add_argument("--rider-noise", type=RIDER_NOISE, default=DEFAULT_RIDER_NOISE, metavar="N·m",
                   help=f"rider motor noise, N·m (default {DEFAULT_RIDER_NOISE:g})")
    _controller_options(p)
    p.set_defaults(func=_cmd_simulate)

    _add_dataset_parser(sub)

    p = sub.add_parser("stability", help="linearisation, eigenvalues and the rider's delay margin")
    p.add_argument("--json", metavar="FILE", help="write the report as JSON")
    p.add_argument("--speed", type=bounded(-30.0, 30.0, unit="m/s"), default=0.0, metavar="M/S",
                   help="operating speed, m/s (within ±30)")
    _controller_options(p)
    p.set_defaults(func=_cmd_stability)


def _add_dataset_parser(sub) -> None:
    """Register ``dataset`` on the subparsers ``sub``."""
    effect_help = f"NAME one of {', '.join(effect_names())}; VALUE within: {bounds_text()}"
    p = sub.add_parser("dataset", help="a paper-like set of synthetic recordings, in parallel")
    out = p.add_mutually_exclusive_group(required=True)
    out.add_argument("--out-dir", metavar="DIR",
                     help="folder for the recordings (NAME.csv + NAME.json + NAME.truth.json) and dataset.json")
    deprecated(out, "--out", "--out-dir")
    p.add_argument("--seed", type=seed, default=0, metavar="N",
                   help="dataset seed: speeds, rider and sensor noise of every recording, a non-negative integer (default 0)")
    p.add_argument("--duration", type=DURATION, default=15.0, metavar="S", help="s per recording (default 15)")
    p.add_argument("--workers", type=workers(), default=None, metavar="N",
                   help="processes on this machine (default: all cores; 1: in this process), "
                        "or the workers of --scheduler local (default 2)")
    p.add_argument("--scheduler", default=None, metavar="local|ADDRESS",
                   help="run on Dask: 'local' starts a cluster on this machine that only this command can "
                        "use (TLS with throwaway keys, no dashboard or HTTP port); tcp://HOST:PORT (or "
                        "tls://) uses a running one, which is trusted with code: it receives this "
                        "command's tasks as pickled Python and runs them, and its pickled results are "
                        "unpickled here; use only a cluster that you and users you trust control")
    p.add_argument("--noise", default="paper", metavar=one_of(NOISE_LEVELS), help="paper (default) or none")
    p.add_argument("--engine", default="mujoco", metavar=one_of(ENGINES), help="mujoco (default) or analytic")
    p.add_argument("--format", default="csv", metavar=one_of(("csv", "parquet")), help="csv (default) or parquet")
    p.add_argument("--effect", action="append", metavar="NAME=VALUE",
                   help=f"inject in every recording (repeatable); {effect_help}")
    p.add_argument("--rider-noise", type=RIDER_NOISE, default=DEFAULT_RIDER_NOISE, metavar="N·m",
                   help="rider motor noise, N·m")
    p.add_argument("--param", action="append", metavar="NAME=VALUE", help="override a Table 3 value")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    deprecated(p, "--no-progress", "--quiet")
    p.set_defaults(func=_cmd_dataset)

"""Benchmarks of real and long rides (``scripts/bench.py`` sections ``ride_mass``, ``ride``)."""

from __future__ import annotations

import time

import numpy as np

from bench_timing import timed


def _shared_root():
    """``shared/data/euc_core`` beside the checkout or any folder above it (a worktree sits deeper)."""
    from pathlib import Path

    for up in Path(__file__).resolve().parents:
        if (up / "shared" / "data" / "euc_core").is_dir():
            return up / "shared" / "data" / "euc_core"
    return Path(__file__).resolve().parents[3] / "shared" / "data" / "euc_core"


# --- a 60-minute real ride, mass and drivetrain ---------------------------------
def bench_ride_mass() -> dict:
    """A 64-minute real ride (Blitz 4): mass + drivetrain, and the whole ride command without simulation."""
    import warnings

    from euc_sim.rides.drive.drivetrain_report import analyse
    from euc_sim.rides.source.logs import read_log
    from euc_sim.rides.source.spec import read_spec

    root = _shared_root()
    log = root / "trips/begode/blitz/4/4.csv"
    if not log.is_file():
        print(f"  {log} absent: skipped")
        return {"skipped": str(log)}
    warnings.simplefilter("ignore")
    spec = read_spec(root / "specs/blitz.csv")
    t_read = timed(lambda: read_log(log, emit_warnings=False), repeat=1)
    t_mass = timed(lambda: analyse(read_log(log, emit_warnings=False), spec), repeat=1) - t_read

    def whole():
        from euc_sim.api.functions import analyse_request
        from euc_sim.rides.request import RideRequest
        return analyse_request(RideRequest(read_log(log, emit_warnings=False), spec=spec)).to_json()

    cpu0 = time.process_time()
    t_all = timed(whole, repeat=1)
    cpu_all = time.process_time() - cpu0        # CPU seconds, every thread: the one-core time
    minutes = read_log(log, emit_warnings=False).duration / 60.0
    out = {"ride_minutes": minutes, "read_s": t_read, "mass_drivetrain_s": t_mass,
           "ride_no_simulate_s": t_all, "ratio_mass_vs_read": t_mass / t_read,
           "ride_no_simulate_cpu_s": cpu_all, "ratio_ride_vs_read": t_all / t_read}
    print(f"  {minutes:.0f}-minute ride: read {t_read:.2f} s (the reference); mass + drivetrain "
          f"(200 bootstrap) {t_mass:.2f} s ({t_mass / t_read:.1f}x reading)")
    print(f"  euc-sim ride --no-simulate, everything (3 balance fits x 200 bootstrap too): "
          f"{t_all:.1f} s wall, {cpu_all:.1f} s CPU ({t_all / t_read:.1f}x reading; aim < 20 s, "
          f"one core)")
    return out


# --- a 60-minute ride along a logged-like profile ------------------------------
def bench_ride() -> dict:
    """A 60-minute speed profile ridden by simulate_profile (augmented effects, native) vs a bare mj_step loop."""
    import mujoco

    from euc_sim.controllers.rider import RiderRun
    from euc_sim.model.parameters import TABLE3
    from euc_sim.rides.sim.tracking import simulate_profile
    from euc_sim.simulation.engine import _MujocoStepper

    minutes = 60.0
    t = np.arange(0.0, minutes * 60.0 + 1e-9, 0.1)          # a log's 10 Hz grid
    v = np.clip(6.0 + 4.0 * np.sin(2 * np.pi * t / 300.0) + 2.0 * np.sin(2 * np.pi * t / 47.0 + 1.0)
                + 1.5 * np.sin(2 * np.pi * t / 13.0), 0.0, None)        # stops, 0.9 m/s² at most
    effects = {"aerodynamic_drag": 0.25, "rolling_resistance": 0.012, "road_slope": 0.01}
    simulate_profile(t[:50], v[:50], TABLE3, effects, track_iterations=0)      # compile, warm caches
    spent = {"rider": 0.0}
    commands = RiderRun.commands

    def timed_commands(self, k0, Y):                    # the rider's Python block law, timed
        t0 = time.perf_counter()
        try:
            return commands(self, k0, Y)
        finally:
            spent["rider"] += time.perf_counter() - t0

    RiderRun.commands = timed_commands
    try:
        t0 = time.perf_counter()
        run = simulate_profile(t, v, TABLE3, effects, track_iterations=0, stops=())   # all 60 min ridden
        t_ride = time.perf_counter() - t0
    finally:
        RiderRun.commands = commands
    if run.falls:
        raise RuntimeError(f"bench ride: the rider fell ({run.falls[0]}); the timing would be of a shorter ride")
    stepper = _MujocoStepper(TABLE3, "ideal", 1e-3, {}, None)
    bare_s = 120.0                                        # seconds of ride stepped bare, scaled
    t0 = time.perf_counter()
    mujoco.mj_step(stepper.m, stepper.d, nstep=int(bare_s / 1e-3))
    t_bare = (time.perf_counter() - t0) * (minutes * 60.0 / bare_s)
    out = {"sixty_minute_seconds": t_ride, "bare_mj_step_sixty_minute_seconds": t_bare,
           "ratio_ride_vs_bare_mj_step": t_ride / t_bare, "rider_law_seconds": spent["rider"],
           "real_time_factor": minutes * 60.0 / t_ride}
    print(f"  60-minute ride, 1 kHz, drag + rolling + slope (native): {t_ride:6.1f} s "
          f"({out['real_time_factor']:.0f}x real time; aim < 60 s, one core)")
    print(f"  bare mj_step loop, same model, 60 min (from {bare_s:.0f} s): {t_bare:6.1f} s "
          f"(ride / bare = {out['ratio_ride_vs_bare_mj_step']:.2f}x)")
    print(f"  of which the rider's block law (Python): {spent['rider']:.1f} s")
    return out


# --- the ride page of a 60-minute ride against one bare simulation of its profile ----------
def _warm_up() -> float:
    """Imports, the native callback's compile and a 5 s ride: the one-off costs of a process, s.

    Paid by whichever is timed first in a process; taken out here so that the page and the
    bare simulation are timed alike (and reported apart: ``warm_up_seconds``)."""
    import numpy as np

    t0 = time.perf_counter()
    import euc_sim.rides.balance.analysis  # noqa: F401  (the page's heavy imports: scipy.signal, pandas)
    import euc_sim.report.ride.page_html  # noqa: F401
    import euc_sim.rides.pipeline  # noqa: F401
    import importlib
    import pkgutil

    import euc_sim.diagnosis.localise  # noqa: F401
    import euc_sim.rides
    # every module the pipeline imports where it first needs one (each compiled from source
    # where PYTHONDONTWRITEBYTECODE is set): a one-off of the process, not of the page
    for mod in pkgutil.walk_packages(euc_sim.rides.__path__, "euc_sim.rides."):
        importlib.import_module(mod.name)
    from euc_sim.model.parameters import TABLE3
    from euc_sim.rides.sim.tracking import simulate_profile
    from euc_sim.simulation.native_core import available

    available()
    t = np.arange(0.0, 5.0, 0.1)
    simulate_profile(t, np.full(t.size, 3.0), TABLE3, {}, track_iterations=0, stops=())
    return time.perf_counter() - t0


def bench_ride_page(fit=None, held=None, spec_path=None, workers: int = 2) -> dict:
    """The full ride page (analyse_request LOG --compare OTHER, every step) against one bare simulation of OTHER's profile."""
    import os
    import tempfile
    import warnings
    from pathlib import Path

    from euc_sim.rides.grids.signals import ride_signals
    from euc_sim.api.functions import analyse_request
    from euc_sim.rides.request import RideRequest
    from euc_sim.rides.sim.sim_steps import StepInputs, build_steps, nominal_step
    from euc_sim.rides.sim.simulate import ride_params, simulate_ride
    from euc_sim.rides.source.logs import read_log
    from euc_sim.rides.source.spec import read_spec

    root = _shared_root()
    fit = Path(fit or root / "trips/begode/blitz/2/2.csv")
    held = Path(held or root / "trips/begode/blitz/4/4.csv")
    spec_path = spec_path or (root / "specs/blitz.csv" if fit.is_relative_to(root) else None)
    if not (fit.is_file() and held.is_file()):
        print(f"  {fit} or {held} absent: skipped")
        return {"skipped": str(held)}
    warnings.simplefilter("ignore")
    spec = read_spec(spec_path) if spec_path else None
    warm = _warm_up()
    load0 = os.getloadavg()[0]
    steps_seen = []
    with tempfile.TemporaryDirectory() as out:
        cpu0 = time.process_time()
        t_page = timed(lambda: steps_seen.append(analyse_request(
            RideRequest(read_log(fit, emit_warnings=False), read_log(held, emit_warnings=False), spec, simulate=True),
            out, workers).to_json()), repeat=1)
        cpu_page = time.process_time() - cpu0
    ride = read_log(held, emit_warnings=False)
    sig = ride_signals(ride)
    steps = build_steps(StepInputs(ride_params(sig.assumptions), {}, {}, ()), (nominal_step,))
    cpu0 = time.process_time()
    t_sim = timed(lambda: simulate_ride(sig, steps, ride, label=ride.name, workers=1), repeat=1)
    cpu_sim = time.process_time() - cpu0
    load1 = os.getloadavg()[0]
    minutes = ride.duration / 60.0
    ran = steps_seen[0]["simulation"]["steps"] if steps_seen[0].get("simulation") else []
    ran = [s["step"] for s in ran if s["ran"]]
    out = {"ride_minutes": minutes, "page_seconds": t_page, "page_cpu_seconds": cpu_page,
           "one_simulation_seconds": t_sim, "page_cost_vs_one_simulation": t_page / t_sim,
           "one_simulation_cpu_seconds": cpu_sim, "page_cpu_vs_one_simulation_cpu": cpu_page / cpu_sim,
           "workers": workers, "steps": ran, "warm_up_seconds": warm,
           "load_average": [load0, load1], "cpu_count": os.cpu_count()}
    print(f"  {minutes:.0f}-minute held-out ride: the page {t_page:.1f} s ({cpu_page:.1f} s CPU; steps "
          f"{', '.join(ran)} on {workers} thread(s)), one bare simulation of its profile {t_sim:.1f} s: "
          f"{t_page / t_sim:.2f}x (aim <= 2.5 on an idle 2-core machine); CPU seconds {cpu_page:.1f} / "
          f"{cpu_sim:.1f} = {cpu_page / cpu_sim:.2f}x (the one-core cost, which threads do not lower)")
    print(f"  both timed after the process's one-off warm-up ({warm:.1f} s: imports, the native "
          f"callback's compile); load average {load0:.1f} then {load1:.1f} on {os.cpu_count()} cores")
    return out


def bench_ride_page_serial() -> dict:
    """The ride page as ``ride_page``, its simulation steps one after the other (one thread)."""
    return bench_ride_page(workers=1)


# --- the rider's numbers: every fit without the replay, against reading the log ------------
def _longest_rides(root, n: int):
    """The ``n`` longest shared rides (by rows: what reading costs), longest first, and spans, s."""
    import warnings

    from euc_sim.rides.source.logs import read_log

    warnings.simplefilter("ignore")
    logs = sorted(root.glob("trips/*/*/*/[0-9]*.csv"))
    rows = {p: read_log(p, emit_warnings=False) for p in logs}
    span = {p: r.duration for p, r in rows.items()}
    return sorted(logs, key=lambda p: len(rows[p].data), reverse=True)[:n], span


def _stages(marks: list) -> dict:
    """Seconds per stage of one ride page from the pipeline's progress messages (each the
    start of a step): reading, mass and drivetrain, the balance fits, the rest of the
    analyses (balance law, parameter set, residual, rider's numbers), the page."""
    def stage(step: str) -> str:
        if step == "read_log" or step.startswith("finding the total mass"):
            return "read_log" if step == "read_log" else "mass_drivetrain"
        if step.startswith("writing the report"):
            return "page"
        if step.startswith(("reading the wheel's", "locating")):
            return "law_residual_numbers"
        return "balance_fits" if step.startswith(("reading ", "fitting ")) else "law_residual_numbers"

    out: dict = {}
    for (step, t0), (_, t1) in zip(marks, marks[1:]):
        out[stage(step)] = out.get(stage(step), 0.0) + t1 - t0
    return out


def bench_ride_fast() -> dict:
    """The ride page and every fit without the simulated replay, against pandas reading the log;
    the peak memory of ``ride --compare`` on the two longest rides (a child process)."""
    import os
    import resource
    import subprocess
    import sys
    import tempfile
    from pathlib import Path

    import pandas as pd

    from euc_sim.api.functions import analyse_request
    from euc_sim.rides.request import RideRequest
    from euc_sim.rides.source.logs import read_log

    root = _shared_root()
    if not root.is_dir():
        print(f"  {root} absent: skipped")
        return {"skipped": str(root)}
    (log, other), span = _longest_rides(root, 2)
    _warm_up()
    read = timed(lambda: pd.read_csv(log), repeat=3)
    load0 = os.getloadavg()[0]
    marks: list = []
    cpu0 = time.process_time()

    def one_page(out):
        marks[:] = [("read_log", time.perf_counter())]
        analyse_request(RideRequest(read_log(log, emit_warnings=False)), out,
                        progress=lambda step: marks.append((step, time.perf_counter()))).to_json()
        marks.append(("end", time.perf_counter()))

    with tempfile.TemporaryDirectory() as out:
        page = timed(lambda: one_page(out), repeat=1)
        page_cpu = time.process_time() - cpu0
        stages = _stages(marks)
        cmd = [sys.executable, "-m", "euc_sim.cli", "ride", str(log), "--compare", str(other),
               "--no-simulate", "--report", str(Path(out) / "pair"), "--quiet"]
        subprocess.run(cmd, check=True, capture_output=True)
    peak = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss / 1024.0   # kB on Linux
    name = "/".join(log.parts[-4:-1])
    out = {"ride": name, "ride_minutes": span[log] / 60.0, "read_csv_seconds": read,
           "page_seconds": page, "page_cost_vs_read_csv": page / read, "peak_rss_mb": peak,
           "page_cpu_seconds": page_cpu, "stages_seconds": stages,
           "compare_minutes": [span[log] / 60.0, span[other] / 60.0],
           "load_average": [load0, os.getloadavg()[0]], "cpu_count": os.cpu_count()}
    print(f"  {name} ({span[log] / 60:.0f} min): pandas reads it in {read:.2f} s (the reference); the "
          f"page and every fit without the replay {page:.2f} s = {page / read:.0f}x (aim <= 10; "
          f"{page_cpu:.2f} s CPU)")
    print("  of which " + ", ".join(f"{k} {v:.3f} s" for k, v in stages.items()))
    print(f"  ride --compare --no-simulate on the two longest rides ({span[log] / 60:.0f} and "
          f"{span[other] / 60:.0f} min): peak memory {peak:.0f} MB (aim <= 1000); load average "
          f"{load0:.1f} at the start")
    return out

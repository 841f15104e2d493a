"""Synthetic recordings: simulate, sample like motion capture, write with sidecars.

:func:`simulated_recording` makes one recording in memory; :func:`write_simulated`
writes it (``NAME.csv`` + ``NAME.json`` + ``NAME.truth.json``); :func:`run_dataset`
makes a set shaped like the paper's longitudinal recordings (Table 1: constant
speed 7, acceleration 3, deceleration 2; plus stop-and-go) in parallel processes.

Seeds: a recording with seed s draws the rider's motor noise from s and the
measurement noise from (s, 120); a dataset with seed S gives recording i the seed
``SeedSequence(S).spawn(n)[i]``, and its speeds from the same stream, so every file
is reproducible on its own.
"""

from __future__ import annotations

import math
import os
from concurrent.futures import ProcessPoolExecutor, as_completed
from dataclasses import dataclass, field
from pathlib import Path
from typing import Mapping

import numpy as np

from controllers.motor import MotorPD
from controllers.rider import DEFAULT_RIDER_NOISE, Rider
from euc_sim import io
from euc_sim.simulation.mocap import motion_capture
from euc_sim.model.parameters import Params, TABLE3
from euc_sim.simulation.maneuvers import Maneuver, make_maneuver
from euc_sim.simulation.engine import default_rider, simulate, true_params

__all__ = ["PAPER_SET", "DEFAULT_RIDER_NOISE", "RecordingSpec", "simulated_recording",
           "write_simulated", "dataset_plan", "run_dataset"]

#: The paper's longitudinal maneuvers (Table 1) and how many recordings of each, plus
#: stop-and-go, which the paper's NOTES single out for h.
PAPER_SET = (("constant_speed", 7), ("acceleration", 3), ("deceleration", 2), ("stop_and_go", 2))


@dataclass(frozen=True)
class RecordingSpec:
    """Everything that defines one synthetic recording (picklable, for worker processes)."""

    name: str
    maneuver: Maneuver
    duration: float
    seed: int
    params: Params = TABLE3
    effects: tuple = ()
    noise: str = "paper"
    engine: str = "mujoco"
    variant: str = "ideal"
    hide_torques: bool = False
    motor: MotorPD = field(default_factory=MotorPD)
    rider: Rider | None = None
    rolling_model: str = "moment"
    #: an out-of-catalog disturbance F(t) at G, N (see simulation.simulate); its
    #: description goes to the truth file only
    external_force: object = None
    #: shape of h(t) with ``cog_height_drift`` (:class:`euc_sim.simulation.drift.DriftShape`;
    #: None: the catalog's 12 s sine); it goes to the truth file only
    drift_shape: object = None


def simulated_recording(spec: RecordingSpec):
    """Simulate and sample one recording.

    Returns
    -------
    (recording, meta, truth) : (pandas.DataFrame, dict, dict)
        CONTRACT columns at 120 Hz, the ``NAME.json`` sidecar and the
        ``NAME.truth.json`` content.

    Raises
    ------
    FallError
        when the rider falls (nothing is produced).
    """
    eff = dict(spec.effects)
    rider = spec.rider or default_rider(spec.params, spec.motor)
    run = simulate(spec.maneuver, spec.duration, params=spec.params, motor=spec.motor, rider=rider,
                   seed=spec.seed, engine=spec.engine, variant=spec.variant, effects=eff,
                   rolling_model=spec.rolling_model, external_force=spec.external_force,
                   drift_shape=spec.drift_shape)
    p_true = true_params(spec.params, eff)
    rec = motion_capture(run, p_true, noise=spec.noise, seed=spec.seed, effects=eff,
                         hide_torques=spec.hide_torques)
    known = {k: v for k, v in spec.params.as_dict().items() if k != "h"}   # h is to be identified
    meta = {
        "params": known,
        "maneuver": spec.maneuver.name,
        "maneuver_options": dict(spec.maneuver.options),
        "source": (f"euc-sim simulate: {spec.engine} engine, {spec.variant} ground, "
                   f"{spec.duration:g} s at 1 kHz sampled at 120 Hz, noise {spec.noise}, seed {spec.seed}"),
        "duration": spec.duration,
        "noise": spec.noise,
        "torques": "hidden" if spec.hide_torques else "true M_d, M_h of the simulation",
    }
    truth = {
        "effects": {k: {"value": v, "unit": _unit(k)} for k, v in eff.items()},
        "params": p_true.as_dict(),
        "nominal_params": spec.params.as_dict(),
        "maneuver": spec.maneuver.as_dict(),
        "motor": spec.motor.as_dict(),
        "rider": rider.as_dict(),
        "seed": spec.seed,
        "engine": spec.engine,
        "variant": spec.variant,
        "rolling_model": spec.rolling_model,
    }
    if spec.drift_shape is not None:
        truth["drift_shape"] = spec.drift_shape.as_dict()
    if spec.external_force is not None:
        describe = getattr(spec.external_force, "as_dict", None)
        truth["out_of_catalog"] = describe() if describe else repr(spec.external_force)
    return rec, meta, truth


def _unit(name: str) -> str:
    from euc_sim.simulation.effects import get
    return get(name).unit


def write_simulated(path: str | Path, spec: RecordingSpec) -> Path:
    """Simulate, sample and write ``path`` with ``NAME.json`` and ``NAME.truth.json``.

    The destination is checked before the simulation runs; nothing is written when
    the run fails.
    """
    io.check_writable(path)
    rec, meta, truth = simulated_recording(spec)
    return io.write_recording(rec, path, meta, truth)


def dataset_plan(seed: int = 0, duration: float = 15.0, counts=PAPER_SET, params: Params = TABLE3,
                 noise: str = "paper", rider_noise: float = DEFAULT_RIDER_NOISE,
                 engine: str = "mujoco", effects: Mapping[str, float] | None = None) -> list[RecordingSpec]:
    """Specs of a paper-like dataset, speeds varied per recording from the seed.

    Parameters
    ----------
    seed : int
        Dataset seed.
    duration : float
        Length of each recording, s.
    counts : sequence of (maneuver, count)
    params : Params
    noise : {"paper", "none"}
    rider_noise : float
        Rider motor noise, N·m.
    engine : {"mujoco", "analytic"}
    effects : mapping, optional
        Effects injected in every recording.
    """
    total = sum(c for _, c in counts)
    children = np.random.SeedSequence(int(seed)).spawn(total)
    motor = MotorPD()
    rider = default_rider(params, motor, noise_std=rider_noise)
    specs, i = [], 0
    for name, count in counts:
        for j in range(count):
            rng = np.random.default_rng(children[i])
            rec_seed = int(children[i].generate_state(1)[0])
            if name == "constant_speed":
                man = make_maneuver(name, v=float(rng.uniform(2.0, 4.0)))
            elif name == "acceleration":
                man = make_maneuver(name, v0=float(rng.uniform(0.5, 1.5)), v1=float(rng.uniform(3.0, 4.5)),
                                    start=float(rng.uniform(2.0, 4.0)), ramp=float(rng.uniform(3.0, 5.0)))
            elif name == "deceleration":
                man = make_maneuver(name, v0=float(rng.uniform(3.0, 4.5)), v1=float(rng.uniform(0.3, 1.0)),
                                    start=float(rng.uniform(2.0, 4.0)), ramp=float(rng.uniform(3.0, 5.0)))
            else:
                man = make_maneuver(name, v=float(rng.uniform(2.0, 3.0)))
            specs.append(RecordingSpec(f"{name}_{j + 1:02d}", man, duration, rec_seed, params,
                                       tuple(sorted(dict(effects or {}).items())), noise, engine,
                                       motor=motor, rider=rider))
            i += 1
    return specs


def _work(args):
    out_dir, spec, ext = args
    path = Path(out_dir) / f"{spec.name}{ext}"
    write_simulated(path, spec)
    return str(path)


def run_dataset(out_dir: str | Path, specs: list[RecordingSpec], workers: int | None = None,
                progress: bool = True, ext: str = ".csv") -> list[Path]:
    """Write every spec's recording into ``out_dir``, in parallel processes.

    Parameters
    ----------
    out_dir : path
    specs : list of RecordingSpec
    workers : int, optional
        Worker processes (default: all cores); 1 runs in this process.
    progress : bool
        Show a tqdm progress bar on stderr.
    ext : {".csv", ".parquet"}

    Returns
    -------
    list of pathlib.Path
        In the order of ``specs``; a manifest ``dataset.json`` is written beside them.
    """
    from tqdm import tqdm

    out_dir = Path(out_dir)
    io.check_writable(out_dir / "dataset.json")
    workers = workers or os.cpu_count() or 1
    jobs = [(str(out_dir), s, ext) for s in specs]
    bar = tqdm(total=len(jobs), desc="dataset", unit="rec", disable=not progress)
    try:
        if workers == 1:
            paths = []
            for job in jobs:
                paths.append(_work(job))
                bar.update()
        else:
            with ProcessPoolExecutor(max_workers=workers) as pool:
                futures = {pool.submit(_work, job): k for k, job in enumerate(jobs)}
                paths = [None] * len(jobs)
                for fut in as_completed(futures):
                    paths[futures[fut]] = fut.result()
                    bar.update()
    finally:
        bar.close()
    io.write_json(out_dir / "dataset.json", {
        "recordings": [Path(p).name for p in paths],
        "maneuvers": {s.name: s.maneuver.name for s in specs},
        "duration": specs[0].duration if specs else math.nan,
    })
    return [Path(p) for p in paths]

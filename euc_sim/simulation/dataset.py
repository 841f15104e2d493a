"""Synthetic recordings: simulate, sample like motion capture, write with sidecars.

:func:`simulated_recording` makes one recording in memory; :func:`write_simulated`
writes it (``NAME.csv`` + ``NAME.json`` + ``NAME.truth.json``); :func:`run_dataset`
makes a set shaped like the paper's longitudinal recordings (Table 1: constant
speed 7, acceleration 3, deceleration 2; plus stop-and-go) in parallel
(:mod:`euc_sim.simulation.runner`: a process pool or Dask).

Seeds: a recording with seed s draws the rider's motor noise from s and the
measurement noise from (s, 120); a dataset with seed S gives recording i the seed
``SeedSequence(S).spawn(n)[i]``, and its speeds from the same stream, so every file
is reproducible on its own.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Mapping

import numpy as np

from euc_sim.controllers.motor import MotorPD
from euc_sim.controllers.rider import DEFAULT_RIDER_NOISE, Rider
from euc_sim import io
from euc_sim.errors import InputError
from euc_sim.simulation.mocap import motion_capture
from euc_sim.model.parameters import Params, TABLE3
from euc_sim.simulation.maneuvers import Maneuver, make_maneuver
from euc_sim.simulation.engine import default_rider, simulate, true_params

__all__ = ["PAPER_SET", "DEFAULT_RIDER_NOISE", "RecordingSpec", "simulated_recording", "simulated_recordings",
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


def _request(spec: RecordingSpec) -> dict:
    """The spec's run as keyword arguments of :func:`simulate`."""
    return dict(maneuver=spec.maneuver, duration=spec.duration, params=spec.params, motor=spec.motor,
                rider=spec.rider or default_rider(spec.params, spec.motor), seed=spec.seed,
                engine=spec.engine, variant=spec.variant, effects=dict(spec.effects),
                rolling_model=spec.rolling_model, external_force=spec.external_force,
                drift_shape=spec.drift_shape)


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
    return _sampled(spec, simulate(**_request(spec)))


def simulated_recordings(specs: list[RecordingSpec], nthread: int = 1) -> list:
    """:func:`simulated_recording` of many specs, their rides in MuJoCo batches on ``nthread``
    threads (:func:`euc_sim.simulation.mujoco_batch.simulate_rides`: the same runs).

    Parameters
    ----------
    specs : list of RecordingSpec
        The recordings to simulate.
    nthread : int
        Threads of the MuJoCo batch.

    Returns
    -------
    list
        Per spec, in order: ``(recording, meta, truth)``, or the ``FallError`` of its rider.
    """
    from euc_sim.simulation.mujoco_batch import simulate_rides

    runs = simulate_rides([_request(s) for s in specs], nthread=nthread)
    return [run if isinstance(run, Exception) else _sampled(spec, run) for spec, run in zip(specs, runs)]


def _sampled(spec: RecordingSpec, run):
    """The recording, sidecar and truth of a spec's simulated run (see :func:`simulated_recording`)."""
    eff = dict(spec.effects)
    rider = spec.rider or default_rider(spec.params, spec.motor)
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


def _make_batch(args):
    """Worker side: one batch of recordings in memory (written by the parent, atomically);
    a spec whose rider fell gives its one-line reason instead."""
    from euc_sim.simulation.runner import _reason

    specs, nthread = args
    return [_reason(v) if isinstance(v, Exception) else v for v in simulated_recordings(specs, nthread)]


def run_dataset(out_dir: str | Path, specs: list[RecordingSpec], workers: int | None = None,
                progress: bool = True, ext: str = ".csv", scheduler: str | None = None,
                threads: int = 1, batch: int | None = None):
    """Write every spec's recording into ``out_dir``, in parallel (:mod:`runner`).

    The specs go in batches (:func:`simulated_recordings`: one ``mujoco.batch.Batch``
    on ``threads`` threads each); a batch is one task of the process pool or of Dask.
    Workers simulate and return the recordings; this process writes each one as it
    arrives (``euc_sim.io``: temp file then rename), so an interrupted run leaves
    complete recordings only, and a remote Dask cluster needs no shared folder.
    A recording whose rider falls (or whose worker dies) is named in the report and
    the manifest; the others are written.

    Parameters
    ----------
    out_dir : path
    specs : list of RecordingSpec
    workers : int, optional
        Worker processes (default: all cores; 1 runs in this process), or the local
        Dask cluster's workers.
    progress : bool
        A progress bar (over batches) on stderr.
    ext : {".csv", ".parquet"}
    scheduler : {None, "local"} or str
        See :func:`euc_sim.simulation.runner.run_tasks`.
    threads : int
        Threads of each batch (a worker machine's cores under Dask).
    batch : int, optional
        Recordings per batch (default: the specs shared evenly among the workers,
        at most 64 per batch).

    Returns
    -------
    RunReport
        By recording: ``results`` maps each written recording's name to its path;
        ``failed`` maps the others to the reason.  A manifest ``dataset.json`` is
        written beside them (``recordings`` in the order of ``specs``, ``failed``:
        name -> reason).
    """
    import os

    from euc_sim.simulation.runner import RunReport, check_backend, run_tasks

    out_dir = Path(out_dir)
    created = [d for d in (out_dir, *out_dir.parents) if not d.exists()]   # deepest first
    io.check_writable(out_dir / "dataset.json")
    check_backend(scheduler, workers)
    if batch is None:            # as many batches as workers (a Dask cluster: 2 unless told)
        shares = workers or (2 if scheduler is not None else os.cpu_count() or 1)
        batch = min(64, max(1, -(-len(specs) // shares)))
    if not (isinstance(batch, int) and batch >= 1):
        raise InputError(f"batch: expected a positive number of recordings, got {batch!r}")
    groups = {f"batch{i // batch:04d}": specs[i:i + batch] for i in range(0, len(specs), batch)}

    written: dict[str, Path] = {}
    fell: dict[str, str] = {}

    def write(name: str, values) -> None:
        for spec, value in zip(groups[name], values):
            if isinstance(value, str):
                fell[spec.name] = value
            else:
                rec, meta, truth = value
                written[spec.name] = io.write_recording(rec, out_dir / f"{spec.name}{ext}", meta, truth)

    try:
        by_batch = run_tasks(_make_batch, [(n, (g, threads)) for n, g in groups.items()], scheduler=scheduler,
                             workers=workers, progress=progress, desc="dataset", on_result=write)
    except BaseException:        # no scheduler, an interruption: no folder left that this run made empty
        for d in created:
            if d.is_dir() and not any(d.iterdir()):
                d.rmdir()
        raise
    for name, reason in by_batch.failed.items():      # a batch that died: each of its recordings named
        fell.update({spec.name: reason for spec in groups[name]})
    report = RunReport(names=[s.name for s in specs], backend=by_batch.backend, seconds=by_batch.seconds)
    report.results = {s.name: written[s.name] for s in specs if s.name in written}
    report.failed = {s.name: fell[s.name] for s in specs if s.name in fell}
    io.write_json(out_dir / "dataset.json", {
        "recordings": [p.name for p in report.results.values()],
        "maneuvers": {s.name: s.maneuver.name for s in specs},
        "duration": specs[0].duration if specs else math.nan,
        "failed": report.failed,
    })
    return report

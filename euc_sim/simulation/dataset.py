"""Synthetic recordings: simulate, sample like motion capture, write with sidecars.

:func:`simulated_recording` makes one recording in memory; :func:`run_dataset` writes a
set shaped like the paper's longitudinal recordings (Table 1, plus stop-and-go) in
parallel (:mod:`euc_sim.simulation.runner`).  Recording i of a dataset with seed S has
the seed ``SeedSequence(S).spawn(n)[i]`` (rider noise from it, measurement noise from
(s, 120)), so every file is reproducible on its own.  A dataset's folder appears whole
or not at all, and a rerun replaces only a dataset of the same plan (:func:`plan_digest`).
"""

from __future__ import annotations

import hashlib
import json
import math
import os
import shutil
import tempfile
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
from euc_sim.simulation import effects as fx, runner
from euc_sim.simulation.maneuvers import Maneuver, make_maneuver
from euc_sim.simulation.engine import default_rider, simulate, true_params

__all__ = ["PAPER_SET", "DEFAULT_RIDER_NOISE", "RecordingSpec", "simulated_recording", "simulated_recordings",
           "dataset_plan", "run_dataset", "plan_digest", "DATASET_BATCH"]

#: The paper's longitudinal maneuvers (Table 1) and how many recordings of each, plus
#: stop-and-go, which identifies h best (docs/scale.md).
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
    #: out-of-catalog F(t) at G, N (:func:`simulate`); in the truth file only
    external_force: object = None
    #: shape of h(t) with ``cog_height_drift`` (:class:`~euc_sim.simulation.drift.DriftShape`)
    drift_shape: object = None


def _request(spec: RecordingSpec) -> dict:
    """The spec's run as keyword arguments of :func:`simulate`."""
    return dict(maneuver=spec.maneuver, duration=spec.duration, params=spec.params, motor=spec.motor,
                rider=spec.rider or default_rider(spec.params, spec.motor), seed=spec.seed,
                engine=spec.engine, variant=spec.variant, effects=dict(spec.effects),
                rolling_model=spec.rolling_model, external_force=spec.external_force,
                drift_shape=spec.drift_shape)


def simulated_recording(spec: RecordingSpec):
    """Simulate and sample one recording: (recording, meta, truth), the CONTRACT columns at
    120 Hz, the ``NAME.json`` sidecar and the ``NAME.truth.json`` content; ``FallError`` when
    the rider falls.
    """
    return _sampled(spec, simulate(**_request(spec)))


def simulated_recordings(specs: list[RecordingSpec], nthread: int = 1) -> list:
    """:func:`simulated_recording` of many specs, in MuJoCo batches on ``nthread`` threads
    (:func:`euc_sim.simulation.mujoco_batch.simulate_rides`); per spec, in order, its
    ``(recording, meta, truth)`` or the ``FallError`` of its rider.
    """
    from euc_sim.simulation.mujoco_batch import simulate_rides  # deferred: loads scipy.linalg, mujoco (0.4 s)

    runs = simulate_rides([_request(s) for s in specs], nthread=nthread)
    return [run if isinstance(run, Exception) else _sampled(spec, run) for spec, run in zip(specs, runs)]


def _sampled(spec: RecordingSpec, run):
    """The recording, sidecar and truth of a spec's simulated run."""
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
        "effects": {k: {"value": v, "unit": fx.get(k).unit} for k, v in eff.items()},
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


#: The ranges each maneuver's options are drawn from, m/s and s (others: ``v`` in [2, 3] m/s).
_OPTION_DRAWS = {"constant_speed": {"v": (2.0, 4.0)},
                 "acceleration": {"v0": (0.5, 1.5), "v1": (3.0, 4.5), "start": (2.0, 4.0), "ramp": (3.0, 5.0)},
                 "deceleration": {"v0": (3.0, 4.5), "v1": (0.3, 1.0), "start": (2.0, 4.0), "ramp": (3.0, 5.0)}}


def dataset_plan(seed: int = 0, duration: float = 15.0, counts=PAPER_SET, params: Params = TABLE3,
                 noise: str = "paper", rider_noise: float = DEFAULT_RIDER_NOISE,
                 engine: str = "mujoco", effects: Mapping[str, float] | None = None) -> list[RecordingSpec]:
    """Specs of a paper-like dataset (``counts``: (maneuver, count) pairs), speeds varied per
    recording from the dataset ``seed``; each recording ``duration`` s long with ``noise``,
    rider noise ``rider_noise``, N·m, on ``engine``, with ``effects`` in every one.
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
            draws = _OPTION_DRAWS.get(name, {"v": (2.0, 3.0)})      # drawn in this order
            man = make_maneuver(name, **{key: float(rng.uniform(*span)) for key, span in draws.items()})
            specs.append(RecordingSpec(f"{name}_{j + 1:02d}", man, duration, rec_seed, params,
                                       tuple(sorted(dict(effects or {}).items())), noise, engine,
                                       motor=motor, rider=rider))
            i += 1
    return specs


#: Recordings per task of :func:`run_dataset` unless told: fixed by the plan, never by the
#: backend, so that serial, pool and Dask runs give the same bytes (the batched rider's rounding).
DATASET_BATCH = 8
#: The manifest beside the recordings.
MANIFEST = "dataset.json"


def _make_batch(args):
    """Worker side: one batch of recordings in memory, a fallen rider's spec as its one-line reason."""
    specs, nthread = args
    return [runner._reason(v) if isinstance(v, Exception) else v for v in simulated_recordings(specs, nthread)]


def plan_digest(specs: list[RecordingSpec], ext: str = ".csv") -> str:
    """SHA-256 (hex) of everything that makes a dataset's files: every spec's settings and the format ``ext``."""
    def one(s: RecordingSpec) -> dict:
        force = s.external_force
        return {"name": s.name, "maneuver": s.maneuver.as_dict(), "duration": s.duration, "seed": s.seed,
                "params": s.params.as_dict(), "effects": s.effects, "noise": s.noise, "engine": s.engine,
                "variant": s.variant, "hide_torques": s.hide_torques, "motor": s.motor.as_dict(),
                "rider": (s.rider or default_rider(s.params, s.motor)).as_dict(),
                "rolling_model": s.rolling_model,
                "external_force": None if force is None else getattr(force, "as_dict", lambda: repr(force))(),
                "drift_shape": None if s.drift_shape is None else s.drift_shape.as_dict()}
    text = json.dumps(io.to_jsonable({"format": ext, "recordings": [one(s) for s in specs]}), sort_keys=True)
    return hashlib.sha256(text.encode("utf-8")).hexdigest()


def _check_folder(out_dir: Path, digest: str) -> None:
    """Raise ``InputError`` unless ``out_dir`` is missing, empty, or a dataset of the same plan
    (manifest ``plan`` = ``digest``) holding nothing else.
    """
    if not out_dir.exists():
        return
    if not out_dir.is_dir():
        raise InputError(f"dataset folder {out_dir}: exists and is not a folder")
    present = {p.name for p in out_dir.iterdir()}
    if not present:
        return
    try:
        old = json.loads((out_dir / MANIFEST).read_text(encoding="utf-8"))
        ours = {MANIFEST} | {n for r in old["recordings"] for n in (r, *(p.name for p in io.sidecar_paths(r)))}
        same = old.get("plan") == digest and present <= ours
    except (OSError, ValueError, KeyError, TypeError):
        same = False
    if not same:
        raise InputError(f"dataset folder {out_dir}: not empty and not a previous dataset of these settings "
                         f"(its {MANIFEST} is missing or names another plan, or other files are there); "
                         f"choose a new or empty folder")


class _Staging:
    """A hidden folder beside ``out_dir`` (``.NAME.partial-PID-XXXX``) that :meth:`commit` renames
    into place; removed otherwise, with the parent folders this run made.  Partial folders of
    dead processes are removed first.
    """

    def __init__(self, out_dir: Path):
        self.out_dir = out_dir
        self.created = [d for d in (out_dir.parent, *out_dir.parent.parents) if not d.exists()]
        self.path: Path | None = None

    def __enter__(self) -> Path:
        parent, name = self.out_dir.parent, self.out_dir.name
        try:
            parent.mkdir(parents=True, exist_ok=True)
            _remove_stale(parent, f".{name}.partial-")
            self.path = Path(tempfile.mkdtemp(prefix=f".{name}.partial-{os.getpid()}-", dir=parent))
        except OSError as exc:
            self._clean()
            raise type(exc)(f"cannot write {self.out_dir}: {exc.strerror or type(exc).__name__} ({parent})") from None
        return self.path

    def commit(self) -> None:
        """Rename the staged folder into place, an existing dataset of the same plan moved aside and removed."""
        os.chmod(self.path, 0o777 & ~io._umask())          # mkdtemp makes 0700
        if self.out_dir.is_dir() and any(self.out_dir.iterdir()):
            aside = Path(tempfile.mkdtemp(prefix=f".{self.out_dir.name}.old-", dir=self.out_dir.parent))
            os.replace(self.out_dir, aside / self.out_dir.name)
            os.replace(self.path, self.out_dir)
            shutil.rmtree(aside)
        else:                        # missing or an empty folder: one rename (replaces an empty folder)
            os.replace(self.path, self.out_dir)
        self.path = None

    def __exit__(self, *exc) -> None:
        self._clean()

    def _clean(self) -> None:
        if self.path is not None:
            shutil.rmtree(self.path, ignore_errors=True)
            self.path = None
        if not self.out_dir.exists():
            for d in [self.out_dir.parent, *self.out_dir.parent.parents]:     # deepest first
                if d in self.created and d.is_dir() and not any(d.iterdir()):
                    d.rmdir()


def _remove_stale(parent: Path, prefix: str) -> None:
    """Remove ``PREFIX<pid>-XXXX`` folders in ``parent`` whose process no longer runs."""
    for d in parent.glob(prefix + "*"):
        pid = d.name[len(prefix):].split("-")[0]
        if not (d.is_dir() and pid.isdigit()):
            continue
        try:
            os.kill(int(pid), 0)
        except ProcessLookupError:
            shutil.rmtree(d, ignore_errors=True)
        except OSError:               # alive (another user's process): left alone
            pass


def run_dataset(out_dir: str | Path, specs: list[RecordingSpec], workers: int | None = None,
                progress: bool = True, ext: str = ".csv", scheduler: str | None = None,
                threads: int = 1, batch: int | None = None, settings: Mapping | None = None):
    """Write every spec's recording into ``out_dir``, in parallel (:mod:`runner`).

    Batches of specs (:func:`simulated_recordings`) are the tasks of the pool or of Dask;
    this process writes their recordings into a staging folder, then the manifest, then
    renames it into place: a failed run leaves nothing.  A recording whose rider falls (or
    whose worker dies) is named in the report and the manifest.

    Parameters
    ----------
    out_dir : path
        Missing, empty, or a previous dataset of the same plan (replaced).
    specs : list of RecordingSpec
    workers : int, optional
        Worker processes (default: all cores; 1: this process) or local Dask workers.
    progress : bool
        A progress bar on stderr.
    ext : {".csv", ".parquet"}
    scheduler : {None, "local"} or str
        See :func:`euc_sim.simulation.runner.run_tasks`.
    threads : int
        Threads of each batch.
    batch : int, optional
        Recordings per batch (default :data:`DATASET_BATCH`; the bytes depend on it).
    settings : mapping, optional
        The settings that made ``specs``, kept in the manifest.

    Returns
    -------
    RunReport
        ``results``: name → path of each written recording; ``failed``: name → reason.
        The manifest ``dataset.json`` holds ``recordings``, ``failed``, ``maneuvers``,
        ``duration``, ``seed``, ``settings`` and ``plan``.

    Raises
    ------
    ValueError
        For a refused folder or a bad ``batch``/backend, before anything runs.
    """
    out_dir = Path(out_dir)
    runner.check_backend(scheduler, workers)
    batch = DATASET_BATCH if batch is None else batch
    if not (isinstance(batch, int) and not isinstance(batch, bool) and batch >= 1):
        raise InputError(f"batch: expected a positive number of recordings, got {batch!r}")
    digest = plan_digest(specs, ext)
    _check_folder(out_dir, digest)
    groups = {f"batch{i // batch:04d}": specs[i:i + batch] for i in range(0, len(specs), batch)}
    written: dict[str, str] = {}
    fell: dict[str, str] = {}
    staging = _Staging(out_dir)
    with staging as stage:
        def write(name: str, values) -> None:
            for spec, value in zip(groups[name], values):
                if isinstance(value, str):
                    fell[spec.name] = value
                else:
                    rec, meta, truth = value
                    written[spec.name] = io.write_recording(rec, stage / f"{spec.name}{ext}", meta, truth).name

        by_batch = runner.run_tasks(_make_batch, [(n, (g, threads)) for n, g in groups.items()], scheduler=scheduler,
                             workers=workers, progress=progress, desc="dataset", on_result=write)
        for name, reason in by_batch.failed.items():      # a batch that died: each of its recordings named
            fell.update({spec.name: reason for spec in groups[name]})
        report = runner.RunReport(names=[s.name for s in specs], backend=by_batch.backend, seconds=by_batch.seconds)
        report.results = {s.name: out_dir / written[s.name] for s in specs if s.name in written}
        report.failed = {s.name: fell[s.name] for s in specs if s.name in fell}
        settings = dict(settings or {})
        io.write_json(stage / MANIFEST, {
            "recordings": [p.name for p in report.results.values()],
            "maneuvers": {s.name: s.maneuver.name for s in specs},
            "duration": specs[0].duration if specs else math.nan,
            "failed": report.failed,
            "seed": settings.get("seed"),
            "settings": settings,
            "plan": digest,
        })
        staging.commit()
    return report

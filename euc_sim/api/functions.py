"""The public API's functions; each returns a typed result of :mod:`euc_sim.api.results`.

Heavy packages (MuJoCo, scipy, pandas) load inside the functions, so ``import euc_sim`` stays
fast.  Bad input raises ``ValueError`` (or ``OSError``), one line naming the file, column or parameter.
"""

from __future__ import annotations

import math
import warnings
from pathlib import Path
from typing import TYPE_CHECKING, Callable, Mapping, Sequence

from euc_sim import io
from euc_sim.api.results import Crosscheck, CrosscheckRow, Diagnosis, Identification, Recording, Rendering, RideAnalysis
from euc_sim.controllers.motor import MotorPD
from euc_sim.controllers.rider import DEFAULT_RIDER_NOISE
from euc_sim.errors import InputError
from euc_sim.identification.h_fit import BOOTSTRAP_BLOCK, identify_recordings, load
from euc_sim.identification.recordings import read_recording as _read_recording
from euc_sim.model.parameters import TABLE3, Params, check_plausible
from euc_sim.rides.request import RideRequest, ride_request
from euc_sim.simulation.engine import default_rider
from euc_sim.simulation.maneuvers import MANEUVERS, make_maneuver

if TYPE_CHECKING:
    from euc_sim.rides.source.ride import Ride

__all__ = ["simulate", "write_recording", "read_recording", "identify", "diagnose", "read_ride",
           "analyse_ride", "render", "crosscheck"]


def _params(params):
    """``Params``, a mapping of Table 3 names to values (checked as plausible), or None."""
    if params is None or not isinstance(params, Mapping):
        return params

    return check_plausible(Params.from_mapping(dict(params)), params)


def simulate(maneuver="constant_speed", duration: float = 15.0, *, seed: int = 0, params=None,
             effects: Mapping[str, float] | None = None, noise: str = "paper", engine: str = "mujoco",
             variant: str = "ideal", hide_torques: bool = False, motor=None,
             rider_noise: float | None = None, rider_delay: float = 0.15, rolling_model: str = "moment",
             drift_shape=None, name: str = "recording") -> Recording:
    """Closed-loop simulation (the paper's eqs. 5-8, MuJoCo at 1 kHz), sampled at 120 Hz as a recording.

    Parameters
    ----------
    maneuver : str or Maneuver
        ``"constant_speed"``, ``"acceleration"``, ``"deceleration"``, ``"stop_and_go"`` or a
        :class:`euc_sim.simulation.maneuvers.Maneuver`.
    duration : float
        Length, s.
    seed : int
        Seed of the rider's motor noise and the measurement noise.
    params : Params or mapping, optional
        Table 3 values (default Table 3, h = 0.6 m); a mapping overrides some of them.
    effects : mapping, optional
        CONTRACT catalog effects, name → value in the catalog's unit.
    noise : {"paper", "none"}
        Measurement noise (0.2 mm, 0.5°) or none.
    engine : {"mujoco", "analytic"}
    variant : {"ideal", "contact"}
        MuJoCo ground model.
    hide_torques : bool
        Leave ``M_d``, ``M_h`` out of the recording.
    motor : MotorPD, optional
        Balance law (default K_p = 600 N·m/rad, K_d = 40 N·m·s/rad).
    rider_noise : float, optional
        Rider's motor noise, N·m (default :data:`~euc_sim.controllers.rider.DEFAULT_RIDER_NOISE`).
    rider_delay : float
        Rider's reaction delay, s.
    rolling_model : {"moment", "contact"}
    drift_shape : DriftShape, optional
        Shape of h(t) for the ``cog_height_drift`` effect.
    name : str
        The recording's name (its file stem when written).

    Returns
    -------
    Recording

    Examples
    --------
    >>> import euc_sim
    >>> rec = euc_sim.simulate("deceleration", duration=3.0, seed=1)
    >>> list(rec.data.columns[:4]), round(rec.duration, 2)
    (['t', 'x', 'gamma', 'phi'], 3.0)
    >>> rec.to_json()["maneuver"]
    'deceleration'
    """
    from euc_sim.simulation.dataset import RecordingSpec, simulated_recording  # deferred: loads multiprocessing, tqdm (0.02 s)

    if isinstance(maneuver, str):
        if maneuver not in MANEUVERS or maneuver == "profile":
            raise InputError(f"maneuver: unknown value {maneuver!r}; valid: "
                             f"{', '.join(m for m in MANEUVERS if m != 'profile')} (or a Maneuver)")
        maneuver = make_maneuver(maneuver)
    p = _params(params) or TABLE3
    motor = motor or MotorPD()
    rider = default_rider(p, motor, noise_std=DEFAULT_RIDER_NOISE if rider_noise is None else rider_noise,
                          delay=rider_delay)
    spec = RecordingSpec(name, maneuver, float(duration), int(seed), p, tuple(sorted((effects or {}).items())),
                         noise, engine, variant, bool(hide_torques), motor, rider, rolling_model,
                         drift_shape=drift_shape)
    data, meta, truth = simulated_recording(spec)
    return Recording(name=name, data=data, meta=meta, truth=truth)


def write_recording(recording: Recording, path) -> Path:
    """Write ``NAME.csv`` (or ``.parquet``), ``NAME.json`` and, for a simulation, ``NAME.truth.json``, atomically.

    Returns
    -------
    pathlib.Path
        The recording's path.

    Examples
    --------
    >>> import tempfile, pathlib, euc_sim
    >>> rec = euc_sim.simulate("constant_speed", duration=2.0)
    >>> folder = pathlib.Path(tempfile.mkdtemp())
    >>> euc_sim.write_recording(rec, folder / "ride.csv").name
    'ride.csv'
    >>> sorted(p.name for p in folder.iterdir())
    ['ride.csv', 'ride.json', 'ride.truth.json']
    """
    truth = None if recording.truth is None else dict(recording.truth)
    return io.write_recording(recording.data, path, dict(recording.meta), truth)


def read_recording(path) -> Recording:
    """Read and validate a recording (CSV or Parquet) and its sidecar; ``NAME.truth.json`` is never read.

    Gaps of a few samples are repaired with a warning.

    Examples
    --------
    >>> import tempfile, pathlib, euc_sim
    >>> path = pathlib.Path(tempfile.mkdtemp()) / "ride.csv"
    >>> _ = euc_sim.write_recording(euc_sim.simulate("constant_speed", duration=2.0), path)
    >>> rec = euc_sim.read_recording(path)
    >>> rec.name, len(rec.data), rec.truth is None
    ('ride.csv', 241, True)
    """
    data, meta = _read_recording(path)
    return Recording(name=Path(path).name, data=data, meta=meta, truth=None)


def identify(recordings: Sequence, *, bounds: tuple[float, float] = (0.1, 1.5), n_boot: int = 400,
             block: float | None = None, seed: int = 0, n_noise: int | None = None,
             params=None) -> Identification:
    """Identify the centre-of-gravity height h with the 3-DoF and 2-DoF models (eqs. 9-10, 13).

    Parameters
    ----------
    recordings : sequence of path or loaded recordings
        Paths, or recordings loaded with :func:`euc_sim.identification.h_fit.load`.
    bounds : (float, float)
        Search interval of h, m.
    n_boot : int
        Block-bootstrap replicates of the 95 % interval.
    block : float, optional
        Bootstrap block, s (default 1 s).
    seed : int
    n_noise : int, optional
        Replicates with fresh measurement noise that widen the interval (default 40).
    params : Params or mapping, optional
        Parameters of paths given (default: each sidecar's, else Table 3).

    Examples
    --------
    >>> import tempfile, pathlib, euc_sim
    >>> path = pathlib.Path(tempfile.mkdtemp()) / "brake.csv"
    >>> _ = euc_sim.write_recording(euc_sim.simulate("deceleration", duration=8.0, seed=2), path)
    >>> fit = euc_sim.identify([path], n_boot=60, n_noise=0)
    >>> abs(fit.h - 0.6) < 0.05, sorted(fit.to_json()["models"])
    (True, ['2dof', '3dof'])
    """
    if not recordings:
        raise InputError("identify: no recordings given")
    p = _params(params)
    recs = [r if hasattr(r, "kin") else load(r, params=p) for r in recordings]
    res = identify_recordings(recs, bounds=bounds, n_boot=n_boot,
                              block=BOOTSTRAP_BLOCK if block is None else block, seed=seed, n_noise=n_noise)
    return Identification(recordings=tuple(r.name for r in recs), models=res["pooled"],
                          per_recording=tuple(res["per_recording"]))


def diagnose(recording, *, params=None, resimulate: bool = True, calibrate: bool = True, seed: int = 0,
             progress: Callable[[str], None] | None = None) -> Diagnosis:
    """Find the physics the nominal model leaves out of a recording (residual M_d,1 − M_d,2).

    Parameters
    ----------
    recording : path or pandas.DataFrame
        A CONTRACT recording with its sidecar.
    params : Params or mapping, optional
        Nominal parameters (default: the sidecar's, else Table 3); h is identified.
    resimulate : bool
        Re-simulate the maneuver with the accepted effects (seconds to minutes).
    calibrate : bool
        On a 3-D ride, calibrate ``lateral_dynamics`` on a simulated twin.
    seed : int
        Seed of the noise-floor draw.
    progress : callable, optional
        Receives a short line at each step.

    Examples
    --------
    >>> import tempfile, pathlib, euc_sim
    >>> path = pathlib.Path(tempfile.mkdtemp()) / "slope.csv"
    >>> rec = euc_sim.simulate("stop_and_go", duration=12.0, seed=3, effects={"road_slope": 0.05},
    ...                        hide_torques=True)
    >>> _ = euc_sim.write_recording(rec, path)
    >>> d = euc_sim.diagnose(path, resimulate=False)
    >>> [e["name"] for e in d.effects], abs(d.effects[0]["estimate"] - 0.05) < 0.01
    (['road_slope'], True)
    >>> sorted(k for k in d.to_json() if k in ("recording", "nominal_rmse", "effects", "unexplained", "windows"))
    ['effects', 'nominal_rmse', 'recording', 'unexplained', 'windows']
    """
    from euc_sim.diagnosis.pipeline import diagnose as run  # deferred: loads scipy (0.7 s)

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")          # repaired gaps are reported by the reader
        result = run(recording, params=_params(params), resimulate=resimulate, calibrate=calibrate,
                     seed=seed, progress=progress)
    return Diagnosis.from_dict(result, series=result.get("_series", {}))


def read_ride(path, *, layout: str | None = None) -> Ride:
    """Read a WheelLog, EUC World or DarknessBot log into a :class:`~euc_sim.rides.source.ride.Ride` (SI units).

    ``layout`` forces ``"wheellog"``, ``"eucworld"`` or ``"darknessbot"`` (default: from the header).

    Examples
    --------
    >>> import tempfile, pathlib, euc_sim
    >>> from euc_sim.rides.synth.lawsynth import law_ride, wheellog_log
    >>> path = wheellog_log(law_ride(seed=1, duration=60.0), pathlib.Path(tempfile.mkdtemp()) / "log.csv", seed=1)
    >>> ride = euc_sim.read_ride(path)
    >>> ride.layout, ride.duration > 50, "v" in ride.data.columns
    ('wheellog', True, True)
    """
    from euc_sim.rides.source.logs import read_log  # deferred: loads euc_sim.rides.source.bounds (0.01 s)

    return read_log(path, layout=layout, emit_warnings=False)    # the reader's notes are in .warnings


def analyse_ride(log, compare=None, *, report_dir=None, simulate: bool = False, jobs: int = 1,
                 progress: Callable[[str], None] | None = None, **options) -> RideAnalysis:
    """Everything ``euc-sim ride`` finds in a ride log, optionally tested on ``compare``.

    Parameters
    ----------
    log, compare : path
        The ride to fit and, optionally, a ride of the same wheel to test on.
    report_dir : path, optional
        Folder for the report page and figures.
    simulate : bool
        Also replay the ride (minutes; ``calibrate_rider`` needs it).
    jobs : int
        Threads for that replay.
    progress : callable, optional
    **options
        :func:`~euc_sim.rides.request.ride_request`'s keywords; a bad value is refused with the
        command's line, naming the option (``--n-boot`` for ``n_boot``).

    Examples
    --------
    >>> import tempfile, pathlib, euc_sim
    >>> from euc_sim.rides.synth.lawsynth import law_ride, wheellog_log
    >>> path = wheellog_log(law_ride(seed=1, duration=200.0), pathlib.Path(tempfile.mkdtemp()) / "log.csv", seed=1)
    >>> ride = euc_sim.analyse_ride(path, n_boot=20, simulate=False)
    >>> ride.error_unit, ride.heldout_error_augmented <= ride.heldout_error_nominal
    ('W', True)
    >>> sorted(k for k in ride.to_json() if k.startswith("heldout_error_"))[:2]
    ['heldout_error_all_candidates', 'heldout_error_augmented']
    """
    return analyse_request(ride_request(log, compare, simulate=simulate, **options), report_dir, jobs, progress)


def analyse_request(req: RideRequest, report_dir=None, jobs: int = 1, progress=None) -> RideAnalysis:
    """The pipeline on a :class:`~euc_sim.rides.request.RideRequest`, then the report folder when asked (written at the end)."""
    from euc_sim.rides.pipeline import ride_pipeline  # deferred: loads scipy (1.1 s)
    from euc_sim.report.ride.report_files import write_report  # deferred: loads scipy, plotly (1.2 s)

    res = ride_pipeline(req, jobs=jobs, progress=progress)
    files = None
    if report_dir is not None:
        if progress:
            progress(f"writing the report to {report_dir}")
        files = write_report(res, Path(report_dir))
    return RideAnalysis(res, files)


def render(recording, out, *, fps: float = 30.0, width: int = 640, height: int = 480,
           time: float | None = None, progress: bool = False) -> Rendering:
    """Replay a recording in the 3-D model with MuJoCo's offscreen renderer.

    Parameters
    ----------
    recording : path
        With ``psi``, ``theta``, ``gamma`` and the C (or E) marker columns.
    out : path
        ``.mp4`` or ``.gif`` (a video) or ``.png`` (one frame at ``time``).
    fps : float
        Frames per second, in [1, 120].
    width, height : int
        Pixels.
    time : float, optional
        The ``.png`` frame's time, s (default: the middle).
    progress : bool
        A progress bar on stderr.

    Examples
    --------
    >>> import tempfile, pathlib, euc_sim
    >>> from euc_sim.simulation.spatial import write_spatial
    >>> folder = pathlib.Path(tempfile.mkdtemp())
    >>> rec = write_spatial(folder / "turn.csv", "circle", 2.0)
    >>> euc_sim.render(rec, folder / "frame.png", width=160, height=120).frames   # doctest: +SKIP
    1
    """
    from euc_sim.simulation.render import render_recording  # deferred: loads imageio, tqdm (0.03 s)

    out = Path(out)
    if out.suffix.lower() not in (".mp4", ".gif", ".png"):
        raise InputError(f"out must end in .mp4, .gif or .png, got {str(out)!r}")
    if not (math.isfinite(fps) and 1 <= fps <= 120):
        raise InputError(f"fps must be in [1, 120], got {fps!r}")
    n = render_recording(recording, out, fps=fps, width=width, height=height, frame_time=time,
                         progress=progress)
    return Rendering(path=str(out), frames=int(n), fps=float(fps), width=int(width), height=int(height))


def crosscheck(samples: int = 2500, *, params=None, mjcf=None,
               progress: Callable[[str], None] | None = None) -> Crosscheck:
    """Check the MuJoCo model against the analytic equations (5)-(8) on random states and trajectories.

    Parameters
    ----------
    samples : int
        Random states per parameter set (at least 1).
    params : Params or mapping, optional
        One parameter set to check instead of the built-in four.
    mjcf : path, optional
        An MJCF file (default ``mjcf/euc_planar.xml``).
    progress : callable, optional

    Examples
    --------
    >>> import euc_sim
    >>> euc_sim.crosscheck(samples=20).ok
    True
    """
    from euc_sim.model import crosscheck as cc  # deferred: loads scipy (0.7 s)

    if samples < 1:
        raise InputError(f"samples must be at least 1, got {samples}")
    sets = dict(cc.PARAMETER_SETS) if params is None else {"user": _params(params)}
    checks = cc.run_all(samples, progress=progress, sets=sets, mjcf=mjcf)
    rows = tuple(CrosscheckRow(c.name, float(c.value), float(c.bound), bool(c.ok), c.detail) for c in checks)
    return Crosscheck(ok=all(r.ok for r in rows), checks=rows)

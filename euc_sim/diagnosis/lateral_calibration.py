"""The lateral term calibrated on a simulated twin of the ride.

Through the recording the ``lateral_dynamics`` estimate of a 3-D ride runs low: at 1 kHz the
catalogued term fits the spatial model's coupling at s = 0.99–1.02, through a 120 Hz motion
capture at 0.90–0.93 (docs/spatial.md, "Through the recording": the Section 2 projection of
the markers, the wheel row, the sampling and the term filter).  That loss belongs to the
pipeline, and a simulation measures it on the ride itself:

1. the ride's plan (the sidecar's 3-D path with its ``maneuver_options`` speed and turn
   radius; where the options are missing, the mean speed, and the distance over the heading
   change where the yaw rate turns, read from the recording) is ridden again in the spatial model
   (:func:`euc_sim.simulation.spatial.simulate_3d`) with the fitted h and the simulator's own
   riders, without motor noise;
2. the twin is recorded as the recording was (its sampling rate and its columns,
   :func:`~euc_sim.simulation.spatial.spatial_recording`, no sensor noise: no draw, so the
   calibration is deterministic) and diagnosed as it was;
3. its estimate over its own truth (CONTRACT's peak tilt: the band peak of its 1 kHz tilt,
   :func:`euc_sim.simulation.effects.band_peak_tilt`) is the pipeline's gain b_k for each
   choice k the recording cannot make (the ``alternatives`` of
   :func:`euc_sim.diagnosis.estimates.coupling_of`); the recording's estimate of each choice
   is divided by its own gain (:func:`calibrate_item`).  The interval adds the calibrated
   choices' reach and the coupling's 95 % interval in quadrature.

The twin also says how much structure the catalogued term leaves on a ride of the spatial
model itself (its held-out RMSE): the model's floor, which :func:`model_floor` adds to the
noise floor of the ``unexplained`` test (on a noise-free recording the noise floor is the
interpolation's own 5–7·10⁻⁵ N·m, and every ride was flagged for the term's approximation),
and what the twin's diagnosis names beside the lateral term is not named on the recording
(:func:`twin_artifacts`).  The rider's own motor noise excites lateral motion (his twist)
that the term does not model, so that floor is measured on twins whose rider carries the
noise the recording shows (:func:`noisy_twins`: the level read from the recorded M_h by
:mod:`euc_sim.diagnosis.rider_noise`, :data:`NOISE_DRAWS` draws seeded from the recording);
the calibration of the estimate keeps the noise-free twin, so the interval is unchanged.
"""

from __future__ import annotations

import math

import numpy as np
import pandas as pd

from euc_sim.controllers.motor import MotorPD
from euc_sim.diagnosis.prepare import Prepared
from euc_sim.diagnosis.rider_noise import motor_noise_level, recording_seed
from euc_sim.simulation import effects
from euc_sim.simulation.engine import default_rider
from euc_sim.simulation.spatial import PATHS, simulate_3d, spatial_recording

__all__ = ["plan_of", "twin_recording", "calibrate_item", "model_floor", "twin_floor", "calibrate_lateral",
           "noisy_twins", "twin_artifacts", "NOISE_DRAWS"]

#: Markers a recording must carry for the twin to be diagnosed the same way.
MARKERS = ("psi", "theta", "C_X", "C_Y", "C_Z", "E_X", "E_Y", "E_Z")

#: Draws of the noisy twin (:func:`noisy_twins`) whose held-out RMSEs make the model's floor.
NOISE_DRAWS = 2


def plan_of(prep: Prepared) -> dict | None:
    """The ride's plan: ``{"path", "speed" (m/s), "radius" (m or None), "from"}``, or None
    where the sidecar names no 3-D path or the recording lacks the markers.

    Speed and radius come from the sidecar's ``maneuver_options``; where absent, the mean
    forward speed and Σv / Σ|ψ̇| over the samples whose 2 s mean yaw rate is at least half
    its peak are read from the recording.
    """
    path = prep.meta.get("maneuver")
    if path not in PATHS or path == "straight" or prep.lateral is None or not set(MARKERS) <= set(prep.raw.columns):
        return None
    opts = prep.meta.get("maneuver_options") or {}
    v = np.abs(prep.qd[:, 0])
    speed = float(opts["speed"]) if opts.get("speed") else float(np.mean(v))
    radius = None
    if path != "slalom":
        radius = opts.get("radius")
        if not radius:     # distance over heading change where the 2 s mean yaw rate turns
            from scipy.ndimage import uniform_filter1d
            r = np.abs(uniform_filter1d(prep.lateral["psi_d"], max(int(round(2.0 / prep.kin.dt)), 1)))
            turning = r >= 0.5 * np.max(r)
            radius = float(np.sum(v[turning]) / np.sum(r[turning]))
    return {"path": path, "speed": speed, "radius": None if radius is None else float(radius),
            "from": "sidecar" if opts.get("speed") else "recording"}


def twin_recording(prep: Prepared, plan: dict, h: float, noise_std: float = 0.0,
                   seed: int = 0) -> tuple[pd.DataFrame, dict, float]:
    """Ride the plan again in the spatial model and record it as the recording was.

    Parameters
    ----------
    prep : Prepared
    plan : dict
        :func:`plan_of`.
    h : float
        The fitted h, m.
    noise_std : float
        The twin rider's motor noise, N·m (0: none, the calibration's twin).
    seed : int
        Seed of that noise (:func:`euc_sim.diagnosis.rider_noise.recording_seed`).

    Returns
    -------
    recording : pandas.DataFrame
        The twin's recording: the recording's own columns and sampling rate, no sensor noise.
    meta : dict
        Its sidecar (the recording's, without the plan's options: nothing to calibrate).
    truth : float
        Its peak tilt (the band peak of its 1 kHz tilt), rad.

    Raises
    ------
    ValueError
        when the twin falls (:class:`~euc_sim.simulation.errors.FallError`).
    """
    p = prep.params.replace(h=float(np.clip(h, 0.3, 1.1)))
    motor = MotorPD()
    t = prep.raw["t"].to_numpy(float)
    duration = float(t[-1] - t[0])
    run = simulate_3d(plan["path"], duration, params=p, speed=plan["speed"], motor=motor,
                      rider=default_rider(p, motor, noise_std=float(noise_std)), seed=int(seed),
                      radius=plan["radius"])
    rate = 1.0 / float(np.median(np.diff(t)))
    rec = spatial_recording(run, noise="none", rate=rate, hide_torques="M_d" not in prep.raw.columns)
    rec = rec[[c for c in rec.columns if c in prep.raw.columns]]
    meta = {k: v for k, v in prep.meta.items() if k != "maneuver_options"}
    truth = effects.band_peak_tilt(run["theta"].to_numpy(), float(run.attrs["dt"]))
    return rec, meta, float(truth)


def calibrate_item(item: dict, twin: dict, truth: float) -> dict | None:
    """The recording's ``lateral_dynamics`` item calibrated by its twin's.

    Parameters
    ----------
    item, twin : dict
        The ``lateral_dynamics`` effect items of the recording and of its twin (with
        ``coupling``: :func:`euc_sim.diagnosis.estimates.coupling_of`).
    truth : float
        The twin's peak tilt, rad.

    Returns
    -------
    dict or None
        The item with ``estimate`` and ``ci95`` calibrated and a ``calibration`` field
        (the uncalibrated estimate and interval, the twin's estimate, truth and gain b of
        each choice); None when the twin's coupling is not positive.

    Notes
    -----
    Choice k estimates a_k √s (a_k rad per √s); the twin's gain is
    b_k = a_k,twin √s_twin / truth_twin and the calibrated choice c_k = a_k / b_k.  The
    estimate is ĉ = c_first √s.  The interval adds, each way, the choices' relative reach
    (1 − min_k c_k / c_first, max_k c_k / c_first − 1) and the coupling interval's
    (1 − √(s_lo / s), √(s_hi / s) − 1) in quadrature: the two are independent errors.
    Quadrature rather than product: see
    docs/coverage.md#calibrated-on-a-simulated-twin-of-the-ride-the-interval-measured-cause.
    """
    cp, ct = item["coupling"], twin["coupling"]
    if ct["s"] <= 0 or cp["s"] <= 0 or truth <= 0:
        return None
    keys = [k for k in cp["alternatives"] if k in ct["alternatives"] and ct["alternatives"][k] > 0]
    if not keys:
        return None
    gain = {k: ct["alternatives"][k] * math.sqrt(ct["s"]) / truth for k in keys}
    cal = {k: cp["alternatives"][k] / gain[k] for k in keys}
    first = keys[0]
    s, (lo, hi) = cp["s"], cp["s_ci95"]
    est = cal[first] * math.sqrt(s)
    # relative reach of the choices (calibrated) and of the coupling's interval, each way
    env = (1.0 - min(cal.values()) / cal[first], max(cal.values()) / cal[first] - 1.0)
    samp = (1.0 - math.sqrt(lo / s), math.sqrt(hi / s) - 1.0)
    out = dict(item)
    out["estimate"] = est
    out["ci95"] = [est * (1.0 - math.hypot(env[0], samp[0])), est * (1.0 + math.hypot(env[1], samp[1]))]
    out["calibration"] = {
        "uncalibrated_estimate": item["estimate"], "uncalibrated_ci95": list(item["ci95"]),
        "twin_estimate": twin["estimate"], "twin_truth": truth, "gain": gain,
        "how": ("the ride's plan re-simulated in the spatial model with the fitted h, recorded as this "
                "recording was (no noise) and diagnosed: each choice divided by its gain on the twin")}
    return out


def twin_floor(twin: dict) -> float:
    """The lateral term's own remainder on the ride's twin, N·m: the noisy twins' floor
    (:func:`noisy_twins`) where there is one, else the noise-free twin's held-out RMSE."""
    noisy = twin.get("noisy") or {}
    return float(noisy["floor"]) if noisy.get("floor") is not None else float(twin["heldout"])


def model_floor(noise_floor: float, twin_heldout: float) -> float:
    """The floor of the ``unexplained`` test with the lateral term's own remainder, N·m:
    √(noise floor² + the twin's held-out RMSE²)."""
    return float(math.hypot(noise_floor, twin_heldout))


def calibrate_lateral(prep: Prepared, h: float, diagnose, draws: int | None = None) -> dict:
    """Ride, record and diagnose the twin of a 3-D ride.

    Parameters
    ----------
    prep : Prepared
    h : float
        The fitted h with the named effects, m.
    diagnose : callable
        :func:`euc_sim.diagnosis.pipeline.diagnose` (passed in: no import cycle); called
        with ``calibrate=False``.

    Returns
    -------
    dict
        ``done`` (bool); with ``done``: ``plan``, ``truth`` (rad), ``item`` (the twin's
        ``lateral_dynamics`` item, named or tentative), ``heldout`` (the twin's held-out
        RMSE, N·m), ``noisy`` (:func:`noisy_twins`); otherwise ``reason``.
    draws : int, optional
        Noisy twins (:data:`NOISE_DRAWS` by default; 0: none, the floor is the noise-free
        twin's).
    """
    plan = plan_of(prep)
    if plan is None:
        return {"done": False, "reason": "no 3-D path in the sidecar, or no tilt, yaw and C, E markers"}
    try:
        rec, meta, truth = twin_recording(prep, plan, h)
    except ValueError as exc:            # a fall of the twin
        return {"done": False, "plan": plan, "reason": f"the twin fell: {str(exc).splitlines()[0]}"}
    res = _diagnose_twin(rec, meta, prep, diagnose)
    items = [e for e in res["effects"] + res["tentative"] if e["name"] == "lateral_dynamics" and "coupling" in e]
    if not items:
        return {"done": False, "plan": plan, "reason": "the twin's diagnosis named no lateral_dynamics"}
    others = {e["name"]: e["estimate"] for e in res["effects"] + res["tentative"] if e["name"] != "lateral_dynamics"}
    out = {"done": True, "plan": plan, "truth": truth, "item": items[0], "heldout": float(res["augmented_rmse"]),
           "h": float(res["h_augmented"]), "names": others}
    out["noisy"] = noisy_twins(prep, plan, h, diagnose, NOISE_DRAWS if draws is None else draws)
    return out


def _diagnose_twin(rec: pd.DataFrame, meta: dict, prep: Prepared, diagnose) -> dict:
    return diagnose(rec, params=prep.params, meta=meta, resimulate=False, calibrate=False,
                    smoothing=prep.kin.smoothing)


def noisy_twins(prep: Prepared, plan: dict, h: float, diagnose, draws: int = NOISE_DRAWS) -> dict:
    """The twin with the rider's motor noise read from the recording: what the lateral term
    leaves on a ride of the spatial model whose rider is as noisy as this one.

    The level is :func:`euc_sim.diagnosis.rider_noise.motor_noise_level` of the recorded
    M_h at the twin rider's correlation time; each of ``draws`` twins takes the seed
    :func:`~euc_sim.diagnosis.rider_noise.recording_seed` (the recording's content and the
    draw's index), is recorded as the recording was (no sensor noise) and diagnosed.

    Returns
    -------
    dict
        ``level`` (N·m, or None without a recorded M_h), ``seeds``, ``heldout`` (each draw's
        held-out RMSE, N·m; a draw whose twin fell or named no ``lateral_dynamics`` is left
        out and counted in ``failed``) and ``floor``: the RMS of ``heldout`` (None when
        none), N·m.
    """
    out = {"level": None, "seeds": [], "heldout": [], "failed": 0, "floor": None}
    if "M_h" not in prep.raw.columns or draws <= 0:
        return out
    tau = default_rider(prep.params).noise_tau
    level = motor_noise_level(prep.raw["t"].to_numpy(float), prep.raw["M_h"].to_numpy(float), tau)
    if not math.isfinite(level):
        return out
    out["level"] = level
    for k in range(draws):
        seed = recording_seed(prep.raw, k)
        out["seeds"].append(seed)
        try:
            rec, meta, _ = twin_recording(prep, plan, h, noise_std=level, seed=seed)
        except ValueError:               # the noisy twin fell
            out["failed"] += 1
            continue
        res = _diagnose_twin(rec, meta, prep, diagnose)
        if not any(e["name"] == "lateral_dynamics" for e in res["effects"] + res["tentative"]):
            out["failed"] += 1
            continue
        out["heldout"].append(float(res["augmented_rmse"]))
    if out["heldout"]:
        out["floor"] = float(np.sqrt(np.mean(np.square(out["heldout"]))))
    return out


def twin_artifacts(decision: dict, twin: dict) -> list[str]:
    """Move the effects the twin names too from ``decision["effects"]`` to its ``tentative``.

    The twin has none of the catalog's other physics: what its diagnosis names beside
    ``lateral_dynamics`` (on 3-D rides a rider mass of 67–69 kg and a slope of −0.0003 rad,
    through the wheel row) is the lateral term's approximation seen through the recording,
    and the same name on the recording is no evidence of that physics.  Returns the names
    moved (a note in ``decision["notes"]`` says so).
    """
    moved = [e for e in decision["effects"] if e["name"] != "lateral_dynamics" and e["name"] in twin.get("names", {})]
    if moved:
        decision["effects"] = [e for e in decision["effects"] if e not in moved]
        decision["tentative"] = list(decision["tentative"]) + moved
        decision["notes"].append("not named, because the ride's simulated twin (the spatial model with none of "
                                 "them) names them too: " + ", ".join(
                                     f"{e['name']} (twin {twin['names'][e['name']]:.4g})" for e in moved))
    return [e["name"] for e in moved]

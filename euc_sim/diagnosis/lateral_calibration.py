"""The ``lateral_dynamics`` estimate of a 3-D ride calibrated on a simulated twin of the ride.

Through the recording the estimate runs low (docs/spatial.md#diagnosis-on-3-d-recordings).
The ride's plan (:func:`plan_of`) is ridden again in the spatial model with the fitted h,
recorded as the recording was (no noise: deterministic) and diagnosed; its estimate over
its own truth (the band peak of its tilt) is the pipeline's gain b_k of each choice k, by
which the recording's estimate is divided (:func:`calibrate_item`).  Twins whose rider
carries the recording's motor noise (:func:`noisy_twins`) give the model's floor that
:func:`model_floor` adds to the ``unexplained`` test's.  See
docs/coverage.md#calibrated-on-a-simulated-twin-of-the-ride-the-interval-measured-cause.
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
    """The ride's plan ``{"path", "speed" (m/s), "radius" (m or None), "from"}``, or None without a 3-D path or
    the markers.

    Speed and radius come from the sidecar's ``maneuver_options``, else from the recording:
    the mean forward speed and Σv / Σ|ψ̇| where the 2 s mean yaw rate is at least half its peak.
    """
    path = prep.meta.get("maneuver")
    if path not in PATHS or path == "straight" or prep.lateral is None or not set(MARKERS) <= set(prep.raw.columns):
        return None
    opts = prep.meta.get("maneuver_options") or {}
    v = np.abs(prep.kin.qd[:, 0])
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
        The twin rider's motor noise, N·m (0: none).
    seed : int
        Seed of that noise.

    Returns
    -------
    recording : pandas.DataFrame
        The recording's columns and sampling rate, no sensor noise.
    meta : dict
        Its sidecar.
    truth : float
        Its peak tilt, rad.

    Raises
    ------
    ValueError
        when the twin falls.
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
    """The recording's ``lateral_dynamics`` item calibrated by its twin's (None when the twin's coupling is not
    positive).

    Choice k estimates a_k √s; the twin's gain is b_k = a_k,twin √s_twin / truth_twin (``truth``
    in rad) and c_k = a_k / b_k; the estimate is c_first √s.  The interval adds the choices'
    relative reach and the coupling interval's in quadrature.  The item gains a
    ``calibration`` field (uncalibrated estimate and interval, the twin's estimate, truth, b).
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


def calibrate_lateral(prep: Prepared, h: float, diagnose) -> dict:
    """Ride, record and diagnose the twin of a 3-D ride.

    Parameters
    ----------
    prep : Prepared
    h : float
        The fitted h with the named effects, m.
    diagnose : callable
        :func:`euc_sim.diagnosis.pipeline.diagnose` (passed in: no import cycle).

    Returns
    -------
    dict
        ``done``; with it ``plan``, ``truth`` (rad), ``item`` (the twin's ``lateral_dynamics``
        item), ``heldout`` (N·m), ``noisy`` (:func:`noisy_twins`); otherwise ``reason``.
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
    out["noisy"] = noisy_twins(prep, plan, h, diagnose)
    return out


def _diagnose_twin(rec: pd.DataFrame, meta: dict, prep: Prepared, diagnose) -> dict:
    return diagnose(rec, params=prep.params, meta=meta, resimulate=False, calibrate=False,
                    smoothing=prep.kin.smoothing)


def noisy_twins(prep: Prepared, plan: dict, h: float, diagnose) -> dict:
    """:data:`NOISE_DRAWS` twins whose rider carries the motor noise read from the recorded M_h.

    Returns
    -------
    dict
        ``level`` (N·m, None without M_h), ``seeds``, ``heldout`` (held-out RMSE per draw,
        N·m; a twin that fell or named no ``lateral_dynamics`` is counted in ``failed``) and
        ``floor``, their RMS (None when none), N·m.
    """
    out = {"level": None, "seeds": [], "heldout": [], "failed": 0, "floor": None}
    if "M_h" not in prep.raw.columns:
        return out
    tau = default_rider(prep.params).noise_tau
    level = motor_noise_level(prep.raw["t"].to_numpy(float), prep.raw["M_h"].to_numpy(float), tau)
    if not math.isfinite(level):
        return out
    out["level"] = level
    for k in range(NOISE_DRAWS):
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
    """Move the effects the twin names too from ``decision["effects"]`` to ``tentative``, with a note; returns
    their names.

    The twin has none of the catalog's other physics, so what it names beside
    ``lateral_dynamics`` is the term's approximation, not evidence.
    """
    moved = [e for e in decision["effects"] if e["name"] != "lateral_dynamics" and e["name"] in twin.get("names", {})]
    if moved:
        decision["effects"] = [e for e in decision["effects"] if e not in moved]
        decision["tentative"] = list(decision["tentative"]) + moved
        decision["notes"].append("not named, because the ride's simulated twin (the spatial model with none of "
                                 "them) names them too: " + ", ".join(
                                     f"{e['name']} (twin {twin['names'][e['name']]:.4g})" for e in moved))
    return [e["name"] for e in moved]

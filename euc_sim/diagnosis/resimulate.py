"""Step 6, model it: the accepted effects injected into the simulator, the maneuver re-simulated.

Analytic or MuJoCo (:func:`euc_sim.simulation.engine.simulate`), with the same
controllers; recording vs nominal vs augmented.
"""

from __future__ import annotations

import numpy as np

from euc_sim.diagnosis.prepare import Prepared
from euc_sim.model.parameters import Params
from euc_sim.simulation import engine as simulation, maneuvers
from euc_sim.simulation.drift import DriftShape
from euc_sim.simulation.lateral import LATERAL_INPUTS

__all__ = ["resimulate_recording"]


def _sim_params(p: Params, h: float) -> Params:
    return p.replace(h=float(np.clip(h, 0.3, 1.1)))


def _maneuver_of(prep: Prepared):
    """The planned maneuver: the sidecar's (name and ``maneuver_options``) when it names a
    built-in one, else the recording's own filtered speed as a ``profile``."""
    name = prep.meta.get("maneuver")
    opts = prep.meta.get("maneuver_options") or {}
    if isinstance(name, str) and name in maneuvers.MANEUVERS and name != "profile":
        try:
            args = ", ".join(f"{k} = {v:g}" if isinstance(v, (int, float)) else f"{k} = {v}"
                             for k, v in opts.items()) or "its default options"
            return maneuvers.make_maneuver(name, **opts), f"the sidecar's {name} ({args})"
        except ValueError:
            pass
    t = prep.kin.t
    tt = np.arange(t[0], t[-1], 0.1)
    v = np.interp(tt, t, prep.kin.qd[:, 0])
    return (maneuvers.Maneuver("profile", float(v[0]), (), (tuple((tt - t[0]).tolist()), tuple(v.tolist()))),
            "profile: the recording's own speed")


def resimulate_recording(prep: Prepared, result: dict, engine: str = "mujoco") -> dict:
    """Re-simulate the recording's maneuver, nominal and augmented, with the same controllers.

    The plan is the sidecar's built-in maneuver, else the recording's own speed profile; the
    nominal run uses the nominal h, the augmented one the re-identified h with the accepted
    effects injected as physics.  Returns ``done``; per run the RMSE of φ, γ (rad) and ẋ (m/s)
    against the recording; ``series`` for the figure; or ``reason``.
    """
    t = prep.kin.t
    k = prep.keep
    man, how = _maneuver_of(prep)
    duration = float(t[-1] - t[0])
    eff, tau = _injected(prep, result["effects"])
    runs = {"nominal": (_sim_params(prep.params, result["h_nominal"]), {}),
            "augmented": (_sim_params(prep.params, result["h_augmented"]), eff)}
    out = {"done": True, "engine": engine, "maneuver": how,
           "effects_injected": eff, "sensor_time_offset_applied": tau}
    rec_phi, rec_gam, rec_v = prep.kin.q[k, 2], prep.kin.q[k, 1], prep.kin.qd[k, 0]
    series = {"t": t[k], "recording_phi": rec_phi, "recording_speed": rec_v, "recording_gamma": rec_gam}
    sim_dt = simulation.DEFAULT_DT
    lat_motion = _lateral_motion(prep, duration, sim_dt) if "lateral_dynamics" in eff else None
    for label, (p, e) in runs.items():
        try:
            run = simulation.simulate(man, duration, params=p, engine=engine, effects=e, dt=sim_dt,
                                      lateral_motion=lat_motion if e else None,
                                      drift_shape=_drift_profile(result) if "cog_height_drift" in e else None)
        except ValueError as exc:      # FallError and SimulationError are ValueErrors
            out[label] = {"error": str(exc).splitlines()[0]}
            continue
        ts = run["t"].to_numpy() + t[0]
        phi = np.interp(t[k], ts, run["phi"].to_numpy())
        if label == "augmented" and tau:
            phi = np.interp(t[k] - tau, ts, run["phi"].to_numpy())
        gam = np.interp(t[k], ts, run["gamma"].to_numpy())
        vs = np.interp(t[k], ts, run["x_dot"].to_numpy())
        out[label] = {"rmse_phi": float(np.sqrt(np.mean((phi - rec_phi) ** 2))),
                      "rmse_gamma": float(np.sqrt(np.mean((gam - rec_gam) ** 2))),
                      "rmse_speed": float(np.sqrt(np.mean((vs - rec_v) ** 2)))}
        series[f"{label}_phi"] = phi
        series[f"{label}_speed"] = vs
        series[f"{label}_gamma"] = gam
    out["series"] = series
    return out


def _injected(prep: Prepared, named: list[dict]) -> tuple[dict, float]:
    """The simulator's effects from the named ones, and the rider channel's time offset, s."""
    eff = {}
    tau = 0.0
    for e in named:
        name, val = e["name"], float(e["estimate"])
        if name == "sensor_time_offset":
            tau = val
            continue
        if name == "lateral_dynamics" and prep.lateral is None:
            continue
        eff[name] = abs(val) if name in ("cog_height_drift", "lateral_dynamics") else val
    return eff, tau


def _lateral_motion(prep: Prepared, duration: float, sim_dt: float):
    """The recording's own tilt and yaw on the run's grid (only the prescribed
    :data:`~euc_sim.simulation.lateral.LATERAL_INPUTS`)."""
    from scipy.integrate import cumulative_trapezoid

    t = prep.kin.t
    grid = np.arange(int(round(duration / sim_dt)) + 1) * sim_dt + t[0]
    on = {key: np.interp(grid, t, prep.lateral[key]) for key in LATERAL_INPUTS}
    return maneuvers.LateralMotion(on["theta"], on["theta_d"],
                                   cumulative_trapezoid(on["psi_d"], grid, initial=0.0),
                                   on["psi_d"], on["psi_dd"])


def _drift_profile(result: dict):
    """The named drift's h(t) as the simulator's ``profile`` shape (times from the recording's start)."""
    item = next(e for e in result["effects"] if e["name"] == "cog_height_drift")
    ht = item["h_of_t"]
    t = np.asarray(ht["t"], float)
    return DriftShape("profile", knots_t=tuple((t - t[0]).tolist()),
                      knots_dh=tuple((np.asarray(ht["h"], float) - result["h_augmented"]).tolist()))

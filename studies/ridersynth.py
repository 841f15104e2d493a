"""A ride with a concealed rider (delay, bandwidth, motor noise), written as EUC World writes it.

The wheel runs the concealed firmware law of :mod:`euc_sim.rides.synth.lawsynth` (``WHEEL_LAW``) on its
road (``ROAD``) along its speed plan (:func:`euc_sim.rides.synth.lawsynth.profile`); the rider is
:func:`euc_sim.rides.rider.rider_params.rider_from` with the settings given.  The log has physical
battery power (:func:`euc_sim.rides.sim.simulate.battery_power` with :data:`DRIVETRAIN`), phase
current M_d/K_T and pitch in 0.1° steps.  The truth is returned, never written beside the log.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

from euc_sim.rides.synth.lawsynth import EW_HEADER, K_T, LAW, ROAD, _sample, profile

#: The wheel's law: lawsynth's concealed PD and tilt-back, with a torque limit (150 N·m) that the
#: rider's corrections do not reach (lawsynth's 45 N·m is a law-recovery case: along a log's
#: speed profile it throws every rider off).
WHEEL_LAW = {**LAW, "torque_limit": 150.0}
#: The paper's PD (600 / 40 N·m/rad, 250 N·m) as the wheel's law: a softer wheel under which a slow
#: or noisy rider falls (a twin of the ride table's Blitz and Master Pro fits, whose law is not
#: in their logs).
PAPER_LAW = {"Kp": 600.0, "Kd": 40.0, "torque_limit": 250.0}
#: The battery-power model of the written log (the balance's energy form): copper loss
#: k_cu, W/N², and idle drain, W.
DRIVETRAIN = {"copper_loss": 0.003, "drivetrain_idle_loss": 40.0}
#: The concealed rider: a 0.2 s delay, a softer than default rider, 5 N·m of noise.
RIDER = {"delay": 0.2, "bandwidth": 0.4, "noise_std": 5.0}


def rider_ride(seed: int, duration: float = 240.0, rider=RIDER, dt: float = 1e-3,
               law=WHEEL_LAW, params=None) -> pd.DataFrame:
    """The closed-loop ride under the wheel's ``law`` (MotorPD keywords), ``params`` (default Table 3):
    columns t, x_dot, gamma, gamma_dot, M_d (SI)."""
    from euc_sim.controllers.motor import MotorPD
    from euc_sim.model.parameters import TABLE3
    from euc_sim.rides.rider.rider_params import rider_from
    from euc_sim.simulation.engine import simulate
    from euc_sim.simulation.maneuvers import Maneuver

    motor = MotorPD(**law)
    t, v = profile(seed, duration)
    man = Maneuver(name="profile", table=(tuple(t.tolist()), tuple(v.tolist())))
    params = TABLE3 if params is None else params
    df = simulate(man, duration, params=params, motor=motor, rider=rider_from(rider, params, motor), seed=seed,
                  effects=ROAD, dt=dt)
    return df[["t", "x_dot", "gamma", "gamma_dot", "M_d"]]


def eucworld_power_log(ride: pd.DataFrame, path: Path, seed: int, R: float | None = None) -> Path:
    """EUC World CSV: irregular 5 Hz rows, battery power, phase current, 0.1° pitch."""
    from euc_sim.model.parameters import TABLE3
    from euc_sim.rides.sim.simulate import battery_power

    rng = np.random.default_rng(seed)
    ride = ride.assign(P=battery_power(ride["M_d"], ride["x_dot"], ride["gamma_dot"], R or TABLE3.R,
                                       DRIVETRAIN["copper_loss"], DRIVETRAIN["drivetrain_idle_loss"]))
    T = float(ride["t"].iloc[-1])
    ts = np.cumsum(rng.uniform(0.18, 0.22, int(T / 0.18)))
    ts = ts[ts < T - 0.5]
    s = _sample(ride, ts)
    t = ride["t"].to_numpy()
    n = int(round(0.2 / (t[1] - t[0])))
    c = np.cumsum(np.r_[0.0, ride["P"].to_numpy()])
    P = np.interp(ts, t[n - 1:], (c[n:] - c[:-n]) / n)
    volts = 84.0
    current = np.round(P / volts, 2)
    tilt = np.round(-np.degrees(s["gamma"]) - 2.0, 1)
    I_ph = np.round(s["M_d"] / K_T + rng.normal(0.0, 0.5, ts.size), 1)
    stamps = pd.Timestamp("2025-07-01 10:00:00") + pd.to_timedelta(np.round(ts, 3), unit="s")
    lines = [EW_HEADER]
    for st, v, i, ip, g in zip(stamps, s["x_dot"], current, I_ph, tilt):
        lines.append(f"{st:%Y-%m-%dT%H:%M:%S}.{st.microsecond // 1000:03d}+0200,{v * 3.6:.2f},"
                     f"{volts:.2f},{i:.2f},{ip:.1f},{volts * i:.0f},80,90,{g:.1f},0.0,")
    path.write_text("\n".join(lines) + "\n")
    return path


def concealed_fit_inputs(law=WHEEL_LAW, params=None):
    """What the fit is told: the ride's params, the wheel's ``law``, road and drivetrain, k_t."""
    from euc_sim.controllers.motor import MotorPD
    from euc_sim.model.parameters import TABLE3
    from euc_sim.rides.grids.signals import RideAssumptions

    return {"params": TABLE3 if params is None else params, "motor": MotorPD(**law), "effects": dict(ROAD),
            "drivetrain": dict(DRIVETRAIN), "assumptions": RideAssumptions(torque_constant=K_T)}

"""Recordings for the identification tests, made by the closed-loop simulator.

``euc_sim.simulation.engine.simulate`` runs the maneuver (MuJoCo engine, which
``euc-sim crosscheck`` proves equal to eqs. 5-8: data from the 3-DoF world) and ``euc_sim.simulation.mocap.motion_capture``
samples it at 120 Hz with the paper's noise (0.2 mm, 0.5°, one standard deviation)
or none.  Cached per process: each maneuver is simulated once.
"""

from __future__ import annotations

from functools import lru_cache

import pandas as pd

from euc_sim.simulation.mocap import motion_capture
from euc_sim.model.parameters import TABLE3
from euc_sim.simulation.engine import simulate

#: the simulator's default motor gains (controllers.motor.MotorPD)
KP_TRUE, KD_TRUE = 600.0, 40.0


@lru_cache(maxsize=None)
def run(maneuver: str, duration: float = 15.0) -> pd.DataFrame:
    """The 1 kHz closed-loop run (true states and torques)."""
    return simulate(maneuver, duration, params=TABLE3)


def recording(maneuver: str, noise: str = "paper", seed: int = 1, duration: float = 15.0) -> pd.DataFrame:
    """A 120 Hz CONTRACT recording of the run (a new frame each call)."""
    return motion_capture(run(maneuver, duration), TABLE3, noise=noise, seed=seed).copy()


#: the rollout fits' twin: h not Table 3's 0.6, so the fit must find it, not inherit it
H_TWIN = 0.55


@lru_cache(maxsize=None)
def twin_run() -> pd.DataFrame:
    """A 4 s deceleration (3 → 1 m/s) of a rider with h = :data:`H_TWIN`, no motor noise."""
    from euc_sim.simulation.engine import default_rider
    from euc_sim.simulation.maneuvers import make_maneuver

    p = TABLE3.replace(h=H_TWIN)
    man = make_maneuver("deceleration", v0=3.0, v1=1.0, start=0.5, ramp=2.5)
    return simulate(man, 4.0, params=p, rider=default_rider(p, noise_std=0.0), seed=3)


def twin_recording(noise: str):
    """:func:`twin_run` recorded at 120 Hz (``noise``: ``"paper"`` or ``"none"``, seed 5) and
    its kinematics under Table 3: ``(recording, kinematics)``."""
    from euc_sim.identification.processing import Smoothing, kinematics

    df = motion_capture(twin_run(), TABLE3.replace(h=H_TWIN), noise=noise, seed=5)
    return df, kinematics(df, TABLE3, Smoothing())

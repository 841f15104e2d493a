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

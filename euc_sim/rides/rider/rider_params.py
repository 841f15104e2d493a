"""The calibrated rider's three settings and the rider they make.

:data:`RIDER_PARAMS` names each fitted setting with its nominal value, search bounds and unit;
:func:`rider_from` designs the rider for given values.  The fit is
:func:`euc_sim.rides.rider.rider_fit.fit_rider`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Mapping

from euc_sim.controllers.design import DEFAULT_SCALES, design_rider
from euc_sim.controllers.motor import MotorPD
from euc_sim.controllers.rider import Rider
from euc_sim.model.parameters import Params
from euc_sim.rides.grids.rider_features import RiderFitError

__all__ = ["RiderParam", "RIDER_PARAMS", "rider_from"]


@dataclass(frozen=True)
class RiderParam:
    """A fitted rider setting: name, nominal value, search bounds, unit, log-scaled search."""

    name: str
    nominal: float
    lo: float
    hi: float
    unit: str
    log: bool

    def to_unit(self, value: float) -> float:
        """The value in the search's [0, 1] coordinate."""
        f = math.log if self.log else float
        return (f(value) - f(self.lo)) / (f(self.hi) - f(self.lo))

    def from_unit(self, u: float) -> float:
        """The value at the search coordinate u ∈ [0, 1]."""
        f, back = (math.log, math.exp) if self.log else (float, float)
        return back(f(self.lo) + u * (f(self.hi) - f(self.lo)))


#: The rider's fitted settings (default rider: 0.15 s, ρ = 1; generated recordings: 3 N·m).
RIDER_PARAMS = (RiderParam("delay", 0.15, 0.03, 0.40, "s", False),
                RiderParam("bandwidth", 1.0, 0.05, 20.0, "1", True),
                RiderParam("noise_std", 3.0, 0.3, 40.0, "N·m", True))


def rider_from(values: Mapping[str, float], params: Params, motor: MotorPD) -> Rider:
    """The rider with the given ``delay`` (s), ``bandwidth`` (1) and ``noise_std`` (N·m): LQR
    gains designed against ``motor`` on ``params``, Bryson's ankle-torque scale × √bandwidth.
    """
    bw = float(values["bandwidth"])
    if not (math.isfinite(bw) and bw > 0):
        raise RiderFitError(f"bandwidth must be a positive number, got {bw!r}")
    return design_rider(params, motor, delay=float(values["delay"]),
                        scales={"M_h": DEFAULT_SCALES["M_h"] * math.sqrt(bw)},
                        noise_std=float(values["noise_std"]))

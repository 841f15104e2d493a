"""Suspicions about a ride's input, said plainly instead of a confident absurd mass.

A spec whose weight or voltage is absurd, or a log in the wrong units
(mph read as km/h, mA read as A), must give one line and exit 2, or a warning
naming the suspicion; never a confident, absurd mass.  The spec's own values are
refused by :func:`euc_sim.rides.source.spec.read_spec` (:data:`SPEC_RANGE`); what only
shows against the log is found here:

- :func:`input_warnings`: the log's battery voltage against the spec's
  full-charge voltage (above 1.1× it, or a median below 0.65× it, which an
  empty pack at 3.0 V of 4.2 V per cell does not reach), and the wheel's speed against GPS speed (a speedometer
  reading 0.62 of GPS speed is a log in mph read as km/h);
- :func:`mass_suspicion`: a total mass no rider with a wheel has (outside
  :data:`TOTAL_MASS_RANGE`), which a log in the wrong units gives (mass ∝ I and
  ∝ 1/v²).  The mass is then withheld, with the reason.
"""

from __future__ import annotations

import numpy as np

__all__ = ["SPEC_RANGE", "TOTAL_MASS_RANGE", "SPEED_SCALE_RANGE", "input_warnings",
           "mass_suspicion"]

#: Plausible values of a wheel's spec: attribute -> (low, high, unit).
SPEC_RANGE = {"radius": (0.1, 0.4, "m"), "wheel_mass": (5.0, 100.0, "kg"),
              "battery_voltage": (24.0, 250.0, "V"), "top_speed": (10.0 / 3.6, 250.0 / 3.6, "m/s")}
#: A rider with a wheel weighs this much, kg (a child on a small wheel to a heavy
#: rider with gear on the heaviest wheel).
TOTAL_MASS_RANGE = (35.0, 350.0)
#: The wheel's speed against GPS speed: beyond this, the speed column is suspect.
SPEED_SCALE_RANGE = (0.75, 1.33)


def input_warnings(log, spec, scale) -> list[str]:
    """What the log and the spec say against each other, one sentence each.

    Parameters
    ----------
    log : RideLog
    spec : WheelSpec
    scale : SpeedScale
        The wheel's speed scale against GPS (:func:`euc_sim.rides.grids.power.speed_scale`).
    """
    from pathlib import Path

    name = Path(str(log.path)).name                 # no machine path in outputs
    out = []
    if scale.source != "assumed" and not SPEED_SCALE_RANGE[0] <= scale.estimate <= SPEED_SCALE_RANGE[1]:
        out.append(f"{name}: the wheel's speed reads {1 / scale.estimate:.2f} × GPS speed: the "
                   f"speed column may be in other units (mph read as km/h gives 0.62) or from "
                   f"another wheel size; every speed was rescaled by GPS, check the log")
    if spec.battery_voltage is not None and "voltage" in log.data:
        v = log.data["voltage"].to_numpy(float)
        v = v[np.isfinite(v) & (v > 0)]
        if v.size:
            hi, med = float(np.percentile(v, 99)), float(np.median(v))
            if hi > 1.1 * spec.battery_voltage or med < 0.65 * spec.battery_voltage:
                out.append(f"{name}: battery voltage {med:.0f} V (median), up to {hi:.0f} V, "
                           f"against the spec's full charge {spec.battery_voltage:g} V "
                           f"({Path(str(spec.source).split(' + ')[0]).name}): the spec may be "
                           f"another wheel's, or the voltage "
                           f"column in other units")
    return out


def mass_suspicion(estimate: float | None) -> str | None:
    """Why a total mass cannot be a rider with a wheel (kg), or None."""
    lo, hi = TOTAL_MASS_RANGE
    if estimate is None or lo <= estimate <= hi:
        return None
    return (f"the mass found, {estimate:.0f} kg, is no rider with a wheel ({lo:g}–{hi:g} kg): the "
            f"log is likely in other units (current in mA read as A makes it 1000× heavier, speed "
            f"in mph read as km/h 2.6× heavier without GPS), so it is withheld")

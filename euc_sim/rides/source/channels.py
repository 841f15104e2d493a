"""Which of a log's channels the wheel measured and which the app derived from others.

A derived channel carries no information beyond its inputs and, used as a
measurement, biases what is fitted on it: EUC World and WheelLog compute some
wheels' battery current as duty × phase current, and some wheels' duty from
speed and voltage alone.  Each check here names what it found.
"""

from __future__ import annotations

import numpy as np

from euc_sim.rides.source.ride import Ride

__all__ = ["current_from_phase", "duty_from_speed", "power_not_measured"]


def current_from_phase(log: Ride) -> bool:
    """True when the battery current is the app's duty × phase current, not a measurement (then
    the phase current adds nothing and is not used for the copper loss).
    """
    d = log.data
    if not {"current", "phase_current", "pwm"} <= set(d.columns):
        return False
    m = (d["current"].abs() > 2.0) & (d["pwm"] > 5.0)
    if m.sum() < 100:
        return False
    ratio = (d["current"][m].abs() / (d["pwm"][m] / 100.0 * d["phase_current"][m].abs())).to_numpy()
    return bool(np.median(np.abs(ratio - 1.0)) < 0.03)


def duty_from_speed(log: Ride) -> float | None:
    """The app's constant K (V per m/s) when its logged duty is K·v/V to 1 % RMS on moving
    samples (derived, not measured: no resistive drop); else None.
    """
    d = log.data
    if not {"pwm", "voltage"} <= set(d.columns):
        return None
    m = (d["v"] > 2.0) & np.isfinite(d["pwm"]) & np.isfinite(d["voltage"])
    if m.sum() < 100:
        return None
    v = d["v"][m].to_numpy(float)
    y = (d["pwm"][m] / 100.0 * d["voltage"][m]).to_numpy(float)
    K = float(np.sum(v * y) / np.sum(v * v))
    return K if np.sqrt(np.mean((y - K * v) ** 2)) < 0.01 * np.sqrt(np.mean(y ** 2)) else None


def power_not_measured(log: Ride) -> str:
    """Why an app-derived battery current carries no scale either ("" when it is measured)."""
    K = duty_from_speed(log)
    if K is None or not current_from_phase(log):
        return ""
    return (f"V·I is not battery power: the app's current is its duty × |phase current| and "
            f"its duty is {K:.3f} V per m/s × speed / voltage, so V·I = {K:.3f}·v·|I_ph|, a "
            f"force reading in the app's assumed motor constant whose scale the log cannot give")

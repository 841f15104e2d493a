"""Suspicions about a ride's input, said plainly instead of a confident absurd mass.

The spec's own values are refused by :func:`~euc_sim.rides.source.spec.read_spec`; what
shows only against the log is found here: :func:`input_warnings` (the log against the
spec, and the wheel's speed against GPS: 0.62 is mph read as km/h, beyond
:data:`TYRE_SCALE_RANGE` a mismatched tyre) and :func:`mass_suspicion` (a total mass
outside :data:`TOTAL_MASS_RANGE`, as wrong units give: m ∝ I and ∝ 1/v²), which withholds
the mass with the reason.
"""

from __future__ import annotations

from pathlib import Path

from euc_sim.rides.source.spec import SPEC_RANGE, SpecError, log_contradictions

__all__ = ["SPEC_RANGE", "TOTAL_MASS_RANGE", "SPEED_SCALE_RANGE", "TYRE_SCALE_RANGE",
           "input_warnings", "mass_suspicion"]

#: A rider with a wheel weighs this much, kg (a child on a small wheel to a heavy
#: rider with gear on the heaviest wheel).
TOTAL_MASS_RANGE = (35.0, 350.0)
#: The wheel's speed against GPS speed: beyond this, the speed column is suspect.
SPEED_SCALE_RANGE = (0.75, 1.33)
#: GPS speed over the wheel's beyond which (its whole 95 % interval) the tyre is not the one the
#: wheel assumes: 8 % slow (tyre tolerance) to 15 % fast (speedometers read high by design).
TYRE_SCALE_RANGE = (1 / 1.15, 1.08)


def input_warnings(log, spec, scale) -> list[str]:
    """What the log, the spec and the GPS speed ``scale`` (SpeedScale) say against each other,
    one sentence each.
    """
    name = Path(str(log.path)).name                 # no machine path in outputs
    out = []
    if scale.source != "assumed" and not SPEED_SCALE_RANGE[0] <= scale.estimate <= SPEED_SCALE_RANGE[1]:
        out.append(f"{name}: the wheel's speed reads {1 / scale.estimate:.2f} × GPS speed: the "
                   f"speed column may be in other units (mph read as km/h gives 0.62) or from "
                   f"another wheel size; every speed was rescaled by GPS, check the log")
    elif scale.source != "assumed" and not (
            TYRE_SCALE_RANGE[0] <= scale.estimate + 1.96 * scale.sd
            and scale.estimate - 1.96 * scale.sd <= TYRE_SCALE_RANGE[1]):
        out.append(f"{name}: the wheel's speed reads {1 / scale.estimate:.2f} × GPS speed, beyond a "
                   f"tyre's tolerance (−8 % to +15 %): the wheel's diameter setting may not match its "
                   f"tyre" + (f" (the spec: {2 * spec.radius / 0.0254:.0f} inches)" if spec.radius else ""))
    try:
        out += [f"{name}: {w}" for w in log_contradictions(spec, log.data)]
    except SpecError as exc:        # refused by the command before any work; here said, not raised
        out.append(f"{name}: {exc}")
    return out


def mass_suspicion(estimate: float | None) -> str | None:
    """Why a total mass cannot be a rider with a wheel (kg), or None."""
    lo, hi = TOTAL_MASS_RANGE
    if estimate is None or lo <= estimate <= hi:
        return None
    return (f"the mass found, {estimate:.0f} kg, is no rider with a wheel ({lo:g}–{hi:g} kg): the "
            f"log is likely in other units (current in mA read as A makes it 1000× heavier, speed "
            f"in mph read as km/h 2.6× heavier without GPS), so it is withheld")

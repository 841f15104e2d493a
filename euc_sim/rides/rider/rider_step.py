"""The ``calibrated_rider`` step of the simulated ride: the rider fitted on the fit ride.

:func:`calibrated_rider_step` is one more builder of :mod:`euc_sim.rides.sim.sim_steps`, between the
measured law and the drivetrain (:data:`RIDER_STEPS`); the fit itself is
:func:`euc_sim.rides.rider.rider_fit.fit_rider`.
"""

from __future__ import annotations

from dataclasses import replace

from euc_sim.rides.grids.profile import PLAN_WINDOW
from euc_sim.rides.grids.signals import RideAssumptions
from euc_sim.rides.law.controller_report import torque_constant
from euc_sim.rides.rider.rider_fit import RiderFitError, fit_rider
from euc_sim.rides.sim.sim_steps import STEP_BUILDERS, effects_to_inject

__all__ = ["calibrated_rider_step", "RIDER_STEPS"]


def calibrated_rider_step(prev, inp):
    """The ``calibrated_rider`` step: the rider fitted on ``inp.fit_log`` with ``prev``'s motor law,
    the accepted effects and the augmented power model, riding :data:`PLAN_WINDOW`'s plan;
    skipped (``why``) where he cannot be fitted.
    """
    name, what = "calibrated_rider", "the rider calibrated on the fit ride"
    if inp.fit_log is None:
        return replace(prev, name=name, what=what, notes=(), why="no fit ride log to calibrate the rider on")
    eff, _ = effects_to_inject(inp.augmented, inp.accepted)
    power = {k: float(inp.augmented.get(k, d)) for k, d in
             (("copper_loss", 0.0), ("drivetrain_idle_loss", 0.0))}
    k_t = torque_constant(inp.drivetrain)
    try:
        fit = fit_rider(inp.fit_log, params=inp.params, motor=prev.motor, effects=eff, drivetrain=power,
                        assumptions=RideAssumptions(torque_constant=k_t), n_boot=inp.n_boot, seed=inp.seed)
    except (RiderFitError, ValueError) as exc:
        return replace(prev, name=name, what=what, notes=(), why=f"the rider cannot be calibrated: {exc}")
    got = ", ".join(f"{k} {v['value']:.3g} {v['unit']}" for k, v in fit.params.items())
    return replace(prev, name=name, what=f"{what}: {got}", rider=fit.rider, plan_window=PLAN_WINDOW,
                   rider_fit={k: float(v["value"]) for k, v in fit.params.items()}, notes=fit.notes, why=None)


#: nominal → measured law → calibrated rider → drivetrain (``build_steps(inp, RIDER_STEPS)``).
RIDER_STEPS = STEP_BUILDERS[:2] + (calibrated_rider_step,) + STEP_BUILDERS[2:]

"""Controllers of the closed loop: the EUC's motor law and the human rider.

- :mod:`euc_sim.controllers.motor`: M_d = K_p γ + K_d γ̇, the paper's hypothesised EUC
  controller (Section 3), with a torque limit and optional tilt-back.
- :mod:`euc_sim.controllers.rider`: the rider's ankle torque M_h: balance over the wheel,
  follow a speed profile, reaction delay, optional motor noise.
- :mod:`euc_sim.controllers.design`: the rider's gains by ``control.lqr`` on the analytic
  linearisation with the motor PD inside the loop.
"""

from euc_sim.controllers.motor import MotorPD
from euc_sim.controllers.rider import Rider, trim

__all__ = ["MotorPD", "Rider", "trim"]

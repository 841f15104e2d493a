"""Controllers of the closed loop: the EUC's motor law (:mod:`~euc_sim.controllers.motor`), the
human rider (:mod:`~euc_sim.controllers.rider`) and the design of his gains (:mod:`~euc_sim.controllers.design`).
"""

from euc_sim.controllers.motor import MotorPD
from euc_sim.controllers.rider import Rider, trim

__all__ = ["MotorPD", "Rider", "trim"]

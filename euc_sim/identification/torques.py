"""M_d,1 (eq. 9), M_d,2 (eq. 10) and M_h of the 3-DoF model, and M̄_d,1, M̄_d,2 (eq. 13) of the reduced model,
from a recording's kinematics."""

from __future__ import annotations

import pandas as pd

from euc_sim.model import analytic
from euc_sim.model.parameters import Params
from euc_sim.identification.processing import Kinematics, term_filter


#: The two models: the paper's 3-DoF model and the reduced 2-DoF model (Section 3.2).
MODELS = ("3dof", "2dof")
#: Columns of ``euc-sim torques``' output (CONTRACT.md).
TORQUE_COLUMNS = ("t", "M_d1", "M_d2", "M_h", "M_d1_2dof", "M_d2_2dof")


# --- torques ----------------------------------------------------------------------------
def torques(kin: Kinematics, p: Params) -> pd.DataFrame:
    """The torque estimates of a recording, each with the consistent term filter.

    Parameters
    ----------
    kin : Kinematics
        From :func:`euc_sim.identification.processing.kinematics`.
    p : Params
        Parameters, ``p.h`` the rider's height used.

    Returns
    -------
    DataFrame
        Columns :data:`TORQUE_COLUMNS`, N·m; every row of the recording (the first and
        last ``kin.smoothing.edge`` rows have less filter support).
    """
    sig = kin.smoothing.sigma_samples(kin.dt)
    q, qd, qdd = kin.q, kin.qd, kin.qdd
    raw = (*analytic.torques(p, q, qd, qdd),                     # eqs. (9), (10), row 3 of eq. (5)
           analytic.reduced_driving_torque_1(p, q, qd, qdd), analytic.reduced_driving_torque_2(p, q, qd, qdd))
    return pd.DataFrame({"t": kin.t, **{k: term_filter(v, sig) for k, v in zip(TORQUE_COLUMNS[1:], raw)}},
                        columns=list(TORQUE_COLUMNS))


# --- the residual as a rational function of h ---------------------------------------------
def model_functions(model: str):
    if model == "3dof":
        return analytic.driving_torque_1, analytic.driving_torque_2, lambda p: p
    if model == "2dof":
        return (analytic.reduced_driving_torque_1, analytic.reduced_driving_torque_2,
                lambda p: p.reduced())
    raise ValueError(f"model must be one of {', '.join(MODELS)}, got {model!r}")

"""Beyond the paper: base-parameter groups by linear least squares where M_d is recorded."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from euc_sim.model.parameters import Params, TABLE3
from euc_sim.identification.processing import Kinematics, term_filter



# --- beyond the paper: base parameters where M_d is known ------------------------------------
#: The base-parameter groups of eqs. (5)-(8) and how each follows from Table 3.
BASE_GROUPS = {
    "m_11": "m + m0 + mw + Jw/R²",
    "m0h0 - ml0": "m0·h0 − m·l0",
    "mh": "m·h",
    "J0 + m0h0² + ml0²": "J0 + m0·h0² + m·l0²",
    "mhl0": "m·h·l0",
    "J + mh²": "J + m·h²",
}


def base_groups(p: Params) -> np.ndarray:
    """The values of :data:`BASE_GROUPS` for a parameter set (SI)."""
    return np.array([p.m_eq, p.m0 * p.h0 - p.m * p.l0, p.m * p.h,
                     p.J0 + p.m0 * p.h0**2 + p.m * p.l0**2, p.m * p.h * p.l0, p.J + p.m * p.h**2])


def base_regressor(q, qd, qdd, g: float = TABLE3.g) -> np.ndarray:
    """Regressor Y (..., 3, 6) with inverse_dynamics(p, q, q̇, q̈) = Y · base_groups(p) (eqs. 5–8, groups
    :data:`BASE_GROUPS`)."""
    q, qd, qdd = (np.asarray(a, dtype=float) for a in (q, qd, qdd))
    _, ga, ph = q[..., 0], q[..., 1], q[..., 2]
    _, gd, pd_ = qd[..., 0], qd[..., 1], qd[..., 2]
    xdd, gdd, pdd = qdd[..., 0], qdd[..., 1], qdd[..., 2]
    Y = np.zeros(ga.shape + (3, 6))
    c_pg, s_pg = np.cos(ph - ga), np.sin(ph - ga)
    # row 1 (x): m11 ẍ + m12 γ̈ + m13 φ̈ + h1, eqs. (6)-(7)
    Y[..., 0, 0] = xdd
    Y[..., 0, 1] = np.cos(ga) * gdd - gd**2 * np.sin(ga)
    Y[..., 0, 2] = np.cos(ph) * pdd - pd_**2 * np.sin(ph)
    # row 2 (γ): m21 ẍ + m22 γ̈ + m23 φ̈ + h2 − Q2_gravity, eq. (8)
    Y[..., 1, 1] = np.cos(ga) * xdd - g * np.sin(ga)
    Y[..., 1, 3] = gdd
    Y[..., 1, 4] = -c_pg * pdd + pd_**2 * s_pg
    # row 3 (φ)
    Y[..., 2, 2] = np.cos(ph) * xdd - g * np.sin(ph)
    Y[..., 2, 4] = -c_pg * gdd - gd**2 * s_pg
    Y[..., 2, 5] = pdd
    return Y


@dataclass
class BaseFit:
    """Base-parameter groups from a recording with known torques.

    Attributes
    ----------
    names : list of str
    estimate, std_error, nominal : ndarray
        SI units of each group; ``nominal`` from the parameters used in processing.
    identifiable : ndarray of bool
        Relative standard error below ``rel_tol``, sensitivity above ``min_sensitivity``,
        outside the numerical null space.
    condition_number : float
        Of the column-normalised regressor.
    rows : str
        Which equations were used.
    rmse : float
        N·m (row 1 scaled by R).
    sensitivity : ndarray
        Relative RMS change of the fitted torques for a 10 % error in each group, the
        others compensating.
    """

    names: list
    estimate: np.ndarray
    std_error: np.ndarray
    nominal: np.ndarray
    identifiable: np.ndarray
    condition_number: float
    rows: str
    rmse: float
    sensitivity: np.ndarray = None

    def as_json(self) -> dict:
        return {"condition_number": self.condition_number, "rows": self.rows, "rmse": self.rmse,
                "groups": [{"name": n, "formula": BASE_GROUPS[n], "estimate": e, "std_error": s,
                            "nominal": v, "identifiable": bool(i), "sensitivity": z}
                           for n, e, s, v, i, z in zip(self.names, self.estimate, self.std_error,
                                                       self.nominal, self.identifiable,
                                                       self.sensitivity)]}


def identify_base_parameters(kin: Kinematics, M_d, M_h=None, p: Params = TABLE3,
                             rel_tol: float = 0.1, min_sensitivity: float = 1e-4) -> BaseFit:
    """All base-parameter groups by linear least squares where M_d (N·m) is known.

    Uses R·row 1 = M_d and row 2 + row 3 = −M_d, plus rows 2 and 3 when M_h (N·m) is known;
    regressors and torques term-filtered alike, edges dropped.  ``p`` supplies g and the
    nominal values; ``rel_tol`` and ``min_sensitivity`` decide :attr:`BaseFit.identifiable`.
    """
    sig = kin.smoothing.sigma_samples(kin.dt)
    sl = kin.interior
    Y = base_regressor(kin.q, kin.qd, kin.qdd, p.g)                 # (N, 3, 6)
    M_d = np.asarray(M_d, dtype=float)
    blocks_A = [p.R * Y[:, 0, :], Y[:, 1, :] + Y[:, 2, :]]
    blocks_b = [M_d, -M_d]
    rows = "R·row1 = M_d; row2 + row3 = −M_d"
    if M_h is not None:
        M_h = np.asarray(M_h, dtype=float)
        blocks_A = [p.R * Y[:, 0, :], Y[:, 1, :], Y[:, 2, :]]
        blocks_b = [M_d, M_h - M_d, -M_h]
        rows = "R·row1 = M_d; row2 = M_h − M_d; row3 = −M_h"
    A = np.concatenate([term_filter(a, sig, axis=0)[sl] for a in blocks_A])
    b = np.concatenate([term_filter(v, sig)[sl] for v in blocks_b])
    scale = np.linalg.norm(A, axis=0)
    scale[scale == 0] = 1.0
    As = A / scale
    U, s, Vt = np.linalg.svd(As, full_matrices=False)
    tol = s[0] * max(As.shape) * np.finfo(float).eps * 1e3
    rank = int((s > tol).sum())
    s_inv = np.where(s > tol, 1.0 / np.where(s > tol, s, 1.0), 0.0)
    theta_s = Vt.T @ (s_inv * (U.T @ b))
    resid = b - As @ theta_s
    dof = max(len(b) - rank, 1)
    # the filtered residual is correlated over ~2√π σ samples (Gaussian term filter) or
    # a window (paper's recipe): inflate the white-noise variance by that length
    corr = 2 * math.sqrt(math.pi) * sig if sig > 0 else kin.smoothing.samples(kin.dt)
    sigma2 = float(resid @ resid) / dof * max(1.0, corr)
    cov_s = (Vt.T * s_inv**2) @ Vt * sigma2
    est = theta_s / scale
    se = np.sqrt(np.diag(cov_s)) / scale
    null = np.abs(Vt[rank:]).max(axis=0) > 1e-6 if rank < len(s) else np.zeros(len(s), bool)
    # sensitivity: RMS change of the fitted torques when a group is off by 10 % and the
    # others re-fit to compensate, relative to the torques' RMS; independent of the
    # residual, which on clean data is derivative error rather than white noise
    inv_diag = np.diag((Vt.T * s_inv**2) @ Vt) / scale**2
    with np.errstate(divide="ignore", invalid="ignore"):
        rel = se / np.abs(est)
        sens = (0.1 * np.abs(est) / np.sqrt(inv_diag * len(b))) / np.sqrt(np.mean(b**2))
    ident = (~null) & (rel < rel_tol) & (sens > min_sensitivity)
    cond = float(s[0] / s[-1]) if s[-1] > 0 else math.inf
    return BaseFit(names=list(BASE_GROUPS), estimate=est, std_error=se, nominal=base_groups(p),
                   identifiable=ident, condition_number=cond, rows=rows,
                   rmse=float(np.sqrt(np.mean(resid**2))), sensitivity=sens)

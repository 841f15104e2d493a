"""Step 2, the residual: r(h) = M_d,1 − M_d,2 (eqs. 9-10) in closed form in h, and its noise floor.

r = κ(q)·(moment about the contact point P of whatever the model leaves out); with
M_d recorded, also the wheel row r_w = M_d,1 − M_d = R·Q_e,x.  r depends on the
nuisance h as κ(h)·(e₀ + e₁h + e₂h²) (eq. 6: m_13 ∝ h, m_33 = J + m h²), so it is
evaluated for any h in closed form.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from euc_sim.diagnosis.prepare import Prepared
from euc_sim.identification import h_fit as ident, processing, regression as reg
from euc_sim.model import analytic
from euc_sim.model.parameters import Params

__all__ = ["ResidualModel", "residual_model", "noise_floor"]


# --- the residual --------------------------------------------------------------------------
@dataclass(frozen=True)
class ResidualModel:
    """r(h) = P(h)/D(h) = M_d,1 − M_d,2 on the kept samples, P term-filtered; with M_d recorded r_w(h) = w₀ + w₁ h
    stacked below."""

    P: np.ndarray                # (3, n)
    D: np.ndarray                # (2, n)
    W: np.ndarray | None         # (2, n)

    def kinematic(self, h: float) -> np.ndarray:
        return (self.P[0] + h * (self.P[1] + h * self.P[2])) / (self.D[0] + h * self.D[1])

    def wheel(self, h: float) -> np.ndarray | None:
        return None if self.W is None else self.W[0] + h * self.W[1]

    def __call__(self, h: float) -> np.ndarray:
        r = self.kinematic(h)
        w = self.wheel(h)
        return r if w is None else np.concatenate([r, w])

    def slope(self, h: float) -> np.ndarray:
        """∂r/∂h at ``h`` (m) by a central difference of 0.1 mm, N·m/m."""
        dh = 1e-4
        return (self(h + dh) - self(h - dh)) / (2 * dh)


#: Values of h (m) at which the wheel row is evaluated to recover its coefficients in h.
_H_NODES = np.array([0.5, 1.0])


def residual_model(prep: Prepared, p: Params | None = None) -> ResidualModel:
    """Build r(h) (and r_w(h)) on the kept samples, term-filtered, with ``p`` (default the nominal parameters)."""
    p = prep.params if p is None else p
    kin = prep.kin
    P, D = ident.residual_coefficients(kin, p)
    P, D = prep.filtered(P), D[:, prep.keep]
    W = None
    if prep.M_d is not None:
        w = [analytic.driving_torque_1(p.replace(h=float(h)), kin.q, kin.qd, kin.qdd) - prep.M_d
             for h in _H_NODES]
        w1 = (w[1] - w[0]) / (_H_NODES[1] - _H_NODES[0])
        W = prep.filtered(np.array([w[0] - _H_NODES[0] * w1, w1]))
    return ResidualModel(P, D, W)


# --- noise floor ---------------------------------------------------------------------------
def noise_floor(prep: Prepared, h: float, seed: int = 0) -> dict:
    """The residual the recording's own sensor noise produces through the filter, at ``h`` (m).

    White noise of each channel's level (:func:`noise_sd`), filtered like the data and
    propagated linearly.  Returns ``rms`` (N·m, kinematic row), ``rms_stacked`` (all rows),
    ``tau_int`` (samples, for n_eff) and ``noise`` (the stacked samples).
    """
    rng = np.random.default_rng(seed)
    n = prep.kin.t.size
    sm = prep.kin.smoothing
    dt = prep.kin.dt
    Z = np.column_stack([rng.normal(0.0, prep.noise_sd[c], n) for c in ("x", "gamma", "phi")])
    dq, dqd, dqdd = processing.savgol_derivatives(Z, dt, sm.samples(dt), sm.order, axis=0)
    base = residual_model(prep)(h)
    pert = residual_model(prep.with_kin(prep.kin.q + dq, prep.kin.qd + dqd, prep.kin.qdd + dqdd))(h)
    r = pert - base
    nk = prep.keep.size
    return {"rms": float(np.sqrt(np.mean(r[:nk] ** 2))), "rms_stacked": float(np.sqrt(np.mean(r ** 2))),
            "tau_int": reg.correlation_time(r[:nk]), "noise": r}


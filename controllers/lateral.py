"""The rider's lateral law: balance sideways and steer along a path, by leaning and
twisting the wheel.

Designed on MuJoCo's own linearisation of the spatial model
(:func:`mujoco.mjd_transitionFD` on :class:`euc_sim.model.spatial.EucSpatial`) at
upright straight running at the maneuver's speed.  At that operating point the
linearisation splits exactly into a longitudinal part (kept as in the planar work:
motor PD and the delayed rider with predictor) and a lateral part, whose state is

    z = (e_y, e_ψ, ϑ, lean, twist, ė_y, ϑ̇, ψ̇, leaṅ, twisṫ, ∫e_y dt)

with e_y the lateral offset of C from the path (m, left positive), e_ψ the heading
error (rad), ϑ the tilt, lean and twist the rider's ankle hinges (rad), and inputs
u = (M_lean, M_twist), N·m.  The gains K minimise Σ zᵀQz + uᵀRu (``control.dlqr``
on the 1 ms transition matrices, Bryson's rule from :data:`LATERAL_SCALES`); on a
curve the references are those of a steady turn of curvature κ:
ϑ_ref = −atan(v² κ / g) (into the turn: positive ϑ tilts to the right), ψ̇_ref = v κ.

:func:`lateral_delay_margin` is the largest common input delay the sampled loop
tolerates (spectral radius of the loop with a delay line).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from euc_sim.model.parameters import Params, TABLE3

__all__ = ["LATERAL_SCALES", "LATERAL_STATE", "LateralRider", "lateral_plant", "design_lateral",
           "lateral_delay_margin"]

LATERAL_STATE = ("e_y", "e_psi", "theta", "lean", "twist", "e_y_dot", "theta_dot", "psi_dot",
                 "lean_dot", "twist_dot", "e_y_int")
#: Bryson's-rule scales of the lateral design (None: not weighted): m, rad, rad/s, m·s, N·m.
LATERAL_SCALES = {"e_y": 0.3, "e_psi": 0.3, "theta": 0.1, "lean": 0.2, "twist": 0.3,
                  "e_y_dot": None, "theta_dot": None, "psi_dot": None, "lean_dot": None,
                  "twist_dot": None, "e_y_int": 1.0, "M_lean": 40.0, "M_twist": 20.0}


@dataclass(frozen=True)
class LateralRider:
    """Lateral gains u = −K z (K: 2 × 11) designed at ``speed``.

    Attributes
    ----------
    K : numpy.ndarray, shape (2, 11)
        Gains on :data:`LATERAL_STATE` for (M_lean, M_twist), N·m per state unit.
    speed : float
        Design speed, m/s.
    dt : float
        Control period of the design, s.
    delay_margin : float
        Largest common delay of both inputs the sampled loop tolerates, s.
    torque_limit : float
        |M_lean|, |M_twist| limit, N·m.
    """

    K: np.ndarray
    speed: float
    dt: float
    delay_margin: float
    torque_limit: float = 300.0

    def as_dict(self) -> dict:
        return {"K": np.asarray(self.K).tolist(), "state": list(LATERAL_STATE), "speed": self.speed,
                "dt": self.dt, "delay_margin": self.delay_margin, "torque_limit": self.torque_limit,
                "design": "control.dlqr on mujoco.mjd_transitionFD of mjcf/euc_3d.xml"}


def lateral_plant(params: Params = TABLE3, speed: float = 2.5, dt: float = 1e-3,
                  tyre=None) -> tuple[np.ndarray, np.ndarray]:
    """Discrete lateral plant (Φ, Γ) at upright straight running, from ``mjd_transitionFD``.

    Parameters
    ----------
    params : Params
    speed : float
        Forward speed, m/s.
    dt : float
        Timestep, s.
    tyre : TyreContact, optional

    Returns
    -------
    Phi : numpy.ndarray, shape (11, 11)
    Gamma : numpy.ndarray, shape (11, 2)
        On :data:`LATERAL_STATE` (the integral row appended), inputs (M_lean, M_twist).
    """
    import mujoco

    from euc_sim.model.spatial import EucSpatial

    sim = EucSpatial(params, tyre, timestep=dt)
    sim.set_straight(speed)
    m, d = sim.model, sim.data
    for _ in range(20):        # let the contact settle into steady rolling
        mujoco.mj_step(m, d)
    nv = m.nv
    A = np.zeros((2 * nv + m.na, 2 * nv + m.na))
    B = np.zeros((2 * nv + m.na, m.nu))
    mujoco.mjd_transitionFD(m, d, 1e-6, True, A, B, None, None)
    r = sim.vadr["root"]
    lean, twist = sim.vadr["rider_lean"], sim.vadr["rider_twist"]
    # tangent coordinates of LATERAL_STATE: y, rotation about z, about x (the free joint's
    # rotations are body-frame, which is the ground frame at ψ = ϑ = γ = 0), the hinges;
    # then the rates y, x, z (ϑ̇ before ψ̇)
    idx = [r + 1, r + 5, r + 3, lean, twist] + [nv + i for i in (r + 1, r + 3, r + 5, lean, twist)]
    Phi = np.zeros((11, 11))
    Phi[:10, :10] = A[np.ix_(idx, idx)]
    Phi[10, 10] = 1.0
    Phi[10, 0] = dt                         # ∫e_y: forward-Euler sum of e_y
    Gam = np.zeros((11, 2))
    Gam[:10] = B[np.ix_(idx, [sim.act["lean"], sim.act["twist"]])]
    return Phi, Gam


def design_lateral(params: Params = TABLE3, speed: float = 2.5, dt: float = 1e-3,
                   tyre=None, scales: dict | None = None) -> LateralRider:
    """LQR lateral rider (``control.dlqr``) on :func:`lateral_plant`.

    Raises
    ------
    ValueError
        when the design does not stabilise the sampled plant.
    """
    import control

    if not (math.isfinite(speed) and speed > 0):
        raise ValueError(f"design speed must be positive, got {speed!r} m/s")
    sc = dict(LATERAL_SCALES)
    sc.update(scales or {})
    Phi, Gam = lateral_plant(params, speed, dt, tyre)
    Q = np.diag([0.0 if sc[n] is None else 1.0 / sc[n] ** 2 for n in LATERAL_STATE])
    Rm = np.diag([1.0 / sc["M_lean"] ** 2, 1.0 / sc["M_twist"] ** 2])
    K, _, E = control.dlqr(Phi, Gam, Q, Rm)
    K = np.asarray(K)
    if np.max(np.abs(E)) >= 1.0:  # pragma: no cover - dlqr returns a stabilising gain
        raise ValueError(f"lateral LQR does not stabilise: eigenvalue modulus {np.max(np.abs(E)):.4f}")
    margin = lateral_delay_margin(Phi, Gam, K, dt)
    return LateralRider(K=K, speed=float(speed), dt=dt, delay_margin=margin)


def lateral_delay_margin(Phi: np.ndarray, Gam: np.ndarray, K: np.ndarray, dt: float,
                         block: int = 5, max_delay: float = 0.5) -> float:
    """Largest common input delay (s, on a ``block·dt`` grid) for which the loop
    z⁺ = Φ z + Γ u(t − τ), u = −K z stays stable (spectral radius < 1).

    The loop is resampled at ``block·dt`` (Φᵇ, Σ Φⁱ Γ) to keep the delay line short.
    """
    Pb = np.linalg.matrix_power(Phi, block)
    Gb = sum(np.linalg.matrix_power(Phi, i) for i in range(block)) @ Gam
    n, m = Gam.shape
    best = -1
    for D in range(int(max_delay / (block * dt)) + 1):
        N = n + m * D
        T = np.zeros((N, N))
        T[:n, :n] = Pb
        if D == 0:
            T[:n, :n] -= Gb @ K
        else:
            T[:n, n + m * (D - 1):] = Gb          # the oldest command acts now
            T[n:n + m, :n] = -K                    # newest command
            for i in range(1, D):
                T[n + m * i:n + m * (i + 1), n + m * (i - 1):n + m * i] = np.eye(m)
        if np.max(np.abs(np.linalg.eigvals(T))) >= 1.0:
            break
        best = D
    return best * block * dt if best >= 0 else 0.0

"""The rider's lateral law: balance sideways and steer along a path, by leaning and
twisting the wheel.

An LQR design (``control.dlqr``, Bryson's rule from :data:`LATERAL_SCALES`) on MuJoCo's
linearisation (``mjd_transitionFD``) of :class:`euc_sim.model.spatial.EucSpatial` at
upright straight running, whose lateral part has the state :data:`LATERAL_STATE`

    z = (e_y, e_ψ, ϑ, lean, twist, ė_y, ϑ̇, ψ̇, leaṅ, twisṫ, ∫e_y dt)

(e_y the offset of C from the path, m, left positive; angles rad) and inputs u =
(M_lean, M_twist), N·m.  On a curve of curvature κ the references are a steady turn's:
ϑ_ref = −atan(v² κ / g), ψ̇_ref = v κ.  See docs/spatial.md (Lateral rider).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from euc_sim.errors import InputError
from euc_sim.model.parameters import Params, TABLE3

__all__ = ["LATERAL_SCALES", "LATERAL_STATE", "LateralRider", "lateral_plant", "design_lateral",
           "lateral_delay_margin", "lateral_predictor_rows", "delayed_loop"]

LATERAL_STATE = ("e_y", "e_psi", "theta", "lean", "twist", "e_y_dot", "theta_dot", "psi_dot",
                 "lean_dot", "twist_dot", "e_y_int")
#: Bryson's-rule scales of the lateral design (None: not weighted): m, rad, rad/s, m·s, N·m.
LATERAL_SCALES = {"e_y": 0.3, "e_psi": 0.3, "theta": 0.1, "lean": 0.2, "twist": 0.3,
                  "e_y_dot": None, "theta_dot": None, "psi_dot": None, "lean_dot": None,
                  "twist_dot": None, "e_y_int": 1.0, "M_lean": 40.0, "M_twist": 20.0}


@dataclass(frozen=True)
class LateralRider:
    """Lateral gains u = −K z designed at ``speed``.

    Attributes
    ----------
    K : numpy.ndarray, shape (2, 11)
        Gains on :data:`LATERAL_STATE` for (M_lean, M_twist), N·m per state unit.
    speed : float
        Design speed, m/s.
    dt : float
        Control period of the design, s.
    delay_margin : float
        Largest common input delay (beyond ``delay``, predicted) the sampled loop tolerates, s.
    torque_limit : float
        |M_lean|, |M_twist| limit, N·m.
    delay : float
        The rider's reaction delay, s: he senses z(t − delay).
    K_pred, K_hist : numpy.ndarray, shapes (2, 11), (2, 2n)
        The predictor's gains (:func:`lateral_predictor_rows`), n = delay/dt.
    """

    K: np.ndarray
    speed: float
    dt: float
    delay_margin: float
    torque_limit: float = 300.0
    delay: float = 0.0
    K_pred: np.ndarray | None = None
    K_hist: np.ndarray | None = None

    @property
    def n_delay(self) -> int:
        """The reaction delay in control steps."""
        return int(round(self.delay / self.dt))

    def as_dict(self) -> dict:
        return {"K": np.asarray(self.K).tolist(), "state": list(LATERAL_STATE), "speed": self.speed,
                "dt": self.dt, "delay_margin": self.delay_margin, "torque_limit": self.torque_limit,
                "delay": self.delay, "predictor": self.n_delay > 0,
                "design": "control.dlqr on mujoco.mjd_transitionFD of mjcf/euc_3d.xml"}


def lateral_plant(params: Params = TABLE3, speed: float = 2.5, dt: float = 1e-3,
                  tyre=None) -> tuple[np.ndarray, np.ndarray]:
    """Discrete lateral plant (Φ (11, 11), Γ (11, 2)) on :data:`LATERAL_STATE` at upright
    straight running at ``speed``, m/s, timestep ``dt``, s, from ``mjd_transitionFD``.
    """
    import mujoco

    from euc_sim.model.spatial import EucSpatial  # deferred: loads mujoco (0.1 s)

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
                   tyre=None, delay: float = 0.0) -> LateralRider:
    """LQR lateral rider on :func:`lateral_plant`; with a reaction ``delay``, s, the rider
    predicts the present state (:func:`lateral_predictor_rows`).  ``InputError`` for a bad
    speed or delay.
    """
    import control

    if not (math.isfinite(speed) and speed > 0):
        raise InputError(f"design speed must be positive, got {speed!r} m/s")
    sc = LATERAL_SCALES
    Phi, Gam = lateral_plant(params, speed, dt, tyre)
    Q = np.diag([0.0 if sc[n] is None else 1.0 / sc[n] ** 2 for n in LATERAL_STATE])
    Rm = np.diag([1.0 / sc["M_lean"] ** 2, 1.0 / sc["M_twist"] ** 2])
    K, _, E = control.dlqr(Phi, Gam, Q, Rm)
    K = np.asarray(K)
    if np.max(np.abs(E)) >= 1.0:  # pragma: no cover - dlqr returns a stabilising gain
        raise InputError(f"lateral LQR does not stabilise: eigenvalue modulus {np.max(np.abs(E)):.4f}")
    if not (math.isfinite(delay) and delay >= 0):
        raise InputError(f"lateral reaction delay must be a non-negative number of seconds, got {delay!r}")
    n = int(round(delay / dt))
    K_pred, K_hist = lateral_predictor_rows(Phi, Gam, K, n)
    margin = lateral_delay_margin(Phi, Gam, K, dt, delay=n * dt)
    return LateralRider(K=K, speed=float(speed), dt=dt, delay_margin=margin, delay=n * dt,
                        K_pred=K_pred, K_hist=K_hist)


def lateral_predictor_rows(Phi: np.ndarray, Gam: np.ndarray, K: np.ndarray, n: int) -> tuple[np.ndarray, np.ndarray]:
    """K Φⁿ (2, 11) and (K Φ^{n−1} Γ, …, K Γ) (2, 2n): the predictor's gains for a delay of n
    steps, ẑ = Φⁿ z_{k−n} + Σ Φ^{n−1−i} Γ u_{k−n+i} (commands oldest first).
    """
    K = np.asarray(K, dtype=float)
    m = Gam.shape[1]
    K_hist = np.zeros((K.shape[0], m * n))
    row = K.copy()                                  # K Φ^j
    for j in range(n):
        K_hist[:, m * (n - 1 - j):m * (n - j)] = row @ Gam
        row = row @ Phi
    return row, K_hist


def lateral_delay_margin(Phi: np.ndarray, Gam: np.ndarray, K: np.ndarray, dt: float,
                         delay: float = 0.0) -> float:
    """Largest common input delay τ ≤ 0.5 s (on a 5·dt grid) for which z⁺ = Φ z + Γ u(t − τ),
    u = −K ẑ stays stable (spectral radius < 1); with a reaction ``delay``, s, predicted, the
    margin beyond it.
    """
    block, max_delay = 5, 0.5
    Pb = np.linalg.matrix_power(Phi, block)
    Gb = sum(np.linalg.matrix_power(Phi, i) for i in range(block)) @ Gam
    S = int(round(delay / (block * dt)))
    K_pred, K_hist = lateral_predictor_rows(Pb, Gb, K, S)
    best = -1
    for D in range(int(max_delay / (block * dt)) + 1):
        if np.max(np.abs(np.linalg.eigvals(delayed_loop(Pb, Gb, K_pred, K_hist, S, D)))) >= 1.0:
            break
        best = D
    return best * block * dt if best >= 0 else 0.0


def delayed_loop(Phi, Gam, K_pred, K_hist, S: int, D: int) -> np.ndarray:
    """Transition matrix of the sampled loop z⁺ = Φ z + Γ u_{k−D} under a controller that senses z
    S steps late and predicts it over its last h commands, u_k = −K_pred z_{k−S} − Σ_{i<h} K_hist,i
    u_{k−h+i} (:func:`lateral_predictor_rows`; h = K_hist's columns / inputs); state (z_k, …,
    z_{k−S}, u_{k−1}, …, u_{k−h−D}).
    """
    n, m = Gam.shape
    h = K_hist.shape[1] // m
    H = h + D                                      # commands kept
    N = n * (S + 1) + m * H
    T = np.zeros((N, N))
    u0 = n * (S + 1)                               # offset of u_{k−1}
    u_row = np.zeros((m, N))
    u_row[:, n * S:n * (S + 1)] = -K_pred
    for i in range(h):                             # K_hist pair i weights u_{k−h+i}
        lag = h - i                                # u_{k−lag}
        u_row[:, u0 + m * (lag - 1):u0 + m * lag] -= K_hist[:, m * i:m * (i + 1)]
    T[:n, :n] = Phi
    if D == 0:
        T[:n] += Gam @ u_row
    else:
        T[:n, u0 + m * (D - 1):u0 + m * D] += Gam
    for j in range(S):                             # shift the sensed states
        T[n * (j + 1):n * (j + 2), n * j:n * (j + 1)] = np.eye(n)
    if H:
        T[u0:u0 + m] = u_row                       # newest command
    for j in range(1, H):                          # shift the commands
        T[u0 + m * j:u0 + m * (j + 1), u0 + m * (j - 1):u0 + m * j] = np.eye(m)
    return T

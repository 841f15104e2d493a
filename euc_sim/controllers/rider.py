"""The human rider: an ankle torque M_h that balances the rider over the wheel and
follows a desired speed profile.

A trim for the planned acceleration (:func:`trim`, eqs. 5-8) plus LQR state feedback
(:mod:`euc_sim.controllers.design`) on the deviation from it:

    M_h(t) = M_h*(a_ref) − K · ŝ(t),    s = (ẋ − v_ref, γ − γ*, φ − φ*, γ̇, φ̇, ∫(ẋ − v_ref)dt).

The rider senses s with a reaction delay τ = n dt (default 0.15 s) and predicts it over
the delay with the linearised closed loop and his own recent commands (Kleinman, Baron
and Levison's internal model):

    ŝ_k = Φⁿ s_{k−n} + Σ_{i<n} Φ^{n−1−i} Γ δu_{k−n+i}.

Optional motor noise: an Ornstein–Uhlenbeck torque added to M_h, seeded.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field
from functools import lru_cache

import numpy as np

from euc_sim.controllers.motor import MotorPD
from euc_sim.errors import InputError
from euc_sim.model.parameters import Params

__all__ = ["Rider", "RiderError", "trim", "motor_noise", "RiderRun", "DEFAULT_RIDER_NOISE", "delayed_lqr_torque"]

#: Rider motor noise of generated recordings (command line, datasets), N·m, 1 sigma.
DEFAULT_RIDER_NOISE = 3.0


class RiderError(InputError):
    """An invalid rider setting; the message names it."""


#: Longest reaction delay a rider is given, s (a human's is 0.1–0.4 s).
MAX_DELAY = 1.0


@dataclass(frozen=True)
class Rider:
    """Rider controller settings.

    Attributes
    ----------
    K : tuple of 5 or 6 floats
        Gains on (ẋ − v_ref [m/s], γ − γ* [rad], φ − φ* [rad], γ̇ [rad/s], φ̇ [rad/s]) and
        optionally ∫(ẋ − v_ref) dt [m].
    delay : float
        Reaction delay, s.
    predictor : bool
        Compensate the delay with the internal model.
    noise_std : float
        Standard deviation of the motor noise added to M_h, N·m (0: none).
    noise_tau : float
        Correlation time of the motor noise, s.
    torque_limit : float
        |M_h| limit, N·m.
    anticipation : float
        Preview, s: the rider leans for, and tracks, the plan this far ahead (the plant
        is non-minimum-phase in speed).
    """

    K: tuple = field(default=(0.0,) * 5)
    delay: float = 0.15
    predictor: bool = True
    noise_std: float = 0.0
    noise_tau: float = 0.05
    torque_limit: float = 400.0
    anticipation: float = 0.3

    def __post_init__(self) -> None:
        K = tuple(float(k) for k in self.K)
        if len(K) not in (5, 6) or not all(math.isfinite(k) for k in K):
            raise RiderError(f"rider gains K must be 5 or 6 finite numbers, got {self.K!r}")
        object.__setattr__(self, "K", K)
        for name in ("delay", "noise_std", "anticipation"):
            v = getattr(self, name)
            if not (math.isfinite(v) and v >= 0):
                raise RiderError(f"rider {name!r} must be finite and non-negative, got {v!r}")
        if self.delay > MAX_DELAY:
            raise RiderError(f"rider 'delay' must be at most {MAX_DELAY:g} s (a human reaction), "
                             f"got {self.delay!r}")
        for name in ("noise_tau", "torque_limit"):
            v = getattr(self, name)
            if not (math.isfinite(v) and v > 0):
                raise RiderError(f"rider {name!r} must be positive, got {v!r}")

    def as_dict(self) -> dict:
        """Settings as a JSON-ready dict."""
        return {"K": list(self.K), "delay": self.delay, "predictor": self.predictor,
                "noise_std": self.noise_std, "noise_tau": self.noise_tau,
                "torque_limit": self.torque_limit, "anticipation": self.anticipation}

    def replace(self, **changes) -> "Rider":
        """A copy with some settings changed (validated again)."""
        return dataclasses.replace(self, **changes)


def trim(p: Params, motor: MotorPD, a, v=0.0):
    """Steady acceleration a at speed v: (γ*, φ*, M_d*, M_h*), rad, rad, N·m, N·m, from eqs. (5)-(8).

    Row 1 of eq. (5) gives M_d = R m_11 a, the motor law γ* = γ_ref(v) + M_d/K_p, row 2
    M_h = M_d + m_21 a − (m0 h0 − m l0) g sin γ*, row 3 φ* = atan2(a, g) + asin(M_h / (m h √(g² + a²))).
    ``p`` is the rider's model (nominal parameters); ``a`` (m/s²) and ``v`` (m/s) broadcast.
    """
    a = np.asarray(a, dtype=float)
    v = np.broadcast_to(np.asarray(v, dtype=float), a.shape)
    m11 = p.m + p.m0 + p.mw + p.Jw / p.R**2                              # eq. (6)
    M_d = p.R * m11 * a                                                   # eq. (5) row 1
    g_ref = np.vectorize(motor.gamma_ref, otypes=[float])(v) if np.isfinite(motor.tiltback_speed) \
        else np.zeros_like(a)
    gamma = g_ref + M_d / motor.Kp
    m21 = -(p.m * p.l0 - p.m0 * p.h0) * np.cos(gamma)
    M_h = M_d + m21 * a - (p.m0 * p.h0 - p.m * p.l0) * p.g * np.sin(gamma)  # eq. (5) row 2
    mh = p.m * p.h
    ratio = np.clip(M_h / (mh * np.hypot(p.g, a)), -1.0, 1.0)
    phi = np.arctan2(a, p.g) + np.arcsin(ratio)                           # eq. (5) row 3
    return gamma, phi, M_d, M_h


def motor_noise(n: int, dt: float, std: float, tau: float, seed: int) -> np.ndarray:
    """Ornstein–Uhlenbeck noise: n samples at step dt, s, stationary std ``std``, N·m, correlation time ``tau``, s."""
    if std == 0.0:
        return np.zeros(n)
    from scipy.signal import lfilter

    rng = np.random.default_rng(seed)
    w = rng.standard_normal(n)
    rho = math.exp(-dt / tau)
    drive = std * math.sqrt(1.0 - rho * rho) * w
    drive[0] = std * w[0]                       # start from the stationary distribution
    return lfilter([1.0], [1.0, -rho], drive)


class RiderRun:
    """The rider's law for one run: trims, predictor rows and noise, precomputed.

    Parameters
    ----------
    rider : Rider
    p : Params
        The rider's model (nominal parameters).
    motor : MotorPD
    v_ref, a_ref : numpy.ndarray, shape (N,)
        Planned speed (m/s) and acceleration (m/s²) at each control step.
    dt : float
        Control period, s.
    seed : int
        Seed of the motor noise.

    Notes
    -----
    The state history Y is padded with n entries of the state before t = 0: entry k + n
    is the state at step k, entry k the state the rider senses then.
    """

    def __init__(self, rider: Rider, p: Params, motor: MotorPD, v_ref: np.ndarray,
                 a_ref: np.ndarray, dt: float, seed: int):
        self.rider = rider
        self.n = n = int(round(rider.delay / dt))
        N = len(v_ref)
        if rider.anticipation > 0:                # preview: the plan T_a ahead, held at the end
            steps = np.arange(N) + rider.anticipation / dt
            v_ref = np.interp(steps, np.arange(N), v_ref)
            a_ref = np.interp(steps, np.arange(N), a_ref)
        gam, phi, _, M_h = trim(p, motor, a_ref, v_ref)
        pad = lambda arr: np.concatenate([np.full(n, arr[0]), arr])       # noqa: E731
        # reference state and torque over the padded timeline (index j = k + n)
        self.v_ref = pad(np.asarray(v_ref, float))
        self.gamma_ref, self.phi_ref = pad(gam), pad(phi)
        self.u_ref = pad(M_h)
        self.du = np.zeros(N + n)               # commanded M_h − M_h*, padded history
        self.noise = motor_noise(N, dt, rider.noise_std, rider.noise_tau, seed)
        self._lists = None                      # the same as Python lists, for command()
        self.k_pred, self.k_hist, lower, past = _delay_law(p, motor, rider.K, dt, n, rider.predictor)
        self.integral = len(rider.K) == 6
        self.z = 0.0                            # ∫(ẋ − v_ref) dt over the sensed samples, m
        self.dt = dt
        self.limit = rider.torque_limit
        self._chunk = (lower, past)

    def initial_state(self) -> tuple[float, float, float, float]:
        """(v, γ, φ) of the trim at t = 0 and the trim M_h, for the initial condition."""
        n = self.n
        return float(self.v_ref[n]), float(self.gamma_ref[n]), float(self.phi_ref[n]), float(self.u_ref[n])

    def command(self, k: int, Y) -> tuple[float, float]:
        """Ankle torque at step k from the padded history ``Y``: (commanded, applied with noise) M_h, N·m."""
        if self._lists is None:   # Python lists: indexing them costs less than numpy scalars
            self._lists = tuple(a.tolist() for a in (self.v_ref, self.gamma_ref, self.phi_ref,
                                                     self.u_ref, self.noise))
        v_ref, gamma_ref, phi_ref, u_refs, noise = self._lists
        y = Y[k]                                 # padded index k: the state n steps ago
        n, z = self.n, self.z
        e_v = y[3] - v_ref[k]
        if self.integral:
            self.z = z + e_v * self.dt
        u_ref = u_refs[k + n]
        u = delayed_lqr_torque(e_v, y[1] - gamma_ref[k], y[2] - phi_ref[k], y[4], y[5], z,
                               self.k_hist.dot(self.du[k:k + n]) if n else 0.0, u_ref,
                               self.k_pred, self.integral, self.limit)
        self.du[k + n] = u - u_ref
        return u, u + noise[k]

    def commands(self, k0: int, Y_sensed: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Ankle torques of steps k0 … k0 + L − 1 at once, L ≤ n + 1: :meth:`command` vectorised.

        The predictor's recursion over the block is solved as a unit lower-triangular system
        (:func:`_chunk_matrices`); a block in which the torque limit binds is done step by step.
        ``Y_sensed`` (L, 6) are the padded history's entries k0 …; returns commanded and applied
        M_h, each (L,), N·m.
        """
        Y_sensed = np.asarray(Y_sensed, dtype=float)
        L, n = len(Y_sensed), self.n
        if L > n + 1:
            raise RiderError(f"a block of rider commands spans at most n + 1 = {n + 1} steps, got {L}")
        z0, du0 = self.z, self.du[k0:k0 + n].copy()
        kp = self.k_pred
        v_ref, gamma_ref, phi_ref, u_ref, noise = self.v_ref, self.gamma_ref, self.phi_ref, self.u_ref, self.noise
        y, j = Y_sensed, slice(k0, k0 + L)
        e_v = y[:, 3] - v_ref[j]
        fb = (kp[0] * e_v + kp[1] * (y[:, 1] - gamma_ref[j])
              + kp[2] * (y[:, 2] - phi_ref[j]) + kp[3] * y[:, 4] + kp[4] * y[:, 5])
        if self.integral:
            z = np.cumsum(np.concatenate([[z0], e_v * self.dt]))   # z_{k+1} = z_k + e_v dt, in order
            fb += kp[5] * z[:L]
            self.z = float(z[L])
        u_ref = u_ref[k0 + n:k0 + n + L]
        rhs = -fb
        if n:
            lower, past = self._chunk
            rhs -= past[:L] @ du0
            if L < n + 1:
                lower = np.asfortranarray(lower[:L, :L])
            from scipy.linalg.lapack import dtrtrs

            du, info = dtrtrs(lower, rhs, lower=1, unitdiag=1)   # forward substitution (LAPACK)
        else:
            du = rhs
        u = u_ref + du
        if np.any(np.abs(u) > self.limit):      # the limit binds: step by step, clipping each
            self.z, self.du[k0:k0 + n] = z0, du0
            return self._commands_stepwise(k0, Y_sensed)
        self.du[k0 + n:k0 + n + L] = du
        return u, u + noise[k0:k0 + L]

    def _commands_stepwise(self, k0: int, Y_sensed: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """:meth:`commands` one step at a time through :meth:`command` (the limit binds)."""
        out = np.empty((len(Y_sensed), 2))
        hist = _Lookup(k0, Y_sensed)
        for i in range(len(Y_sensed)):
            out[i] = self.command(k0 + i, hist)
        return out[:, 0], out[:, 1]


def delayed_lqr_torque(e_v: float, e_gamma: float, e_phi: float, gamma_dot: float, phi_dot: float,
                       z: float, history: float, u_ref: float, k_pred, integral: bool, limit: float) -> float:
    """The rider's commanded ankle torque at one step, N·m: M_h = sat(M_h* − K Φⁿ ŝ − Σ KG_i δu_{k−n+i}).

    The one source of the per-step law (:meth:`RiderRun.command`; compiled by
    :mod:`euc_sim.simulation.native_kernels`).  ``e_v``, ``e_gamma``, ``e_phi``, ``gamma_dot``,
    ``phi_dot``: the sensed ŝ (m/s, rad, rad, rad/s, rad/s); ``z``: ∫(ẋ − v_ref) dt before this
    step, m (weighed by ``k_pred[5]`` when ``integral``); ``history``: Σ KG_i δu, N·m;
    ``u_ref``: M_h*, N·m; ``k_pred``: K Φⁿ; ``limit``: |M_h| limit, N·m.
    """
    fb = (k_pred[0] * e_v + k_pred[1] * e_gamma + k_pred[2] * e_phi
          + k_pred[3] * gamma_dot + k_pred[4] * phi_dot)
    if integral:
        fb += k_pred[5] * z
    fb += history
    u = u_ref - fb
    return limit if u > limit else (-limit if u < -limit else u)


class _Lookup:
    """``Y[k]`` for k in a block, backed by the block's sensed states."""

    def __init__(self, k0: int, Y_sensed: np.ndarray):
        self.k0, self.rows = k0, Y_sensed.tolist()

    def __getitem__(self, k: int):
        return self.rows[k - self.k0]


@lru_cache(maxsize=32)
def _delay_law(p: Params, motor: MotorPD, K: tuple, dt: float, n: int, predictor: bool):
    """K Φⁿ (tuple), KG (n,), lower and past (:func:`_chunk_matrices`) of the delayed law, cached
    and read-only (:func:`euc_sim.controllers.plant.predictor_rows`).
    """
    from euc_sim.controllers.plant import predictor_rows  # deferred: loads scipy.linalg (0.3 s)

    K = np.asarray(K, dtype=float)
    if predictor and n > 0:
        KPn, KG = predictor_rows(p, motor, K, dt, n)
    else:
        KPn, KG = K, np.zeros(n)
    KG = np.ascontiguousarray(KG)
    lower, past = _chunk_matrices(KG)
    for arr in (KG, lower, past):
        arr.setflags(write=False)
    return tuple(float(k) for k in KPn), KG, lower, past


def _chunk_matrices(KG: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The predictor's recursion over a block of n + 1 steps: ``lower`` δu_block = r − ``past`` δu_before.

    ``lower`` (n+1, n+1) is unit lower-triangular, entry (j, j') = KG_{n−j+j'} for j' < j;
    ``past`` (n+1, n) has entry (j, m) = KG_{m−j} for m ≥ j.
    """
    n = len(KG)
    lower = np.eye(n + 1, order="F")
    past = np.zeros((n + 1, n))
    for j in range(n + 1):
        lower[j, :j] = KG[n - j:n]
        past[j, j:] = KG[:n - j]
    return lower, past

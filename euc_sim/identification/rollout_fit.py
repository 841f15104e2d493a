"""h by simulation error in MuJoCo: a second opinion where both torques are recorded.

The recording is cut into windows of :data:`WINDOW` s, each rolled out open loop in the
planar model with the recorded M_d and M_h from a free initial state (multiple shooting
without continuity constraints).  h and the window states minimise
Σ ((q_sim − q_rec)/σ)² over x, γ, φ, σ each channel's noise, by Levenberg–Marquardt through
the Schur complement of the block-arrow normal equations; the Jacobian is finite
differences in one batched :func:`mujoco.rollout.rollout` call.  The 95 % interval is
Gauss–Newton's, ĥ ± 1.96 sqrt(s² (JᵀJ)⁻¹_hh).  Torques are interpolated linearly between
samples (:data:`SUBSTEPS` per sample).  See docs/coverage.md.
"""

from __future__ import annotations

import copy
import math
import time
from dataclasses import dataclass

import mujoco
import numpy as np
from mujoco import rollout as mj_rollout

from euc_sim.errors import InputError
from euc_sim.model.mujoco_model import JointIndex, load_model, to_mujoco, from_mujoco
from euc_sim.model.parameters import Params
from euc_sim.identification.noise_bootstrap import split_noise
from euc_sim.identification.processing import Kinematics, sample_period

#: Window length, s.
WINDOW = 1.0
#: Integration steps per recorded sample (RK4).
SUBSTEPS = 1
#: Finite-difference steps: h (m) and the window state (m, rad, m/s, rad/s).
_DH = 1e-4
_DS = np.array([1e-5, 1e-5, 1e-5, 1e-4, 1e-4, 1e-4])
#: Levenberg–Marquardt iterations at most.
MAX_ITER = 40
#: Relative distance to a search bound under which a value counts as on it.
BOUND_TOL = 1e-3


class RolloutError(InputError):
    """The recording cannot be fitted by rollout (no torques, too short)."""


@dataclass
class RolloutFit:
    """h from the simulation error of windowed rollouts.

    Attributes
    ----------
    h : float
        m.
    h_ci95 : tuple of float
        95 % interval, m.
    seconds : float
        Wall time of the fit, s.
    windows : int
    at_bound : list of str
        Fitted quantities that end on their search bound (``"h"``).
    correlation : ndarray, shape (1 + 6 W, 1 + 6 W)
        Parameter correlations: h, then each window's (x, γ, φ, ẋ, γ̇, φ̇).
    t : ndarray, shape (W, L)
        Sample times of the windows, s.
    q_rec, q_fit : ndarray, shape (W, L, 3)
        Recorded and rolled-out (x, γ, φ).
    rms : ndarray, shape (3,)
        RMS simulation error per channel (m, rad, rad).
    nfev : int
        Residual evaluations.
    """

    h: float
    h_ci95: tuple
    seconds: float
    windows: int
    at_bound: list
    correlation: np.ndarray
    t: np.ndarray
    q_rec: np.ndarray
    q_fit: np.ndarray
    rms: np.ndarray
    nfev: int

    def as_json(self) -> dict:
        """CONTRACT's ``rollout`` entry plus the correlation of h with the window states."""
        c = self.correlation[0, 1:]
        return {"h": self.h, "h_ci95": list(self.h_ci95), "seconds": self.seconds,
                "windows": self.windows, "at_bound": list(self.at_bound),
                "rms": {"x": self.rms[0], "gamma": self.rms[1], "phi": self.rms[2]},
                "max_abs_correlation_h": float(np.max(np.abs(c))) if c.size else math.nan}


@dataclass(frozen=True)
class Windows:
    """A recording cut into rollout windows sharing their end samples: time ``t`` (N,) and ``dt``, s; the samples
    ``idx`` (W, L) of each window; the recorded (x, γ, φ) ``q_rec`` (W, L, 3); their noise
    ``sig`` (3,), m, rad, rad; the starting states ``s0`` (W, 6) from the kinematics."""

    t: np.ndarray
    dt: float
    idx: np.ndarray
    q_rec: np.ndarray
    sig: np.ndarray
    s0: np.ndarray


def rollout_windows(df, kin: Kinematics, fit: str) -> Windows:
    """Cut a recording with ``t, x, gamma, phi, M_d, M_h`` into windows of :data:`WINDOW` s (RolloutError naming
    the ``fit``: without those columns or shorter than one window)."""
    need = [c for c in ("M_d", "M_h", "x", "gamma", "phi") if c not in df.columns]
    if need:
        raise RolloutError(f"the {fit} fit needs the recorded column {need[0]!r} "
                           f"(both torques M_d, M_h and the states x, gamma, phi)")
    t = df["t"].to_numpy(dtype=float)
    dt = sample_period(t)
    L = int(round(WINDOW / dt)) + 1
    n_win = (len(t) - 1) // (L - 1)
    if n_win < 1:
        raise RolloutError(f"the recording ({t[-1] - t[0]:.2f} s) is shorter than one rollout window ({WINDOW:g} s)")
    Q = df[["x", "gamma", "phi"]].to_numpy(dtype=float)
    sig = np.array([max(split_noise(Q[:, i], dt)[1], floor) for i, floor in enumerate((1e-5, 1e-4, 1e-4))])
    starts = np.arange(n_win) * (L - 1)
    idx = starts[:, None] + np.arange(L)[None, :]
    s0 = np.concatenate([kin.q[starts], kin.qd[starts]], axis=1)
    return Windows(t=t, dt=dt, idx=idx, q_rec=Q[idx], sig=sig, s0=s0)


class _Roller:
    """Batched rollouts of the windows: states and controls at the substep rate."""

    def __init__(self, p: Params, dt: float, M: np.ndarray, n_win: int, L: int):
        self.model = load_model(p, "ideal")
        self.model.opt.timestep = dt / SUBSTEPS
        self.index = JointIndex.of(self.model)
        self.R = p.R
        self.rider = mujoco.mj_name2id(self.model, mujoco.mjtObj.mjOBJ_BODY, "rider")
        self.data = mujoco.MjData(self.model)
        self.spec = mujoco.mjtState.mjSTATE_FULLPHYSICS
        self.nstate = mujoco.mj_stateSize(self.model, self.spec)
        self.L = L
        # controls per substep: torques interpolated linearly between samples
        act = [mujoco.mj_name2id(self.model, mujoco.mjtObj.mjOBJ_ACTUATOR, n) for n in ("motor", "ankle")]
        nu = self.model.nu
        n_sub = (L - 1) * SUBSTEPS
        frac = (np.arange(n_sub) % SUBSTEPS + 0.5) / SUBSTEPS
        k = np.arange(n_sub) // SUBSTEPS
        self.ctrl = np.zeros((n_win, n_sub, nu))
        for w in range(n_win):
            seg = M[w * (L - 1): w * (L - 1) + L]                       # (L, 2)
            val = seg[k] + (seg[k + 1] - seg[k]) * frac[:, None]
            for j, a in enumerate(act):
                self.ctrl[w, :, a] = val[:, j]
        self._models: dict = {}

    def model_for(self, h: float) -> mujoco.MjModel:
        key = round(float(h), 12)
        if key not in self._models:
            if len(self._models) > 8:
                self._models.clear()
            m = copy.copy(self.model)
            m.body_ipos[self.rider, 2] = h
            self._models[key] = m
        return self._models[key]

    def initial(self, s: np.ndarray) -> np.ndarray:
        """Full-physics states of paper states s (B, 6)."""
        qpos, qvel, _ = to_mujoco(self.index, self.R, s[:, :3], s[:, 3:])
        out = np.empty((len(s), self.nstate))
        for i in range(len(s)):
            self.data.qpos[:] = qpos[i]
            self.data.qvel[:] = qvel[i]
            self.data.time = 0.0
            mujoco.mj_getState(self.model, self.data, out[i], self.spec)
        return out

    def run(self, hs: np.ndarray, s: np.ndarray, win: np.ndarray) -> np.ndarray:
        """q at the samples (B, L, 3) of rollouts with h = hs[b], state s[b], window win[b]."""
        models = [self.model_for(h) for h in hs]
        state, _ = mj_rollout.rollout(models, self.data, self.initial(s), self.ctrl[win])
        nq = self.model.nq
        qpos = state[:, SUBSTEPS - 1::SUBSTEPS, 1:1 + nq]                  # after each sample period
        q, _, _ = from_mujoco(self.index, qpos)
        q0 = s[:, None, :3]
        return np.concatenate([q0, q], axis=1)


def fit_rollout(df, kin: Kinematics, p: Params, h0: float, bounds=(0.1, 1.5)) -> RolloutFit:
    """Identify h by the simulation error of rollouts over windows of :data:`WINDOW` s with free initial states.

    Parameters
    ----------
    df : DataFrame
        A state-level recording with ``t, x, gamma, phi, M_d, M_h``.
    kin : Kinematics
        Its kinematics (the windows' starting guesses).
    p : Params
        Every parameter but h.
    h0 : float
        Starting h, m.
    bounds : (float, float)
        Search bounds of h, m.

    Raises
    ------
    RolloutError
        without the torque or state columns, or shorter than one window.
    """
    t0 = time.perf_counter()
    win = rollout_windows(df, kin, "rollout")
    n_win, L = win.idx.shape
    q_rec, sig, s0 = win.q_rec, win.sig, win.s0
    roller = _Roller(p, win.dt, df[["M_d", "M_h"]].to_numpy(dtype=float), n_win, L)
    lo, hi = map(float, bounds)
    theta0 = np.concatenate([[min(max(h0, lo + 1e-6), hi - 1e-6)], s0.ravel()])
    wins = np.arange(n_win)

    def fun(h, S):
        return (roller.run(np.full(n_win, h), S, wins) - q_rec) / sig          # (W, L, 3)

    def jac(h, S):
        """Finite differences, one batched rollout: a (W, n) for h, B (W, n, 6) for the states."""
        hs, ss = [np.full(n_win, h)], [S]
        for j in range(6):
            Sj = S.copy()
            Sj[:, j] += _DS[j]
            hs.append(np.full(n_win, h))
            ss.append(Sj)
        hs.append(np.full(n_win, h + _DH))
        ss.append(S)
        out = roller.run(np.concatenate(hs), np.concatenate(ss), np.tile(wins, 8))
        out = out.reshape(8, n_win, L, 3) / sig
        a = ((out[7] - out[0]) / _DH).reshape(n_win, -1)
        B = np.stack([((out[1 + j] - out[0]) / _DS[j]).reshape(n_win, -1) for j in range(6)], axis=-1)
        return a, B

    h, S, r, cost, nfev = _levenberg_marquardt(fun, jac, float(theta0[0]), s0.copy(), lo, hi)
    corr, sd_h = _correlation(*jac(h, S), cost, r.size)
    q_fit = roller.run(np.full(n_win, h), S, wins)
    tol = BOUND_TOL * (hi - lo)
    at_bound = ["h"] if (h - lo < tol or hi - h < tol) else []
    ci = (max(lo, h - 1.96 * sd_h), min(hi, h + 1.96 * sd_h))
    rms = np.sqrt(np.mean((q_fit - q_rec) ** 2, axis=(0, 1)))
    return RolloutFit(h=h, h_ci95=ci, seconds=time.perf_counter() - t0, windows=n_win,
                      at_bound=at_bound, correlation=corr, t=win.t[win.idx], q_rec=q_rec, q_fit=q_fit,
                      rms=rms, nfev=nfev)


def _levenberg_marquardt(fun, jac, h: float, S: np.ndarray, lo: float, hi: float):
    """Minimise Σ fun(h, S)² over h in [lo, hi] and the window states S (W, 6): (h, S, r, cost, nfev)."""
    n_win = len(S)
    r = fun(h, S).reshape(n_win, -1)
    cost, mu, nfev = float(np.sum(r ** 2)), 1e-3, 1
    for _ in range(MAX_ITER):
        a, B = jac(h, S)
        nfev += 8
        g_h, g_w = float(np.sum(a * r)), np.einsum("wnj,wn->wj", B, r)
        H_hh, H_hw, H_ww = float(np.sum(a * a)), np.einsum("wnj,wn->wj", B, a), np.einsum("wni,wnj->wij", B, B)
        improved = False
        while mu < 1e10:
            Hd = H_ww + mu * np.einsum("wii->wi", H_ww)[:, :, None] * np.eye(6)
            Hinv_hw = np.linalg.solve(Hd, H_hw[..., None])[..., 0]
            Hinv_g = np.linalg.solve(Hd, g_w[..., None])[..., 0]
            schur = H_hh * (1 + mu) - float(np.sum(H_hw * Hinv_hw))
            dh = (-g_h + float(np.sum(H_hw * Hinv_g))) / schur
            h_new = min(max(h + dh, lo), hi)
            dS = -Hinv_g - Hinv_hw * (h_new - h)
            r_new = fun(h_new, S + dS).reshape(n_win, -1)
            nfev += 1
            cost_new = float(np.sum(r_new ** 2))
            if cost_new < cost:
                step, rel = abs(h_new - h), (cost - cost_new) / cost
                h, S, r, cost, mu, improved = h_new, S + dS, r_new, cost_new, max(mu / 3, 1e-9), True
                break
            mu *= 4
        if not improved or (step < 1e-6 and rel < 1e-7):
            break
    return h, S, r, cost, nfev


def _correlation(a: np.ndarray, B: np.ndarray, cost: float, n_res: int):
    """Gauss–Newton covariance of (h, window states) at the optimum: the correlation
    matrix and h's standard deviation (m)."""
    n_win = len(B)
    W6 = 6 * n_win
    J_states = np.zeros((n_win, a.shape[1], W6))
    for w in range(n_win):
        J_states[w, :, 6 * w: 6 * w + 6] = B[w]
    H = np.zeros((1 + W6, 1 + W6))
    H[0, 0] = np.sum(a * a)
    H[0, 1:] = H[1:, 0] = np.einsum("wn,wnk->k", a, J_states)
    H[1:, 1:] = np.einsum("wnk,wnl->kl", J_states, J_states)
    cov = cost / max(1, n_res - (1 + W6)) * np.linalg.pinv(H)
    sd = np.sqrt(np.clip(np.diag(cov), 0.0, None))
    corr = cov / np.outer(np.where(sd > 0, sd, 1.0), np.where(sd > 0, sd, 1.0))
    return corr, float(sd[0])

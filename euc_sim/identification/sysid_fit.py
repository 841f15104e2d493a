"""h by simulation error with MuJoCo's own toolbox, ``mujoco.sysid``.

The problem of :mod:`euc_sim.identification.rollout_fit` in the toolbox's terms: ``h`` a
``Parameter`` writing the rider's ``ipos`` into the MjSpec, each window's state a
6-vector ``Parameter``, each window one sequence of a ``ModelSequences``, solved by
:func:`mujoco.sysid.optimize`, the interval from ``calculate_intervals``.  Three hooks:
``custom_rollout`` (free initial states, memoised per window), ``modify_residual``
((q_sim − q_rec)/σ rather than the data norm) and ``build_model`` (compiled model
memoised by h).  Torques enter as the mean of consecutive samples held over each step.
"""

from __future__ import annotations

import io
import time

import mujoco
import numpy as np
from mujoco import rollout as mj_rollout

from euc_sim.identification.processing import Kinematics
from euc_sim.identification.rollout_fit import BOUND_TOL, RolloutError, RolloutFit, rollout_windows
from euc_sim.model.mujoco_model import JointIndex, build_spec, from_mujoco, to_mujoco
from euc_sim.model.parameters import Params
from euc_sim.stats import one_blas_thread

#: Optimizer iterations at most.
MAX_ITER = 40
#: Half-width of each window state's search box around its starting guess
#: (m, rad, rad, m/s, rad/s, rad/s).
STATE_SPAN = np.array([1.0, 0.5, 0.5, 2.0, 2.0, 2.0])
#: Per-parameter scale handed to the optimizer (``x_scale``): h, then the state.
_SCALE_H = 1e-2
_SCALE_S = np.array([1e-3, 1e-3, 1e-3, 1e-2, 1e-2, 1e-2])

MISSING_EXTRA = ("--method sysid needs MuJoCo's system-identification toolbox: "
                 "pip install 'euc-sim[sysid]' (the mujoco[sysid] extra)")


def sysid_available() -> bool:
    """Whether ``mujoco.sysid`` imports with its optional dependencies (checked by its ``optimize``: it swallows a
    missing one)."""
    try:
        import mujoco.sysid as ms
    except ImportError:
        return False
    return hasattr(ms, "optimize") and hasattr(ms, "calculate_intervals")


def fit_sysid(df, kin: Kinematics, p: Params, h0: float, bounds=(0.1, 1.5), fast: bool = True) -> RolloutFit:
    """Identify h with ``mujoco.sysid`` over windows of :data:`~euc_sim.identification.rollout_fit.WINDOW` s with
    free initial states, at most :data:`MAX_ITER` iterations.

    Parameters
    ----------
    df, kin, p, h0, bounds
        As :func:`~euc_sim.identification.rollout_fit.fit_rollout`.
    fast : bool
        Memoise the compiled model by h (False: recompile for every column of every window).

    Returns
    -------
    RolloutFit
        ``h_ci95`` from :func:`mujoco.sysid.calculate_intervals`; ``nfev`` counts parameter
        vectors evaluated.

    Raises
    ------
    RolloutError
        as ``fit_rollout``, or without the ``mujoco[sysid]`` extra.
    """
    if not sysid_available():
        raise RolloutError(MISSING_EXTRA)
    import mujoco.sysid as ms
    from absl import logging as absl_logging  # deferred: loads absl, the mujoco[sysid] extra's (optional)
    absl_logging.set_verbosity(absl_logging.ERROR)      # one warning per window otherwise

    t0 = time.perf_counter()
    lo, hi = map(float, bounds)
    prob = _Problem(ms, df, kin, p, min(max(h0, lo + 1e-6), hi - 1e-6), lo, hi, fast)
    x_scale = np.concatenate([[_SCALE_H], np.tile(_SCALE_S, prob.n_win)])
    # the backend's full verbosity is what puts the end point's Jacobian in the result;
    # one BLAS thread: the backend's dense JᵀJ (W·3L × (1 + 6W)) is too small to gain from a pool
    with one_blas_thread():
        opt, res = ms.optimize(prob.params, prob.residual_fn, optimizer="mujoco", verbose=False,
                               max_iters=MAX_ITER, x_scale=x_scale, output=io.StringIO())
        r_star, preds, _ = prob.residual_fn(opt.as_vector(), opt.copy(), return_pred_all=True)
        cov, half = ms.calculate_intervals(r_star, np.asarray(res.jac))
    h = float(opt["h"].value[0])
    sd = np.sqrt(np.clip(np.diag(cov), 0.0, None))
    corr = cov / np.outer(np.where(sd > 0, sd, 1.0), np.where(sd > 0, sd, 1.0))
    q_fit = np.stack([pr.data for pr in preds])
    tol = BOUND_TOL * (hi - lo)
    at_bound = ["h"] if (h - lo < tol or hi - h < tol) else []
    hw = float(half[0])
    rms = np.sqrt(np.mean((q_fit - prob.q_rec) ** 2, axis=(0, 1)))
    return RolloutFit(h=h, h_ci95=(max(lo, h - hw), min(hi, h + hw)), seconds=time.perf_counter() - t0,
                      windows=prob.n_win, at_bound=at_bound, correlation=corr, t=prob.t[prob.idx],
                      q_rec=prob.q_rec, q_fit=q_fit, rms=rms, nfev=prob.n_eval)


class _Problem:
    """The windowed fit in the toolbox's terms: its data, parameters and three hooks."""

    def __init__(self, ms, df, kin: Kinematics, p: Params, h_start: float, lo: float, hi: float, fast: bool):
        win = rollout_windows(df, kin, "sysid")
        self.ms, self.R = ms, p.R
        self.t, self.idx, self.q_rec, self.sig, s0 = win.t, win.idx, win.q_rec, win.sig, win.s0
        self.n_win = len(win.idx)
        self.spec = build_spec(p.replace(h=h_start), "ideal")
        self.spec.option.timestep = win.dt
        self.model0 = self.spec.compile()
        self.index = JointIndex.of(self.model0)
        self.nstate = mujoco.mj_stateSize(self.model0, mujoco.mjtState.mjSTATE_FULLPHYSICS)
        self.data0 = mujoco.MjData(self.model0)
        self.windows = self._sequences(df[["M_d", "M_h"]].to_numpy(dtype=float), s0)
        self.params = ms.ParameterDict()
        self.params.add(ms.Parameter("h", h_start, lo, hi, modifier=_set_h))
        # all window states in one Parameter: the toolbox deep-copies the ParameterDict for
        # every column of every window
        self.params.add(ms.Parameter("window_states", s0, s0 - STATE_SPAN, s0 + STATE_SPAN))
        self.build = self._build_memo if fast else ms.apply_param_modifiers
        self._built, self._memo, self.n_eval = {}, {}, 0
        self._pool = [mujoco.MjData(self.model0)]

    def full_state(self, s, t_start: float) -> np.ndarray:
        """The full-physics state of paper state s (6,) at time t_start."""
        qpos, qvel, _ = to_mujoco(self.index, self.R, s[:3], s[3:])
        self.data0.qpos[:], self.data0.qvel[:], self.data0.time = qpos, qvel, t_start
        out = np.empty(self.nstate)
        mujoco.mj_getState(self.model0, self.data0, out, mujoco.mjtState.mjSTATE_FULLPHYSICS)
        return out

    def _sequences(self, M: np.ndarray, s0: np.ndarray) -> list:
        """One measured sequence per window (a ``ModelSequences``); the window of a
        control series is found again by its identity."""
        ms, L = self.ms, self.idx.shape[1]
        act = [mujoco.mj_name2id(self.model0, mujoco.mjtObj.mjOBJ_ACTUATOR, n) for n in ("motor", "ankle")]
        names, init, controls, sensors = [], [], [], []
        for w, ix in enumerate(self.idx):
            seg = M[ix]
            u = np.zeros((L, self.model0.nu))
            for j, a in enumerate(act):
                u[:-1, a] = 0.5 * (seg[:-1, j] + seg[1:, j])     # the step's mean torque
                u[-1, a] = seg[-1, j]                            # dropped by the toolbox
            names.append(f"window{w:02d}")
            init.append(self.full_state(s0[w], self.t[ix[0]]))
            controls.append(ms.TimeSeries(self.t[ix], u))
            sensors.append(ms.TimeSeries(self.t[ix], self.q_rec[w]))
        self.window_of = {id(c): w for w, c in enumerate(controls)}
        self.seqs = ms.ModelSequences("euc_planar", self.spec, names, init, controls, sensors,
                                      allow_missing_sensors=True)
        return self.seqs.measured_rollout

    def _build_memo(self, prm, spec) -> mujoco.MjModel:
        """``build_model`` hook: the toolbox's compile, memoised by h."""
        key = round(float(prm["h"].value[0]), 12)
        if key not in self._built:
            if len(self._built) > 64:
                self._built.clear()
            self._built[key] = self.ms.apply_param_modifiers(prm, spec)
        return self._built[key]

    def custom_rollout(self, models, datas, control_signal, initial_states, param_dicts,
                       rollout_signal_mapping, rollout_state_mapping, ctrl_mapping):
        """``custom_rollout`` hook: each (column, window) from the window state held in the
        parameters, memoised by (h, window state)."""
        n_chunk = len(models) // len(param_dicts)
        out, todo = [None] * len(models), []
        for i, (m, u) in enumerate(zip(models, control_signal)):
            w = self.window_of[id(u)]
            prm = param_dicts[i // n_chunk]
            s = prm["window_states"].value[w]
            key = (w, float(prm["h"].value[0]), s.tobytes())
            if key in self._memo:
                out[i] = self._memo[key]
            else:
                todo.append((i, m, w, s, key, u))
        if not todo:
            return out
        x0 = np.stack([self.full_state(s, self.t[self.idx[w, 0]]) for _, _, w, s, _, _ in todo])
        state, _ = mj_rollout.rollout([m for _, m, *_ in todo], self._pool, x0,
                                      np.stack([u.data[:-1] for *_, u in todo]))
        if len(self._memo) > 20000:
            self._memo.clear()
        for (i, m, w, s, key, u), st, x in zip(todo, state, x0):
            full = np.concatenate([x[None, :], st], axis=0)               # initial row + L−1 steps
            q, _, _ = from_mujoco(self.index, full[:, 1:1 + self.model0.nq])
            times = self.t[self.idx[w]]
            out[i] = self._memo[key] = self.ms.SystemTrajectory(
                model=m, control=u, sensordata=self.ms.TimeSeries(times, q), initial_state=x,
                state=self.ms.TimeSeries(times, full))
        return out

    def modify_residual(self, prm, pred, meas, model, return_pred_all, state=None, **kw):
        """``modify_residual`` hook: the error over the measurement noise, (q_sim − q_rec)/σ."""
        return (pred.data - meas.data) / self.sig, pred, meas

    def residual_fn(self, x, prm, return_pred_all=False):
        """All windows in one call of the toolbox's ``model_residual`` (one batched rollout), its column-major
        finite-difference batch put back in order."""
        self.n_eval += x.shape[1] if np.ndim(x) > 1 else 1
        r, pred, meas = self.ms.model_residual(
            x, prm, lambda q: self.build(q, self.spec), self.windows, self.modify_residual,
            self.custom_rollout, 1, return_pred_all, False)
        if np.ndim(x) > 1:                                   # (3L, n_col·W) → (W·3L, n_col)
            r = r.T.reshape(x.shape[1], -1).T
        return [r], pred, meas


def _set_h(spec: mujoco.MjSpec, prm) -> None:
    """Modifier of the ``h`` Parameter: the rider's centre of mass above the ankle, m."""
    spec.body("rider").ipos = [0.0, 0.0, float(prm.value[0])]

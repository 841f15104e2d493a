"""The engines of :func:`euc_sim.simulation.engine.simulate`: one control step each.

:class:`_MujocoStepper` steps :class:`euc_sim.model.mujoco_model.EucMujoco` (RK4 at dt),
reading the state by joint name; :class:`_AnalyticStepper` integrates eqs. (5)-(8) plus the
effects' generalised forces with ``scipy.integrate.solve_ivp`` (DOP853) over the same step.
Both hold the motor and ankle torques and the external inputs (``set_effects``) over the
step, so the two engines are comparable sample by sample.  The names stay private: the
engine module builds them (``engine.prepare``) and re-exports them for the benchmarks and
tests that drive a stepper directly.
"""

from __future__ import annotations

import math
from functools import partial

import numpy as np

from euc_sim.model import analytic
from euc_sim.model.parameters import Params
from euc_sim.simulation import effects as fx
from euc_sim.simulation.errors import SimulationError


class _MujocoStepper:
    """One control step of MuJoCo with held torques and per-step effects."""

    def __init__(self, p: Params, variant: str, dt: float, eff: dict, contact):
        import mujoco

        from euc_sim.model.mujoco_model import EucMujoco  # deferred: loads mujoco (0.1 s)

        self.mj = mujoco
        self.sim = EucMujoco(p, variant, contact=contact, timestep=dt)
        m = self.sim.model
        self.m, self.d = m, self.sim.data
        idx = self.sim.index
        self.ix, self.ig, self.ir = idx.qpos["x"], idx.qpos["euc_pitch"], idx.qpos["rider_pitch"]
        self.vx, self.vg, self.vr = idx.dof["x"], idx.dof["euc_pitch"], idx.dof["rider_pitch"]
        body = lambda n: mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, n)   # noqa: E731
        self.b_wheel, self.b_rider = body("wheel"), body("rider")
        self.site_G = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_SITE, "G")
        self.a_motor = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_ACTUATOR, "motor")
        self.a_ankle = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_ACTUATOR, "ankle")
        alpha = eff.get("road_slope", 0.0)
        self.g0 = np.array([-p.g * math.sin(alpha), 0.0, -p.g * math.cos(alpha)])  # road frame
        m.opt.gravity[:] = self.g0
        if "wheel_bearing_friction" in eff:
            self.sim.set_bearing_damping(eff["wheel_bearing_friction"])
        self.p = p
        self.spin = idx.has_spin
        self.step = self._make_step()

    def reset(self, y) -> None:
        self.sim.set_state(y[:3], y[3:])

    def set_effects(self, Fx_drag: float, tau_roll: float, h: float | None, Q_lat) -> None:
        xf = self.d.xfrc_applied
        xf[self.b_rider, 0] = Fx_drag          # force at the rider's CoM G, world (road) frame
        Q_x = 0.0
        if self.spin:
            xf[self.b_wheel, 4] = tau_roll     # moment about +y on the wheel
        else:                                  # the wheel turns at x/R: τ dθ = (τ/R) dx
            Q_x = tau_roll / self.p.R
        if h is not None:
            self.m.body_ipos[self.b_rider, 2] = h
            if self.site_G >= 0:                # the contact variant keeps its sites
                self.m.site_pos[self.site_G, 2] = h
        if Q_lat is not None or not self.spin:   # paper Q → MuJoCo: Q_paper = Tᵀ Q_mj (paper_jacobian)
            Q_lat = (0.0, 0.0, 0.0) if Q_lat is None else Q_lat
            qf = self.d.qfrc_applied
            qf[self.vx] = Q_lat[0] + Q_x
            qf[self.vg] = Q_lat[1] + Q_lat[2]
            qf[self.vr] = Q_lat[2]

    def _make_step(self):
        """``step(M_d, M_h)`` as a closure over MjData's views: attribute look-ups cost more
        than the step's own arithmetic at 1 kHz."""
        mj_step = partial(self.mj.mj_step, self.m, self.d)
        ctrl, qpos, qvel = self.d.ctrl, self.d.qpos, self.d.qvel
        a_motor, a_ankle = self.a_motor, self.a_ankle
        ix, ig, ir, vx, vg, vr = self.ix, self.ig, self.ir, self.vx, self.vg, self.vr

        def step(M_d: float, M_h: float):
            ctrl[a_motor] = M_d
            ctrl[a_ankle] = M_h
            mj_step()
            qp, qv = qpos.tolist(), qvel.tolist()      # Python floats: cheaper downstream
            g, gd = qp[ig], qv[vg]
            return (qp[ix], g, g + qp[ir], qv[vx], gd, gd + qv[vr])

        return step


class _AnalyticStepper:
    """One control step of eqs. (5)-(8) with solve_ivp, torques and held forces fixed."""

    RTOL, ATOL = 1e-10, 1e-12

    def __init__(self, p: Params, dt: float, eff: dict):
        self.p, self.dt, self.eff = p, dt, eff
        self.y = np.zeros(6)
        self.t = 0.0
        self.held = (0.0, 0.0, None, None)

    def reset(self, y) -> None:
        self.y = np.array(y, dtype=float)
        self.t = 0.0

    def set_effects(self, Fx_drag: float, tau_roll: float, h: float | None, Q_lat) -> None:
        self.held = (Fx_drag, tau_roll, h, Q_lat)

    def rhs(self, t, y, M_d, M_h):
        """ẏ of eq. (5) with the effects' generalised forces added to Q (eq. 8)."""
        Fx, tau, h, Q_lat = self.held
        p = self.p if h is None else self.p_h
        eff = self.eff
        q, qd = y[:3], y[3:]
        Q = analytic.generalized_forces(p, q, M_d, M_h)                   # eq. (8)
        if "road_slope" in eff:
            Q = Q + fx.generalized_force("road_slope", eff["road_slope"], p, q, qd)
        if Q_lat is not None:
            Q = Q + Q_lat
        if "wheel_bearing_friction" in eff:
            Q = Q + fx.generalized_force("wheel_bearing_friction", eff["wheel_bearing_friction"], p, q, qd)
        if Fx:                                  # held force at G: F ∂x_G/∂q
            Q = Q + Fx * np.array([1.0, -p.l0 * math.cos(q[1]), p.h * math.cos(q[2])])
        if tau:                                 # held moment on the wheel: Q_x = τ/R
            Q[0] += tau / p.R
        qdd = np.linalg.solve(analytic.mass_matrix(p, q), Q - analytic.nonlinear_terms(p, q, qd))
        out = np.empty(6)
        out[:3] = qd
        out[3:] = qdd
        return out

    def step(self, M_d: float, M_h: float):
        from scipy.integrate import solve_ivp

        h = self.held[2]
        if h is not None:
            self.p_h = self.p.replace(h=h)
        t_end = self.t + self.dt
        sol = solve_ivp(self.rhs, (self.t, t_end), self.y, method="DOP853", rtol=self.RTOL,
                        atol=self.ATOL, args=(M_d, M_h), first_step=t_end - self.t)
        if not sol.success:
            raise SimulationError(f"analytic integration failed at t = {self.t:.3f} s: {sol.message}")
        self.y = sol.y[:, -1]
        self.t = t_end
        return tuple(self.y.tolist())

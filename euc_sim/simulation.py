"""Closed-loop simulation: the EUC's motor PD and the rider on either engine.

:func:`simulate` runs one maneuver and returns a DataFrame at the control rate
(1 kHz by default), one row per control step:

=============  =====  ==========================================================
column         unit   meaning
=============  =====  ==========================================================
``t``          s      time of the step
``x``          m      wheel-centre position (CONTRACT)
``gamma``      rad    EUC body pitch (CONTRACT)
``phi``        rad    rider pitch (CONTRACT)
``x_dot``      m/s    ẋ
``gamma_dot``  rad/s  γ̇
``phi_dot``    rad/s  φ̇
``M_d``        N·m    true motor torque held over [t, t + dt) (CONTRACT sign)
``M_h``        N·m    true ankle torque held over [t, t + dt), noise included
``v_ref``      m/s    the rider's planned speed
``h``          m      rider CoG height, only with ``cog_height_drift``
``psi``        rad    yaw, only with ``lateral_dynamics``
``theta``      rad    tilt, only with ``lateral_dynamics``
=============  =====  ==========================================================

Both controllers run at 1/dt with a zero-order hold; the rider's reaction delay is a
look-back buffer over the state history (:class:`controllers.rider.RiderRun`).

Engines
-------
``mujoco``
    :class:`euc_sim.mujoco_model.EucMujoco` (RK4 at dt), state read by joint name.
``analytic``
    eqs. (5)-(8) plus the effects' generalised forces
    (:func:`euc_sim.effects.generalized_force`), integrated over each control step
    by ``scipy.integrate.solve_ivp`` (DOP853, rtol 1e-10) with the same held torques,
    so the two engines are comparable sample by sample.

Effects (CONTRACT's catalog) act as physics in both engines:
``rolling_resistance`` (moment on the wheel; MuJoCo: ``xfrc_applied`` on ``wheel``,
or true rolling friction with ``contact=ContactSettings(rolling_friction=...)`` on
the contact variant), ``aerodynamic_drag`` (force at G; MuJoCo: ``xfrc_applied`` on
``rider``), ``road_slope`` (``model.opt.gravity`` tilted in the road frame),
``wheel_bearing_friction`` (damping of ``wheel_spin``), ``rider_mass`` (parameters
through MjSpec), ``cog_height_drift`` (``model.body_ipos`` of ``rider`` each step),
``lateral_dynamics`` (a prescribed slalom, tilt ϑ(t) with the yaw rate of a
coordinated turn, acts through :func:`euc_sim.effects.lateral_forces`; MuJoCo:
``qfrc_applied``).  Velocity-dependent
external forces are evaluated at the start of each step and held, in both engines.
``sensor_time_offset`` acts on the recording only (:mod:`euc_sim.recording`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Mapping

import numpy as np
import pandas as pd

from controllers.motor import MotorPD
from controllers.rider import Rider, RiderRun
from euc_sim import analytic, effects as fx
from euc_sim.parameters import Params, TABLE3

__all__ = ["ENGINES", "MANEUVERS", "FALL_BOUNDS", "COLUMNS", "SimulationError", "FallError",
           "Maneuver", "make_maneuver", "load_speed_profile", "simulate", "lateral_profile", "LateralMotion",
           "true_params", "default_rider", "PeriodicPush"]

ENGINES = ("mujoco", "analytic")
MANEUVERS = ("constant_speed", "acceleration", "deceleration", "stop_and_go", "profile")
#: Fall bounds, rad: |φ| (rider) and |γ| (EUC body) beyond these end the run.
FALL_BOUNDS = {"phi": 0.7, "gamma": 0.5}
COLUMNS = ("t", "x", "gamma", "phi", "x_dot", "gamma_dot", "phi_dot", "M_d", "M_h", "v_ref")
#: Control period and MuJoCo timestep of :func:`simulate` by default, s.
DEFAULT_DT = 1e-3
#: Period of the lateral_dynamics slalom, s, and the speed floor of its yaw rate, m/s.
LATERAL_PERIOD = 6.0
LATERAL_MIN_SPEED = 1.0
#: Speed from which the slalom reaches its full tilt, m/s.
LATERAL_FULL_TILT_SPEED = 2.0
#: Effects handled by the simulator as physics (all of CONTRACT's catalog).
SIM_EFFECTS = ("rolling_resistance", "aerodynamic_drag", "road_slope", "wheel_bearing_friction",
               "rider_mass", "cog_height_drift", "lateral_dynamics", "sensor_time_offset")


class SimulationError(ValueError):
    """An invalid simulation request (maneuver, engine, effect, profile); names the argument."""


class FallError(SimulationError):
    """The rider or the EUC fell: a state left its bound or became non-finite.

    Attributes
    ----------
    t : float
        Time of the fall, s.
    quantity : str
        ``"phi"``, ``"gamma"`` or ``"state"`` (non-finite).
    value : float
        The offending value, rad.
    """

    def __init__(self, t: float, quantity: str, value: float, bound: float | None):
        self.t, self.quantity, self.value, self.bound = t, quantity, value, bound
        if bound is None:
            msg = f"fall at t = {t:.3f} s: the state became non-finite ({quantity} = {value!r})"
        else:
            msg = (f"fall at t = {t:.3f} s: |{quantity}| = {abs(value):.3f} rad exceeds the bound "
                   f"{bound:g} rad")
        super().__init__(msg)


# --- maneuvers ---------------------------------------------------------------------
def _ramp(u: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Cosine ramp s(u) = (1 − cos πu)/2 on [0, 1] and its derivative."""
    uc = np.clip(u, 0.0, 1.0)
    inside = (u > 0.0) & (u < 1.0)
    return 0.5 * (1.0 - np.cos(np.pi * uc)), np.where(inside, 0.5 * np.pi * np.sin(np.pi * uc), 0.0)


@dataclass(frozen=True)
class Maneuver:
    """A planned speed profile v_ref(t).

    Attributes
    ----------
    name : str
        One of :data:`MANEUVERS`.
    v0 : float
        Speed at t = 0, m/s.
    ramps : tuple of (start, duration, target)
        Smooth (cosine) speed changes: start time s, duration s, target speed m/s.
    table : tuple of (t, v) tuples, optional
        A tabulated profile (``profile``), interpolated by PCHIP, held beyond its ends.
    options : tuple of (name, value)
        The :func:`make_maneuver` options that built it (for sidecars:
        ``make_maneuver(name, **dict(options))`` rebuilds it).
    """

    name: str
    v0: float = 0.0
    ramps: tuple = ()
    table: tuple | None = field(default=None)
    options: tuple = ()

    def reference(self, t) -> tuple[np.ndarray, np.ndarray]:
        """Planned speed (m/s) and acceleration (m/s²) at times t (s)."""
        t = np.asarray(t, dtype=float)
        if self.table is not None:
            from scipy.interpolate import PchipInterpolator

            tt, vv = (np.asarray(c, dtype=float) for c in self.table)
            if len(tt) == 1:
                return np.full_like(t, vv[0]), np.zeros_like(t)
            f = PchipInterpolator(tt, vv, extrapolate=False)
            tc = np.clip(t, tt[0], tt[-1])
            a = f.derivative()(tc)
            a = np.where((t < tt[0]) | (t > tt[-1]), 0.0, a)
            return f(tc), a
        v = np.full_like(t, self.v0)
        a = np.zeros_like(t)
        prev = self.v0
        for start, dur, target in self.ramps:
            s, ds = _ramp((t - start) / dur)
            v = v + (target - prev) * s
            a = a + (target - prev) * ds / dur
            prev = target
        return v, a

    def as_dict(self) -> dict:
        """JSON-ready description."""
        d = {"name": self.name, "v0": self.v0, "ramps": [list(r) for r in self.ramps],
             "options": dict(self.options)}
        if self.table is not None:
            d["table"] = {"t": list(self.table[0]), "v": list(self.table[1])}
        return d


def make_maneuver(name: str, **options) -> Maneuver:
    """A built-in maneuver, shaped like the paper's recordings (speeds in m/s, times in s).

    Parameters
    ----------
    name : str
        ``constant_speed`` (options v), ``acceleration`` (v0, v1, start, ramp),
        ``deceleration`` (v0, v1, start, ramp) or ``stop_and_go`` (v, start, ramp,
        hold, cycles).
    **options
        Overrides of the defaults below.

    Raises
    ------
    SimulationError
        for an unknown name or option; the message lists the valid ones.
    """
    defaults = {
        "constant_speed": {"v": 3.0},
        "acceleration": {"v0": 1.0, "v1": 4.0, "start": 3.0, "ramp": 4.0},
        "deceleration": {"v0": 4.0, "v1": 0.5, "start": 3.0, "ramp": 4.0},
        "stop_and_go": {"v": 2.5, "start": 1.0, "ramp": 3.0, "hold": 2.0, "cycles": 3},
    }
    if name not in defaults:
        valid = ", ".join(MANEUVERS)
        raise SimulationError(f"unknown maneuver {name!r}; valid maneuvers: {valid} "
                              "(profile needs a speed-profile CSV)")
    unknown = sorted(set(options) - set(defaults[name]))
    if unknown:
        raise SimulationError(f"maneuver {name!r} has no option {unknown[0]!r}; "
                              f"options: {', '.join(defaults[name])}")
    o = {**defaults[name], **options}
    for key, val in o.items():
        if not (isinstance(val, (int, float)) and math.isfinite(val)):
            raise SimulationError(f"maneuver option {key!r} must be a finite number, got {val!r}")
    opts = tuple(sorted(options.items()))
    if name == "constant_speed":
        return Maneuver(name, float(o["v"]), options=opts)
    if name in ("acceleration", "deceleration"):
        if o["ramp"] <= 0:
            raise SimulationError(f"maneuver option 'ramp' must be positive, got {o['ramp']!r}")
        return Maneuver(name, float(o["v0"]), ((float(o["start"]), float(o["ramp"]), float(o["v1"])),),
                        options=opts)
    if o["ramp"] <= 0 or o["hold"] < 0 or int(o["cycles"]) < 1:
        raise SimulationError(f"stop_and_go needs ramp > 0, hold >= 0, cycles >= 1, got {o!r}")
    ramps, t = [], float(o["start"])
    for _ in range(int(o["cycles"])):
        ramps.append((t, float(o["ramp"]), float(o["v"])))
        t += o["ramp"] + o["hold"]
        ramps.append((t, float(o["ramp"]), 0.0))
        t += o["ramp"] + o["hold"]
    return Maneuver(name, 0.0, tuple(ramps), options=opts)


def load_speed_profile(path: str | Path) -> Maneuver:
    """A ``profile`` maneuver from a CSV with columns ``t`` (s) and ``v`` (m/s).

    Raises
    ------
    SimulationError
        for a missing or malformed file: missing columns, non-numeric or non-finite
        values, fewer than one row, t not strictly increasing.
    """
    path = Path(path)
    if not path.is_file():
        raise SimulationError(f"speed profile {path}: no such file")
    try:
        df = pd.read_csv(path)
    except Exception as exc:  # pandas raises several types for bad CSV
        raise SimulationError(f"speed profile {path}: cannot read CSV ({type(exc).__name__}: "
                              f"{str(exc).splitlines()[0] if str(exc) else ''})") from None
    df.columns = [str(c).strip() for c in df.columns]
    missing = [c for c in ("t", "v") if c not in df.columns]
    if missing:
        raise SimulationError(f"speed profile {path}: expected columns t, v; missing {', '.join(missing)} "
                              f"(found {', '.join(map(str, df.columns)) or 'none'})")
    try:
        t = pd.to_numeric(df["t"]).to_numpy(dtype=float)
        v = pd.to_numeric(df["v"]).to_numpy(dtype=float)
    except (ValueError, TypeError):
        raise SimulationError(f"speed profile {path}: columns t and v must be numbers") from None
    if len(t) < 1:
        raise SimulationError(f"speed profile {path}: expected at least one row, got none")
    if not (np.all(np.isfinite(t)) and np.all(np.isfinite(v))):
        raise SimulationError(f"speed profile {path}: t and v must be finite numbers")
    if np.any(np.diff(t) <= 0):
        i = int(np.nonzero(np.diff(t) <= 0)[0][0])
        raise SimulationError(f"speed profile {path}: t must be strictly increasing, got "
                              f"{t[i]:g} then {t[i + 1]:g} at rows {i + 1}-{i + 2}")
    return Maneuver("profile", float(v[0]), (), (tuple(t.tolist()), tuple(v.tolist())))


def _as_maneuver(maneuver) -> Maneuver:
    if isinstance(maneuver, Maneuver):
        return maneuver
    if isinstance(maneuver, str):
        if maneuver == "profile":
            raise SimulationError("maneuver 'profile' needs a speed-profile CSV: "
                                  "pass load_speed_profile(path)")
        return make_maneuver(maneuver)
    raise SimulationError(f"maneuver must be a name or a Maneuver, got {type(maneuver).__name__}")


# --- effects -------------------------------------------------------------------------
def _check_effects(effects: Mapping[str, float] | None) -> dict[str, float]:
    out = {}
    for name, value in dict(effects or {}).items():
        try:
            fx.get(name)                                # unknown name: lists the valid ones
        except ValueError as exc:
            raise SimulationError(str(exc)) from None
        try:
            v = float(value)
        except (TypeError, ValueError):
            raise SimulationError(f"effect {name}: expected a number, got {value!r}") from None
        if not math.isfinite(v):
            raise SimulationError(f"effect {name}: value must be finite, got {value!r}")
        if name in ("rolling_resistance", "aerodynamic_drag", "wheel_bearing_friction",
                    "cog_height_drift", "lateral_dynamics", "sensor_time_offset") and v < 0:
            raise SimulationError(f"effect {name}: value must be non-negative, got {v!r}")
        if name == "rider_mass" and v <= 0:
            raise SimulationError(f"effect rider_mass: the mass must be positive, got {v!r} kg")
        out[name] = v
    return out


def true_params(params: Params, effects: Mapping[str, float] | None) -> Params:
    """The parameters of the simulated physics: ``params`` with parameter effects applied."""
    p = params
    for name, value in _check_effects(effects).items():
        p = fx.apply_to_params(p, name, value)
    return p


@dataclass(frozen=True)
class LateralMotion:
    """Prescribed tilt and yaw of the ``lateral_dynamics`` slalom (arrays over t).

    Attributes: ``theta`` (rad), ``theta_d`` (rad/s), ``psi`` (rad), ``psi_d`` (rad/s),
    ``psi_dd`` (rad/s²).
    """

    theta: np.ndarray
    theta_d: np.ndarray
    psi: np.ndarray
    psi_d: np.ndarray
    psi_dd: np.ndarray


def lateral_profile(peak_tilt: float, t, v_ref) -> LateralMotion:
    """Slalom of the ``lateral_dynamics`` effect.

    The tilt is ϑ ∝ sin(2π t / 6 s) · min(1, |v_ref| / 2 m/s), scaled so that its
    peak is ``peak_tilt`` (riders lean into turns less at walking pace); the yaw rate
    is that of a coordinated turn at the planned speed, ψ̇ = g tan ϑ / max(|v_ref|,
    1 m/s), g = 9.81 m/s².  Rates are central differences on the grid t.

    Parameters
    ----------
    peak_tilt : float
        max |ϑ|, rad.
    t : array_like
        Times, s, increasing.
    v_ref : array_like
        Planned speed at t, m/s.

    Returns
    -------
    LateralMotion
    """
    t = np.asarray(t, dtype=float)
    speed = np.abs(np.asarray(v_ref, dtype=float))
    shape = np.sin(2.0 * np.pi * t / LATERAL_PERIOD) * np.minimum(1.0, speed / LATERAL_FULL_TILT_SPEED)
    peak = float(np.max(np.abs(shape))) if t.size else 0.0
    theta = peak_tilt * shape / peak if peak > 0 else np.zeros_like(t)
    psi_d = 9.81 * np.tan(theta) / np.maximum(speed, LATERAL_MIN_SPEED)
    psi = np.concatenate([[0.0], np.cumsum(0.5 * (psi_d[1:] + psi_d[:-1]) * np.diff(t))]) if t.size else t
    rate = (lambda y: np.gradient(y, t)) if t.size > 1 else np.zeros_like
    return LateralMotion(theta, rate(theta), psi, psi_d, rate(psi_d))


_RIDERS: dict = {}


def default_rider(params: Params = TABLE3, motor: MotorPD | None = None,
                  noise_std: float = 0.0, delay: float = 0.15) -> Rider:
    """The LQR-designed rider of :func:`controllers.design.design_rider`, cached per
    (params, motor), with the given motor noise (N·m) and reaction delay (s)."""
    from controllers.design import design_rider

    motor = motor or MotorPD()
    key = (params, motor)
    if key not in _RIDERS:
        _RIDERS[key] = design_rider(params, motor)
    return _RIDERS[key].replace(noise_std=noise_std, delay=delay)


@dataclass(frozen=True)
class PeriodicPush:
    """A horizontal force A·sin(2π f t) at the rider's G, N: a disturbance outside the catalog.

    Picklable, so it can travel to worker processes with a :class:`euc_sim.dataset.RecordingSpec`.
    """

    amplitude: float
    frequency: float

    def __call__(self, t: float) -> float:
        return self.amplitude * math.sin(2.0 * math.pi * self.frequency * t)

    def as_dict(self) -> dict:
        return {"kind": "periodic_push_at_G", "amplitude_N": self.amplitude, "frequency_Hz": self.frequency}


# --- engines -------------------------------------------------------------------------
class _MujocoStepper:
    """One control step of MuJoCo with held torques and per-step effects."""

    def __init__(self, p: Params, variant: str, dt: float, eff: dict, contact):
        import mujoco

        from euc_sim.mujoco_model import EucMujoco

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
            m.dof_damping[idx.dof["wheel_spin"]] = eff["wheel_bearing_friction"]
        self.p = p
        # views into MjData, cached: attribute access costs more than the step's arithmetic
        self._ctrl, self._qpos, self._qvel = self.d.ctrl, self.d.qpos, self.d.qvel

    def reset(self, y) -> None:
        self.sim.set_state(y[:3], y[3:])

    def set_effects(self, Fx_drag: float, tau_roll: float, h: float | None, Q_lat) -> None:
        xf = self.d.xfrc_applied
        xf[self.b_rider, 0] = Fx_drag          # force at the rider's CoM G, world (road) frame
        xf[self.b_wheel, 4] = tau_roll         # moment about +y on the wheel
        if h is not None:
            self.m.body_ipos[self.b_rider, 2] = h
            self.m.site_pos[self.site_G, 2] = h
        if Q_lat is not None:            # paper Q → MuJoCo: Q_paper = Tᵀ Q_mj (paper_jacobian)
            qf = self.d.qfrc_applied
            qf[self.vx] = Q_lat[0]
            qf[self.vg] = Q_lat[1] + Q_lat[2]
            qf[self.vr] = Q_lat[2]

    def step(self, M_d: float, M_h: float):
        ctrl = self._ctrl
        ctrl[self.a_motor] = M_d
        ctrl[self.a_ankle] = M_h
        self.mj.mj_step(self.m, self.d)
        qp, qv = self._qpos.tolist(), self._qvel.tolist()   # Python floats: cheaper downstream
        g = qp[self.ig]
        gd = qv[self.vg]
        return (qp[self.ix], g, g + qp[self.ir], qv[self.vx], gd, gd + qv[self.vr])


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


# --- the simulation ----------------------------------------------------------------
def simulate(maneuver="constant_speed", duration: float = 15.0, *, params: Params = TABLE3,
             motor: MotorPD | None = None, rider: Rider | None = None, seed: int = 0,
             engine: str = "mujoco", variant: str = "ideal",
             effects: Mapping[str, float] | None = None, dt: float = DEFAULT_DT,
             fall_bounds: Mapping[str, float] | None = None, contact=None,
             rolling_model: str = "moment", external_force=None,
             lateral_motion: LateralMotion | None = None) -> pd.DataFrame:
    """Run one maneuver in closed loop and return the true trajectory.

    Parameters
    ----------
    maneuver : str or Maneuver
        A name of :data:`MANEUVERS` (not ``profile``), or a :class:`Maneuver` from
        :func:`make_maneuver` / :func:`load_speed_profile`.
    duration : float
        Length of the run, s.
    params : Params
        Nominal parameters.  With the effects applied (:func:`true_params`) they are
        the simulated physics and the rider's model of his own body: a rider knows
        his weight, whatever the analyst assumes.
    motor : MotorPD, optional
        The EUC's controller (default gains when omitted).
    rider : Rider, optional
        The rider (``controllers.design.design_rider(true_params(params, effects), motor)``
        when omitted: 0.15 s delay, no motor noise).
    seed : int
        Seed of the rider's motor noise (no other randomness here).
    engine : {"mujoco", "analytic"}
    variant : {"ideal", "contact"}
        MuJoCo ground model (the analytic engine is pure rolling).
    effects : mapping, optional
        ``{name: value}`` in the units of CONTRACT's effect catalog.
    dt : float
        Control period and MuJoCo timestep, s.
    fall_bounds : mapping, optional
        ``{"phi": rad, "gamma": rad}`` (default :data:`FALL_BOUNDS`).
    contact : ContactSettings, optional
        MuJoCo contact variant settings.
    rolling_model : {"moment", "contact"}
        How ``rolling_resistance`` acts: an applied moment −C_rr N R sign(ẋ) on the
        wheel (both engines, CONTRACT's definition), or MuJoCo's own rolling friction
        of the tyre contact (coefficient C_rr·R, m; MuJoCo engine, contact variant).
    external_force : callable, optional
        ``F(t)``: a horizontal force, N, along +x at the rider's centre of gravity G,
        held over each control step in both engines.  It is not a catalog effect: use
        it to put disturbances the catalog does not know into a run (for example
        :class:`PeriodicPush`, the out-of-catalog case of the blind study).
    lateral_motion : LateralMotion, optional
        With ``lateral_dynamics``: the tilt and yaw to use (arrays on the run's grid,
        ``round(duration / dt) + 1`` samples), for example a recording's, instead of
        the built-in slalom.  The effect's value is then an effective peak tilt: the
        coupling is scaled by (value / max|ϑ|)², so value = max|ϑ| is the physics.

    Returns
    -------
    pandas.DataFrame
        Columns as in the module docstring, ``round(duration / dt) + 1`` rows;
        ``df.attrs`` holds the run's description (maneuver, params, effects, engine,
        controllers, seed).

    Raises
    ------
    FallError
        (a ``ValueError``) when |φ| or |γ| passes its bound or the state is not finite;
        the message gives the time of the fall.
    SimulationError
        for an unknown engine, maneuver, effect or a bad duration.
    """
    if engine not in ENGINES:
        raise SimulationError(f"unknown engine {engine!r}; valid engines: {', '.join(ENGINES)}")
    if not (isinstance(duration, (int, float)) and math.isfinite(duration) and duration > 0):
        raise SimulationError(f"duration must be a positive number of seconds, got {duration!r}")
    if not (math.isfinite(dt) and 0 < dt <= 0.01):
        raise SimulationError(f"dt must be in (0, 0.01] s, got {dt!r}")
    man = _as_maneuver(maneuver)
    eff = _check_effects(effects)
    if engine == "analytic" and variant != "ideal":
        raise SimulationError(f"the analytic engine is pure rolling: variant must be 'ideal', got {variant!r}")
    if rolling_model not in ("moment", "contact"):
        raise SimulationError(f"rolling_model must be 'moment' or 'contact', got {rolling_model!r}")
    if rolling_model == "contact" and (engine != "mujoco" or variant != "contact"):
        raise SimulationError("rolling_model 'contact' needs engine 'mujoco' and variant 'contact', "
                              f"got engine {engine!r}, variant {variant!r}")
    bounds = dict(FALL_BOUNDS)
    bounds.update(fall_bounds or {})
    motor = motor or MotorPD()
    p_true = true_params(params, eff)
    if rider is None:
        rider = default_rider(p_true, motor)

    N = int(round(duration / dt))
    t = np.arange(N + 1) * dt
    v_ref, a_ref = man.reference(t)
    run = RiderRun(rider, p_true, motor, v_ref, a_ref, dt, seed)
    n = run.n
    v0, g0, f0, u0 = run.initial_state()
    y0 = (0.0, g0, f0, v0, 0.0, 0.0)

    h_t = (fx.cog_height(p_true.h, eff["cog_height_drift"], t) if "cog_height_drift" in eff else None)
    lat, lat_scale = None, 1.0
    if "lateral_dynamics" in eff:
        lat = lateral_profile(eff["lateral_dynamics"], t, v_ref) if lateral_motion is None else lateral_motion
        if lateral_motion is not None:
            if np.shape(lat.theta) != t.shape:
                raise SimulationError(f"lateral_motion: expected arrays of {t.size} samples (the run's grid), "
                                      f"got {np.shape(lat.theta)}")
            peak = float(np.max(np.abs(lat.theta)))
            lat_scale = (eff["lateral_dynamics"] / peak) ** 2 if peak > 0 else 0.0
    C_rr = eff.get("rolling_resistance", 0.0)
    if rolling_model == "contact":
        import dataclasses

        from euc_sim.mujoco_model import ContactSettings
        contact = dataclasses.replace(contact or ContactSettings(), rolling_friction=C_rr * p_true.R)
        C_rr = 0.0                              # the contact itself resists the rolling
    k_drag = eff.get("aerodynamic_drag", 0.0)
    N_load = fx.normal_load(p_true) if C_rr else 0.0
    if external_force is not None and not callable(external_force):
        raise SimulationError(f"external_force must be a callable F(t) in N, got {external_force!r}")
    push = external_force or (lambda _t: 0.0)
    per_step = bool(C_rr or k_drag or h_t is not None or lat is not None or external_force is not None)

    if engine == "mujoco":
        stepper = _MujocoStepper(p_true, variant, dt, eff, contact)
    else:
        stepper = _AnalyticStepper(p_true, dt, eff)
    if h_t is not None:
        stepper.set_effects(0.0, 0.0, float(h_t[0]), None)
    stepper.reset(y0)

    Y = [y0] * (n + 1)                         # padded state history: the delay buffer
    Md_hist, Mh_hist = [], []
    phi_max, gam_max = bounds["phi"], bounds["gamma"]
    torque, command, step = motor.torque, run.command, stepper.step
    R, sign_v = p_true.R, fx.SIGN_SPEED
    h_list = None if h_t is None else h_t.tolist()
    if lat is not None:     # per-step Python floats: the loop's arithmetic stays off numpy
        lat_s, lat_c = np.sin(lat.theta).tolist(), np.cos(lat.theta).tolist()
        lat_th_d, lat_ps_d, lat_ps_dd = lat.theta_d.tolist(), lat.psi_d.tolist(), lat.psi_dd.tolist()
    y = y0
    for k in range(N + 1):
        x_, g_, f_, xd_, gd_, fd_ = y
        if not (abs(f_) <= phi_max and abs(g_) <= gam_max):
            _raise_fall(k * dt, y, phi_max, gam_max)
        M_d = torque(g_, gd_, xd_)
        M_h = command(k, Y)[1]
        Md_hist.append(M_d)
        Mh_hist.append(M_h)
        if k == N:
            break
        if per_step:
            Q_lat = None
            if lat is not None:  # effects.lateral_forces, held over the step
                Q_lat = [lat_scale * v for v in fx.lateral_force_rows(
                    p_true, math.sin(g_), math.cos(g_), math.sin(f_), math.cos(f_), xd_, gd_, fd_,
                    lat_s[k], lat_c[k], lat_th_d[k], lat_ps_d[k], lat_ps_dd[k])]
            stepper.set_effects(-k_drag * xd_ * abs(xd_) + float(push(k * dt)),
                                -C_rr * N_load * R * math.tanh(xd_ / sign_v),
                                None if h_list is None else h_list[k], Q_lat)
        y = step(M_d, M_h)
        Y.append(y)
    states = np.array(Y[n:], dtype=float)
    U = np.column_stack([Md_hist, Mh_hist])
    if not np.all(np.isfinite(states)):  # pragma: no cover - caught by the loop
        raise FallError(float(t[-1]), "state", float("nan"), None)
    df = pd.DataFrame({
        "t": t, "x": states[:, 0], "gamma": states[:, 1], "phi": states[:, 2],
        "x_dot": states[:, 3], "gamma_dot": states[:, 4], "phi_dot": states[:, 5],
        "M_d": U[:, 0], "M_h": U[:, 1], "v_ref": v_ref,
    })
    if h_t is not None:
        df["h"] = h_t
    if lat is not None:
        df["psi"] = lat.psi
        df["theta"] = lat.theta
    df.attrs.update({
        "maneuver": man.as_dict(), "duration": float(duration), "dt": dt, "engine": engine,
        "variant": variant, "seed": int(seed), "params": params.as_dict(),
        "true_params": p_true.as_dict(), "effects": eff, "motor": motor.as_dict(),
        "rider": rider.as_dict(), "rolling_model": rolling_model,
    })
    return df


def _raise_fall(t: float, y, phi_max: float, gam_max: float) -> None:
    x_, g_, f_ = y[0], y[1], y[2]
    if not all(math.isfinite(v) for v in y):
        raise FallError(t, "state", [float(v) for v in y][int(np.argmin(np.isfinite(y)))], None)
    if abs(f_) > phi_max:
        raise FallError(t, "phi", float(f_), phi_max)
    raise FallError(t, "gamma", float(g_), gam_max)

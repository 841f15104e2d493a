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
look-back buffer over the state history.  Engines: ``mujoco``
(:class:`euc_sim.model.mujoco_model.EucMujoco`, RK4 at dt) and ``analytic`` (eqs. 5-8
plus the effects' generalised forces, DOP853 over each step with the same held
torques).  The catalog's effects act as physics in both, velocity-dependent forces
held over each step from its start; see docs/simulation.md.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from functools import lru_cache
from itertools import chain
from typing import Callable, Mapping

import numpy as np
import pandas as pd

from euc_sim.controllers.motor import MotorPD
from euc_sim.controllers.rider import Rider, RiderRun
from euc_sim.simulation import drift
from euc_sim.simulation import effects as fx
from euc_sim.model.parameters import Params, TABLE3
from euc_sim.simulation.errors import FallError, SimulationError, check_stable
from euc_sim.simulation.maneuvers import LateralMotion, as_maneuver, lateral_profile
from euc_sim.simulation.native import native_loop
from euc_sim.simulation.steppers import _AnalyticStepper, _MujocoStepper  # noqa: F401  (re-exported)


ENGINES = ("mujoco", "analytic")
#: Fall bounds, rad: |φ| (rider) and |γ| (EUC body) beyond these end the run.
FALL_BOUNDS = {"phi": 0.7, "gamma": 0.5}
#: Control period and MuJoCo timestep of :func:`simulate` by default, s.
DEFAULT_DT = 1e-3


# --- effects -------------------------------------------------------------------------
def _check_effects(effects: Mapping[str, float] | None) -> dict[str, float]:
    out = {}
    for name, value in dict(effects or {}).items():
        try:
            out[name] = fx.checked_value(name, value)
        except ValueError as exc:
            raise SimulationError(str(exc)) from None
    return out


def true_params(params: Params, effects: Mapping[str, float] | None) -> Params:
    """The parameters of the simulated physics: ``params`` with parameter effects applied."""
    p = params
    for name, value in _check_effects(effects).items():
        p = fx.apply_to_params(p, name, value)
    return p


def default_rider(params: Params = TABLE3, motor: MotorPD | None = None,
                  noise_std: float = 0.0, delay: float = 0.15) -> Rider:
    """The LQR rider of :func:`euc_sim.controllers.design.design_rider`, cached per (params,
    motor), with motor noise ``noise_std``, N·m, and reaction ``delay``, s.
    """
    return _designed_rider(params, motor or MotorPD()).replace(noise_std=noise_std, delay=delay)


@lru_cache(maxsize=None)
def _designed_rider(params: Params, motor: MotorPD) -> Rider:
    from euc_sim.controllers.design import design_rider  # deferred: loads scipy.linalg (0.3 s)

    return design_rider(params, motor)


# --- the simulation ----------------------------------------------------------------
def simulate(maneuver="constant_speed", duration: float = 15.0, *,
             progress: Callable[[float], None] | None = None, native: bool = True, **request) -> pd.DataFrame:
    """Run one maneuver in closed loop and return the true trajectory.

    Parameters
    ----------
    maneuver, duration, **request
        The run, as :func:`prepare`.
    progress : callable, optional
        ``progress(t)`` with the simulated time, s, every rider block.
    native : bool
        Run the MuJoCo loop as a numba control callback (:mod:`euc_sim.simulation.native`),
        every input included; False, or where numba cannot compile, the Python loop.  The
        two agree to rounding.

    Returns
    -------
    pandas.DataFrame
        The module docstring's columns, ``round(duration / dt) + 1`` rows; ``df.attrs``
        describes the run.

    Raises
    ------
    FallError
        (a ``ValueError``) when |φ| or |γ| passes its bound or the state is not finite; its
        ``trajectory`` holds the run up to the fall.
    SimulationError
        For an unknown engine, maneuver, effect or a bad duration.
    """
    ride = prepare(maneuver, duration, **request)
    stepper, run, ext, N, y0, bounds, motor = ride.stepper, ride.run, ride.ext, ride.N, ride.y0, ride.bounds, ride.motor
    engine, dt = ride.attrs["engine"], ride.attrs["dt"]
    try:
        result = None
        if native and engine == "mujoco":
            forces = (ext.k_drag, ext.C_rr, ext.N_load, ride.p_true.R, request.get("external_force")) \
                if ext.per_step else None
            result = native_loop(stepper, motor, run, dt, N, y0, bounds, _raise_fall, progress, forces,
                                 _moving(ext, ride.p_true, dt))
        if result is None:
            result = _closed_loop(stepper, motor, run, ext, ride.p_true, dt, N, y0, bounds, progress)
        if engine == "mujoco":
            check_stable(stepper.d, N * dt)
    except FallError as exc:             # the run up to the fall, for a caller that keeps it
        ride.attach_partial(exc)
        raise
    return ride.frame(*result)


@dataclass(frozen=True)
class PreparedRun:
    """One run of :func:`simulate`, set up and not yet stepped.

    ``stepper`` is the engine with the initial state set, ``run`` the rider's law, ``ext``
    the effects' inputs on the grid ``t`` (N + 1 samples, s), ``y0`` the initial state
    (x, γ, φ, ẋ, γ̇, φ̇), ``bounds`` the fall bounds, rad.
    """

    stepper: object
    run: RiderRun
    ext: "_ExternalInputs"
    motor: MotorPD
    rider: Rider
    p_true: Params
    N: int
    t: np.ndarray
    v_ref: np.ndarray
    y0: tuple
    bounds: dict
    attrs: dict

    def frame(self, states: np.ndarray, U: np.ndarray) -> pd.DataFrame:
        """The run's DataFrame from states (N+1, 6) and torques (N+1, 2)."""
        df = _trajectory(self.t, states, U, self.v_ref, self.ext)
        df.attrs.update(self.attrs)
        return df

    def attach_partial(self, exc: FallError) -> None:
        """Give a fall its ``trajectory`` from its ``partial`` (states, torques)."""
        if exc.partial is None:
            return
        st, u = exc.partial
        exc.trajectory = _trajectory(self.t[:len(st)], st, u, self.v_ref[:len(st)])


def prepare(maneuver="constant_speed", duration: float = 15.0, *, params: Params = TABLE3,
            motor: MotorPD | None = None, rider: Rider | None = None, seed: int = 0,
            engine: str = "mujoco", variant: str = "ideal",
            effects: Mapping[str, float] | None = None, dt: float = DEFAULT_DT,
            fall_bounds: Mapping[str, float] | None = None, contact=None,
            rolling_model: str = "moment", external_force=None,
            lateral_motion: LateralMotion | None = None, drift_shape=None) -> PreparedRun:
    """Check a :func:`simulate` request and set the run up; ``SimulationError`` as :func:`simulate`.

    Parameters
    ----------
    maneuver : str or Maneuver
        A name of :data:`MANEUVERS` (not ``profile``), or a :class:`Maneuver`.
    duration : float
        Length of the run, s.
    params : Params
        Nominal parameters; with the effects applied (:func:`true_params`) they are the
        simulated physics and the rider's model of his own body.
    motor : MotorPD, optional
        The EUC's controller (default gains when omitted).
    rider : Rider, optional
        Default: :func:`default_rider` of the true parameters (0.15 s delay, no noise).
    seed : int
        Seed of the rider's motor noise (the only randomness).
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
        ``rolling_resistance`` as the applied moment −C_rr N R sign(ẋ) (CONTRACT), or as
        MuJoCo's rolling friction of the tyre contact (coefficient C_rr·R, m; contact variant).
    external_force : callable, optional
        ``F(t)``, N, along +x at the rider's G, held over each step; for disturbances outside
        the catalog (e.g. :class:`euc_sim.simulation.effects.PeriodicPush`).
    lateral_motion : LateralMotion, optional
        With ``lateral_dynamics``: tilt and yaw on the run's grid instead of the built-in
        slalom; the coupling is scaled by (value / max|ϑ|)².
    drift_shape : euc_sim.simulation.drift.DriftShape, optional
        With ``cog_height_drift``: the shape of h(t) (default the catalog's 12 s sine).
    """
    man, eff = _check_request(maneuver, duration, engine, variant, effects, dt, rolling_model, external_force)
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
    v0, g0, f0, u0 = run.initial_state()
    y0 = (0.0, g0, f0, v0, 0.0, 0.0)
    ext = _external_inputs(p_true, eff, t, v_ref, rolling_model, contact, external_force,
                           lateral_motion, drift_shape)
    if engine == "mujoco":
        stepper = _MujocoStepper(p_true, variant, dt, eff, ext.contact)
    else:
        stepper = _AnalyticStepper(p_true, dt, eff)
    if ext.h_t is not None:
        stepper.set_effects(0.0, 0.0, float(ext.h_t[0]), None)
    stepper.reset(y0)
    attrs = {
        "maneuver": man.as_dict(), "duration": float(duration), "dt": dt, "engine": engine,
        "variant": variant, "seed": int(seed), "params": params.as_dict(),
        "true_params": p_true.as_dict(), "effects": eff, "motor": motor.as_dict(),
        "rider": rider.as_dict(), "rolling_model": rolling_model,
    }
    return PreparedRun(stepper, run, ext, motor, rider, p_true, N, t, v_ref, y0, bounds, attrs)


def _check_request(maneuver, duration, engine: str, variant: str, effects, dt: float, rolling_model: str,
                   external_force, **_setup) -> tuple:
    """The checks of :func:`prepare` that set nothing up (its arguments; the others, ``_setup``, are
    not read): ``SimulationError`` naming what :func:`simulate` cannot run, else the maneuver and
    the effects, checked.
    """
    if engine not in ENGINES:
        raise SimulationError(f"unknown engine {engine!r}; valid engines: {', '.join(ENGINES)}")
    if not (isinstance(duration, (int, float)) and math.isfinite(duration) and duration > 0):
        raise SimulationError(f"duration must be a positive number of seconds, got {duration!r}")
    if not (math.isfinite(dt) and 0 < dt <= 0.01):
        raise SimulationError(f"dt must be in (0, 0.01] s, got {dt!r}")
    if engine == "analytic" and variant != "ideal":
        raise SimulationError(f"the analytic engine is pure rolling: variant must be 'ideal', got {variant!r}")
    if rolling_model not in ("moment", "contact"):
        raise SimulationError(f"rolling_model must be 'moment' or 'contact', got {rolling_model!r}")
    if rolling_model == "contact" and (engine != "mujoco" or variant != "contact"):
        raise SimulationError("rolling_model 'contact' needs engine 'mujoco' and variant 'contact', "
                              f"got engine {engine!r}, variant {variant!r}")
    if external_force is not None and not callable(external_force):
        raise SimulationError(f"external_force must be a callable F(t) in N, got {external_force!r}")
    return as_maneuver(maneuver), _check_effects(effects)


@dataclass(frozen=True)
class _ExternalInputs:
    """What acts on the plant besides the motor and ankle torques, on the run's grid.

    ``C_rr`` (1), ``N_load`` (N): rolling resistance; ``k_drag`` (kg/m); ``push``: F(t) at G,
    N; ``h_t``: h, m; ``lat``, ``lat_scale``: ``lateral_dynamics``; ``contact``: MuJoCo
    contact settings; ``per_step``: whether any must be evaluated every step.
    """

    C_rr: float
    N_load: float
    k_drag: float
    push: object
    h_t: np.ndarray | None
    lat: LateralMotion | None
    lat_scale: float
    contact: object
    per_step: bool


def _external_inputs(p_true: Params, eff: dict, t: np.ndarray, v_ref: np.ndarray, rolling_model: str,
                     contact, external_force, lateral_motion, drift_shape) -> _ExternalInputs:
    """The effects' inputs of one run (see :class:`_ExternalInputs`), checked."""
    h_t = (drift.cog_height(p_true.h, eff["cog_height_drift"], t, drift_shape)
           if "cog_height_drift" in eff else None)
    if h_t is not None and float(np.min(h_t)) < 0.2:
        raise SimulationError(f"cog_height_drift: h(t) falls to {float(np.min(h_t)):.2f} m; a rider's centre "
                              "of gravity stays above 0.2 m (lower the drift or raise h)")
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
        from euc_sim.model.mujoco_model import ContactSettings  # deferred: loads mujoco (0.1 s)
        contact = dataclasses.replace(contact or ContactSettings(), rolling_friction=C_rr * p_true.R)
        C_rr = 0.0                              # the contact itself resists the rolling
    k_drag = eff.get("aerodynamic_drag", 0.0)
    per_step = bool(C_rr or k_drag or h_t is not None or lat is not None or external_force is not None)
    return _ExternalInputs(C_rr=C_rr, N_load=fx.normal_load(p_true) if C_rr else 0.0, k_drag=k_drag,
                           push=external_force or (lambda _t: 0.0), h_t=h_t, lat=lat, lat_scale=lat_scale,
                           contact=contact, per_step=per_step)


def _closed_loop(stepper, motor: MotorPD, run: RiderRun, ext: _ExternalInputs, p_true: Params,
                 dt: float, N: int, y0: tuple, bounds: Mapping[str, float],
                 progress: Callable[[float], None] | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Step the plant N times under the held torques; states (N+1, 6) and torques (N+1, 2).

    The rider's ankle torques come a block of n + 1 = delay/dt + 1 steps at a time
    (:meth:`RiderRun.commands`); the motor PD runs every step.  Python floats per step.
    """
    n = run.n
    Y = [y0] * (n + 1)                         # padded state history: the delay buffer
    Md_hist, Mh_hist = [], []
    phi_max, gam_max = bounds["phi"], bounds["gamma"]
    torque, step, keep_Md, keep_y = motor.torque, stepper.step, Md_hist.append, Y.append
    effects = _EffectsRow(ext, p_true, dt) if ext.per_step else None
    y = y0
    for k0 in range(0, N + 1, n + 1):
        block = min(n + 1, N + 1 - k0)
        if progress is not None:
            progress(k0 * dt)
        M_h_block = run.commands(k0, _rows(Y[k0:k0 + block]))[1].tolist()
        Mh_hist += M_h_block
        for k, M_h in enumerate(M_h_block, start=k0):
            x_, g_, f_, xd_, gd_, fd_ = y
            if not (abs(f_) <= phi_max and abs(g_) <= gam_max):
                try:
                    _raise_fall(k * dt, y, phi_max, gam_max)
                except FallError as exc:     # the states and torques of steps 0 … k − 1
                    exc.partial = (_rows(Y[n:n + k]), np.column_stack([Md_hist[:k], Mh_hist[:k]])
                                   if k else np.empty((0, 2)))
                    raise
            M_d = torque(g_, gd_, xd_)
            keep_Md(M_d)
            if k == N:
                break
            if effects is not None:
                stepper.set_effects(*effects(k, y))
            y = step(M_d, M_h)
            keep_y(y)
    states = _rows(Y[n:])
    if not np.all(np.isfinite(states)):  # pragma: no cover - caught by the loop
        raise FallError(float(N * dt), "state", float("nan"), None)
    return states, np.column_stack([Md_hist, Mh_hist])


def _rows(states: list) -> np.ndarray:
    """A list of 6-tuples as an (n, 6) array."""
    return np.fromiter(chain.from_iterable(states), float, 6 * len(states)).reshape(len(states), 6)


class _EffectsRow:
    """The external inputs held over step k, from the state at its start (for ``set_effects``),
    from the tables of :func:`_moving`.
    """

    def __init__(self, ext: _ExternalInputs, p: Params, dt: float):
        self.ext, self.p, self.dt = ext, p, dt
        self.table3, lat, _, h = _moving(ext, p, dt) or (None, None, None, None)
        self.lat = None if lat is None else lat.tolist()
        self.h = None if h is None else h.tolist()

    def __call__(self, k: int, y) -> tuple:
        """(F_x at G [N], wheel moment [N·m], h [m] or None, Q [paper coordinates] or None)."""
        ext, p = self.ext, self.p
        x_, g_, f_, xd_, gd_, fd_ = y
        Q_lat = None
        if self.lat is not None:  # effects.lateral_forces, held over the step
            Q_lat = [ext.lat_scale * v for v in fx.lateral_force_row(
                *self.table3, math.sin(g_), math.cos(g_), math.sin(f_), math.cos(f_), xd_, gd_, fd_, *self.lat[k])]
        h = None
        if self.h is not None:   # G moving along the rider's axis: drift.drift_forces
            h, h_d, h_dd = self.h[k]
            Q_h = drift.drift_force_row(p.m, p.l0, h, h_d, h_dd, g_, f_, fd_)
            Q_lat = list(Q_h) if Q_lat is None else [a + b for a, b in zip(Q_lat, Q_h)]
        return (*fx.held_forces(xd_, ext.k_drag, ext.C_rr, ext.N_load, p.R, float(ext.push(k * self.dt))),
                h, Q_lat)


def _moving(ext: _ExternalInputs, p: Params, dt: float):
    """The ``lateral_dynamics`` and ``cog_height_drift`` tables of the native loop's ``moving``; None without them."""
    if ext.lat is None and ext.h_t is None:
        return None
    lat = ext.lat
    lat_rows = None if lat is None else np.column_stack(
        [np.sin(lat.theta), np.cos(lat.theta), lat.theta_d, lat.psi_d, lat.psi_dd])
    h_rows = None if ext.h_t is None else np.column_stack([ext.h_t, *drift.drift_rates(ext.h_t, dt)])
    return ((p.mw, p.m0, p.m, p.h0, p.l0, p.h, p.R, p.g, p.Jw, p.J0, p.J), lat_rows, ext.lat_scale, h_rows)


def _trajectory(t: np.ndarray, states: np.ndarray, U: np.ndarray, v_ref: np.ndarray,
                ext: _ExternalInputs | None = None) -> pd.DataFrame:
    """The run as the module docstring's columns (``h``, ``psi``, ``theta`` from ``ext``)."""
    df = pd.DataFrame({
        "t": t, "x": states[:, 0], "gamma": states[:, 1], "phi": states[:, 2],
        "x_dot": states[:, 3], "gamma_dot": states[:, 4], "phi_dot": states[:, 5],
        "M_d": U[:, 0], "M_h": U[:, 1], "v_ref": v_ref,
    })
    if ext is None:
        return df
    if ext.h_t is not None:
        df["h"] = ext.h_t
    if ext.lat is not None:
        df["psi"] = ext.lat.psi
        df["theta"] = ext.lat.theta
    return df


def _raise_fall(t: float, y, phi_max: float, gam_max: float) -> None:
    g_, f_ = y[1], y[2]
    if not all(math.isfinite(v) for v in y):
        raise FallError(t, "state", [float(v) for v in y][int(np.argmin(np.isfinite(y)))], None)
    if abs(f_) > phi_max:
        raise FallError(t, "phi", float(f_), phi_max)
    raise FallError(t, "gamma", float(g_), gam_max)

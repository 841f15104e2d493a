"""Closed loop of the spatial model: a rider who balances, steers and follows a path.

:func:`simulate_3d` rides one path of :data:`PATHS` (curvature profiles κ(s) from the
origin heading +X, cosine ramps of 2.5 m at their joints) in
:class:`euc_sim.model.spatial.EucSpatial` at 1 kHz: the planar loop (motor PD, the
delayed rider of :mod:`euc_sim.controllers.rider`) on the paper's state read from the 3-D
model, the lateral rider of :mod:`euc_sim.controllers.lateral` on the path errors.
See docs/spatial.md (Paths).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache

import numpy as np
import pandas as pd

from euc_sim import io
from euc_sim.controllers.lateral import LateralRider, design_lateral
from euc_sim.controllers.motor import MotorPD
from euc_sim.controllers.rider import RiderRun
from euc_sim.errors import InputError
from euc_sim.model.parameters import Params, TABLE3
from euc_sim.simulation import effects
from euc_sim.simulation.engine import FALL_BOUNDS, default_rider
from euc_sim.simulation.errors import FallError, SimulationError, check_stable
from euc_sim.simulation.maneuvers import make_maneuver
from euc_sim.simulation.mocap import E_HEIGHT, NOISE_LEVELS, sample_times
from euc_sim.simulation.native_spatial import ROW_COLUMNS, native_ride

__all__ = ["PATHS", "PATH_SPEEDS", "TILT_BOUND", "Path3D", "make_path", "simulate_3d",
           "spatial_recording", "TURNING_PATHS", "RIDEABLE_SPEEDS", "RIDEABLE_RADII", "RIDEABLE_LATERAL_ACCEL",
           "draw_spatial_ride"]

PATHS = ("straight", "circle", "u_turn", "slalom", "figure_eight")
#: Planned speed of each path, m/s (walking-to-jogging pace, as the paper's indoor runs).
PATH_SPEEDS = {"straight": 3.0, "circle": 2.0, "u_turn": 2.0, "slalom": 2.0, "figure_eight": 2.0}
#: |ϑ| beyond this ends the run as a fall, rad.
TILT_BOUND = 0.6
#: Radius of the circle and of the figure-eight's loops, m.
RADIUS = 4.0
#: Peak curvature (1/m) and wavelength (m) of the slalom.
SLALOM_KAPPA, SLALOM_WAVELENGTH = 0.15, 10.0
_RAMP = 2.5     # m, length of a curvature change
#: Time constant of the delayed lateral rider's estimate of a turn's steady effort, s.
TURN_EFFORT_TIME = 1.0
_DS = 0.01      # m, path sampling


@dataclass(frozen=True)
class Path3D:
    """A planar path sampled every 1 cm: arc length s, X, Y (m), heading (rad), curvature κ (1/m, left positive)."""

    name: str
    s: np.ndarray
    X: np.ndarray
    Y: np.ndarray
    heading: np.ndarray
    kappa: np.ndarray


#: The turning paths, in the order :func:`draw_spatial_ride` cycles through them.
TURNING_PATHS = ("circle", "slalom", "figure_eight", "u_turn")
#: Speeds drawn for the turning paths, m/s: the lateral rider follows all four at 2 m/s
#: (docs/spatial.md) and falls on circles of radius 3 m at 2.5 m/s.
RIDEABLE_SPEEDS = (1.5, 2.2)
#: Turn radii drawn, m, and the largest lateral acceleration v²/R drawn per path, m/s²
#: (below the falls of docs/spatial.md; the figure-eight's reversals are harder).
RIDEABLE_RADII = (3.5, 5.5)
RIDEABLE_LATERAL_ACCEL = {"circle": 1.25, "u_turn": 1.25, "figure_eight": 0.9}


def draw_spatial_ride(j: int, rng: np.random.Generator) -> dict:
    """The j-th ride of a 3-D study from the seeded ``rng``: ``path`` (:data:`TURNING_PATHS` in
    turn), ``speed``, m/s, and ``radius``, m (None for the slalom), drawn within the rideable ranges.
    """
    path = TURNING_PATHS[j % len(TURNING_PATHS)]
    speed = round(float(rng.uniform(*RIDEABLE_SPEEDS)), 3)
    lo = max(RIDEABLE_RADII[0], speed**2 / RIDEABLE_LATERAL_ACCEL.get(path, 1.0))
    radius = round(float(rng.uniform(lo, RIDEABLE_RADII[1])), 3)
    return {"path": path, "speed": speed, "radius": None if path == "slalom" else radius}


def _segments(name: str, length: float, radius: float = RADIUS) -> list[tuple[float, float]]:
    """(segment length m, curvature 1/m) pieces of a path, repeated to cover ``length``."""
    if name == "straight":
        return [(length, 0.0)]
    if name == "circle":
        return [(2.0, 0.0), (length, 1.0 / radius)]
    if name == "u_turn":
        return [(6.0, 0.0), (math.pi * radius, 1.0 / radius), (length, 0.0)]
    if name == "figure_eight":
        lap = 2.0 * math.pi * radius
        pieces = [(2.0, 0.0)]
        while sum(p[0] for p in pieces) < length:
            pieces += [(lap, 1.0 / radius), (lap, -1.0 / radius)]
        return pieces
    raise SimulationError(f"unknown path {name!r}; valid paths: {', '.join(PATHS)}")


def make_path(name: str, length: float, radius: float | None = None) -> Path3D:
    """The path ``name`` sampled over ``length`` m of arc length, turns of ``radius`` m (default :data:`RADIUS`)."""
    if name not in PATHS:
        raise SimulationError(f"unknown path {name!r}; valid paths: {', '.join(PATHS)}")
    radius = RADIUS if radius is None else radius
    if not (isinstance(radius, (int, float)) and math.isfinite(radius) and radius >= 1.0):
        raise SimulationError(f"turn radius must be at least 1 m, got {radius!r}")
    s = np.arange(0.0, length + 5.0, _DS)
    if name == "slalom":
        ramp = np.clip((s - 2.0) / _RAMP, 0.0, 1.0)
        kappa = SLALOM_KAPPA * np.sin(2.0 * np.pi * np.maximum(s - 2.0, 0.0) / SLALOM_WAVELENGTH) * ramp
    else:
        kappa = np.zeros_like(s)
        start, prev = 0.0, 0.0
        for seg_len, k in _segments(name, length + 5.0, radius):
            u = np.clip((s - start + 0.5 * _RAMP) / _RAMP, 0.0, 1.0)   # centred on the joint
            kappa = np.where(s >= start - 0.5 * _RAMP, prev + (k - prev) * 0.5 * (1.0 - np.cos(np.pi * u)), kappa)
            start, prev = start + seg_len, k
    heading = np.concatenate([[0.0], np.cumsum(0.5 * (kappa[1:] + kappa[:-1]) * _DS)])
    X = np.concatenate([[0.0], np.cumsum(0.5 * (np.cos(heading[1:]) + np.cos(heading[:-1])) * _DS)])
    Y = np.concatenate([[0.0], np.cumsum(0.5 * (np.sin(heading[1:]) + np.sin(heading[:-1])) * _DS)])
    return Path3D(name, s, X, Y, heading, kappa)


class _Tracker:
    """Nearest path point, searched forward from the last one."""

    def __init__(self, path: Path3D):
        self.X, self.Y = path.X.tolist(), path.Y.tolist()
        self.h, self.k = path.heading.tolist(), path.kappa.tolist()
        self.i = 0
        self.n = len(self.X)

    def errors(self, X: float, Y: float):
        """(e_y m left positive, path heading rad, κ 1/m) for the point (X, Y)."""
        Xs, Ys, i = self.X, self.Y, self.i
        d = (Xs[i] - X) ** 2 + (Ys[i] - Y) ** 2
        while i + 1 < self.n:
            d1 = (Xs[i + 1] - X) ** 2 + (Ys[i + 1] - Y) ** 2
            if d1 > d:
                break
            i, d = i + 1, d1
        self.i = i
        h = self.h[i]
        e_y = -math.sin(h) * (X - Xs[i]) + math.cos(h) * (Y - Ys[i])
        return e_y, h, self.k[i]


def _wrap(a: float) -> float:
    return (a + math.pi) % (2.0 * math.pi) - math.pi


@lru_cache(maxsize=None)
def default_lateral(params: Params, speed: float, dt: float, tyre=None, delay: float = 0.0) -> LateralRider:
    """:func:`euc_sim.controllers.lateral.design_lateral`, cached per (params, speed, dt, tyre, delay)."""
    return design_lateral(params, speed, dt, tyre, delay=delay)


def simulate_3d(path: str = "figure_eight", duration: float = 15.0, *, params: Params = TABLE3,
                speed: float | None = None, motor: MotorPD | None = None, rider=None,
                lateral: LateralRider | None = None, seed: int = 0, dt: float = 1e-3,
                tyre=None, maneuver=None, integrator: str | None = None, lateral_delay: float = 0.0,
                radius: float | None = None, native: bool = True, external_force=None) -> pd.DataFrame:
    """Ride a path in the spatial model, closed loop, and return the true run at 1/dt.

    Parameters
    ----------
    path : str
        One of :data:`PATHS`.
    duration, dt : float
        Length of the run and control period (the timestep), s.
    params, motor, seed, tyre
        As :func:`euc_sim.simulation.engine.simulate`; ``tyre`` a :class:`TyreContact`.
    speed : float, optional
        Planned speed, m/s (:data:`PATH_SPEEDS` by default).
    rider : controllers.rider.Rider, optional
        Longitudinal rider (default: the planar LQR design, 0.15 s delay, no noise).
    lateral : LateralRider, optional
        Lateral rider (default: designed at ``speed`` with ``lateral_delay``, s).
    maneuver : Maneuver, optional
        Planned speed profile (constant ``speed`` by default; the lateral gains stay those at ``speed``).
    integrator : str, optional
        MuJoCo integrator of the run (the lateral design linearises ``implicitfast``).
    radius : float, optional
        Turn radius of ``circle``, ``u_turn`` and ``figure_eight``, m (default :data:`RADIUS`).
    native : bool
        Run the loop as a numba control callback (:mod:`euc_sim.simulation.native_spatial`);
        False, or where numba cannot compile, the Python loop (they agree to rounding).
    external_force : callable, optional
        F(t), N, at the rider's centre of mass along the heading; ridden by the Python loop.

    Returns
    -------
    pandas.DataFrame
        t, x, gamma, phi, x_dot, gamma_dot, phi_dot, M_d, M_h, v_ref, psi, theta, psi_dot,
        theta_dot, M_lean, M_twist, e_y (path offset, m), C_X … G_Z (site positions, m);
        ``attrs`` describe the run.

    Raises
    ------
    FallError
        When |ϑ| > :data:`TILT_BOUND`, |φ| > 0.7 or |γ| > 0.5 rad.
    SimulationError
        For a bad path, duration or speed.
    """
    from euc_sim.model.spatial import EucSpatial  # deferred: loads mujoco (0.1 s)

    if not (isinstance(duration, (int, float)) and math.isfinite(duration) and duration > 0):
        raise SimulationError(f"duration must be a positive number of seconds, got {duration!r}")
    speed = PATH_SPEEDS.get(path, 2.5) if speed is None else float(speed)
    if not (math.isfinite(speed) and 0.5 <= speed <= 8.0):
        raise SimulationError(f"speed must be in [0.5, 8] m/s, got {speed!r}")
    motor = motor or MotorPD()
    rider = rider or default_rider(params, motor)
    lateral = lateral or default_lateral(params, speed, dt, tyre, lateral_delay)
    man = maneuver or make_maneuver("constant_speed", v=speed)
    N = int(round(duration / dt))
    t = np.arange(N + 1) * dt
    v_ref, a_ref = man.reference(t)
    route = make_path(path, float(np.max(np.abs(v_ref))) * duration + 5.0, radius)
    run = RiderRun(rider, params, motor, v_ref, a_ref, dt, seed)
    v0, g0, f0, _ = run.initial_state()

    sim = EucSpatial(params, tyre, timestep=dt, integrator=integrator)
    sim.set_straight(v0, g0, f0)
    y0, rows = (0.0, g0, f0, v0, 0.0, 0.0), None
    if native and external_force is None:
        rows = native_ride(sim, run, motor, lateral, route, v_ref, N, dt, y0, FALL_BOUNDS, TILT_BOUND,
                           TURN_EFFORT_TIME)
    if rows is None:
        rows = _ride(sim, run, motor, lateral, _Tracker(route), v_ref.tolist(), N, dt, y0, external_force)
    check_stable(sim.data, N * dt)
    df = pd.DataFrame(rows, columns=ROW_COLUMNS)
    df["psi"] = np.unwrap(df["psi"].to_numpy())
    df.attrs.update({"path": path, "speed": speed, "duration": float(duration), "dt": dt,
                     "seed": int(seed), "params": params.as_dict(), "motor": motor.as_dict(),
                     "rider": rider.as_dict(), "lateral": lateral.as_dict(),
                     "model": "mjcf/euc_3d.xml", "tyre": vars(sim.tyre).copy()})
    if external_force is not None:
        df.attrs["external_force"] = external_force.as_dict() if hasattr(external_force, "as_dict") else repr(external_force)
    return df


def _pose(qp, rq: int, ip: int, il: int, p: Params):
    """Body rotation (row-major 9-list) and the sites C, E, G from qpos, ground frame (``data.xmat``
    lags qpos by a step after ``mj_step``).
    """
    w, x, y, z = qp[rq + 3:rq + 7]
    R = [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y),
         2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x),
         2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)]
    C = qp[rq:rq + 3]
    sp_, cp_, sl, cl = math.sin(qp[ip]), math.cos(qp[ip]), math.sin(qp[il]), math.cos(qp[il])
    # A − C = (0, 0, −l0); G − A = Ry(pitch) Rx(lean) (0, 0, h) in the body frame (twist: about z)
    gb = (p.h * cl * sp_, -p.h * sl, p.h * cl * cp_ - p.l0)
    G = [C[i] + R[3 * i] * gb[0] + R[3 * i + 1] * gb[1] + R[3 * i + 2] * gb[2] for i in range(3)]
    E = [C[i] + R[3 * i + 2] * E_HEIGHT for i in range(3)]
    return R, C, E, G


def _ride(sim, run: RiderRun, motor: MotorPD, lateral: LateralRider, track: "_Tracker",
          v_ref: list, N: int, dt: float, y0: tuple, push=None) -> list:
    """The 1 kHz loop of :func:`simulate_3d`: one row per step (its column order)."""
    import mujoco

    m, d, params = sim.model, sim.data, sim.params
    rq, rv = sim.qadr["root"], sim.vadr["root"]
    ip, il, it = sim.qadr["rider_pitch"], sim.qadr["rider_lean"], sim.qadr["rider_twist"]
    vp, vl, vt = sim.vadr["rider_pitch"], sim.vadr["rider_lean"], sim.vadr["rider_twist"]
    a_m, a_h, a_l, a_t = (sim.act[n] for n in ("motor", "ankle", "lean", "twist"))
    xfrc, rb = d.xfrc_applied, sim.body["rider"]
    nd = lateral.n_delay
    if nd:        # the rider senses z nd steps late and predicts the present (LateralRider)
        KP = np.asarray(lateral.K_pred, dtype=float)
        KH = np.asarray(lateral.K_hist, dtype=float)
        u_hist = np.zeros(2 * (N + 1 + nd))      # command changes, oldest first, zero before t = 0
        z_hist: list = []
        u_bar = [0.0, 0.0]                       # the turn's steady effort: commands low-passed
        a_bar = dt / TURN_EFFORT_TIME
    K0, K1 = np.asarray(lateral.K, dtype=float).tolist()
    lim, g = lateral.torque_limit, params.g
    phi_max, gam_max = FALL_BOUNDS["phi"], FALL_BOUNDS["gamma"]
    Y = [y0] * run.n
    rows = []
    x_s, z_int = 0.0, 0.0
    qpos, qvel, ctrl = d.qpos, d.qvel, d.ctrl
    for k in range(N + 1):
        qv, qp = qvel.tolist(), qpos.tolist()
        R, C, E, G = _pose(qp, rq, ip, il, params)
        psi = math.atan2(-R[1], R[4])                      # euler_yaw_tilt_pitch, inlined
        theta = math.asin(max(-1.0, min(1.0, R[7])))
        gamma = math.atan2(-R[6], R[8])
        wl = qv[rv + 3:rv + 6]                             # body-frame angular velocity
        wx = R[0] * wl[0] + R[1] * wl[1] + R[2] * wl[2]
        wy = R[3] * wl[0] + R[4] * wl[1] + R[5] * wl[2]
        wz = R[6] * wl[0] + R[7] * wl[1] + R[8] * wl[2]
        cp, sp, ct, st = math.cos(psi), math.sin(psi), math.cos(theta), math.sin(theta)
        gamma_d = (-sp * wx + cp * wy) / ct                # euler_rates, inlined
        theta_d = cp * wx + sp * wy
        psi_d = wz - gamma_d * st
        vX, vY = qv[rv], qv[rv + 1]
        x_dot = cp * vX + sp * vY
        phi, phi_d = gamma + qp[ip], gamma_d + qv[vp]
        if not (abs(theta) <= TILT_BOUND and abs(phi) <= phi_max and abs(gamma) <= gam_max):
            _fall(k * dt, theta, phi, gamma, phi_max, gam_max)
        Y.append((x_s, gamma, phi, x_dot, gamma_d, phi_d))
        M_d = motor.torque(gamma, gamma_d, x_dot)
        M_h = run.command(k, Y)[1]
        e_y, h_p, kap = track.errors(qp[rq], qp[rq + 1])
        z = (e_y, _wrap(psi - h_p), theta + math.atan(x_dot * x_dot * kap / g), qp[il], qp[it],
             -math.sin(h_p) * vX + math.cos(h_p) * vY, theta_d, psi_d - x_dot * kap, qv[vl], qv[vt], z_int)
        if nd:
            z_hist.append(z)
            u = -(KP @ z_hist[max(k - nd, 0)] + KH @ u_hist[2 * k:2 * (k + nd)])
            u_l, u_t = max(-lim, min(lim, float(u[0]))), max(-lim, min(lim, float(u[1])))
            u_bar[0] += a_bar * (u_l - u_bar[0])
            u_bar[1] += a_bar * (u_t - u_bar[1])
            u_hist[2 * (k + nd)], u_hist[2 * (k + nd) + 1] = u_l - u_bar[0], u_t - u_bar[1]
        else:
            u_l = max(-lim, min(lim, -sum(a * b for a, b in zip(K0, z))))
            u_t = max(-lim, min(lim, -sum(a * b for a, b in zip(K1, z))))
        rows.append((k * dt, x_s, gamma, phi, x_dot, gamma_d, phi_d, M_d, M_h, v_ref[k], psi,
                     theta, psi_d, theta_d, u_l, u_t, e_y, *C, *E, *G))
        if k == N:
            break
        z_int += e_y * dt
        ctrl[a_m], ctrl[a_h], ctrl[a_l], ctrl[a_t] = M_d, M_h, u_l, u_t
        if push is not None:        # F(t) at the rider's centre of mass, along the heading
            f = float(push(k * dt))
            xfrc[rb, 0], xfrc[rb, 1] = f * cp, f * sp
        mujoco.mj_step(m, d)
        x_s += dt * 0.5 * (x_dot + (math.cos(psi) * float(qvel[rv]) + math.sin(psi) * float(qvel[rv + 1])))
    return rows


def _fall(t, theta, phi, gamma, phi_max, gam_max):
    if not all(math.isfinite(v) for v in (theta, phi, gamma)):
        raise FallError(t, "state", float("nan"), None)
    if abs(theta) > TILT_BOUND:
        raise FallError(t, "theta", theta, TILT_BOUND)
    if abs(phi) > phi_max:
        raise FallError(t, "phi", phi, phi_max)
    raise FallError(t, "gamma", gamma, gam_max)


def spatial_recording(run: pd.DataFrame, *, noise: str = "paper", seed: int = 0,
                      rate: float = 120.0, hide_torques: bool = False) -> pd.DataFrame:
    """Sample a :func:`simulate_3d` run like the paper's motion capture.

    t, psi, theta, gamma and C_X … G_Z by cubic spline with the noise of
    :data:`~euc_sim.simulation.mocap.NOISE_LEVELS`, and the held M_d, M_h unless hidden; no
    ``x``, ``phi``: the Section 2 pipeline (eqs. 1-3) computes the state.
    """
    from scipy.interpolate import CubicSpline

    if noise not in NOISE_LEVELS:
        raise InputError(f"unknown noise level {noise!r}; valid: {', '.join(NOISE_LEVELS)}")
    sig_pos, sig_ang = NOISE_LEVELS[noise]
    ts = run["t"].to_numpy()
    t = sample_times(float(ts[-1]), rate)
    rng = np.random.default_rng([int(seed), 3, 120])
    cols = {"t": t}
    for name in ("psi", "theta", "gamma"):
        cols[name] = CubicSpline(ts, run[name].to_numpy())(t) + (rng.normal(0, sig_ang, t.size) if sig_ang else 0)
    for name in ("C_X", "C_Y", "C_Z", "E_X", "E_Y", "E_Z", "G_X", "G_Y", "G_Z"):
        cols[name] = CubicSpline(ts, run[name].to_numpy())(t) + (rng.normal(0, sig_pos, t.size) if sig_pos else 0)
    if not hide_torques:
        zoh = np.minimum(np.searchsorted(ts, t + 1e-9, side="right") - 1, len(ts) - 1)
        cols["M_d"] = run["M_d"].to_numpy()[zoh]
        cols["M_h"] = run["M_h"].to_numpy()[zoh]
    return pd.DataFrame(cols)


def write_spatial(out, path: str, duration: float, *, params: Params = TABLE3, seed: int = 0,
                  noise: str = "paper", rider_noise: float = 0.0, speed: float | None = None,
                  motor: MotorPD | None = None, rider_delay: float = 0.15, hide_torques: bool = False,
                  radius: float | None = None, external_force=None):
    """Simulate ``path`` in the spatial model and write a recording with sidecars.

    ``NAME.csv`` holds :func:`spatial_recording`'s columns, ``NAME.json`` the known
    parameters (not h) and the maneuver, ``NAME.truth.json`` the truth and path error;
    ``external_force`` (see :func:`simulate_3d`) is named in the truth only.  Returns the
    recording's path; ``FallError`` when the rider falls (nothing written).
    """
    motor = motor or MotorPD()
    rider = default_rider(params, motor, noise_std=rider_noise, delay=rider_delay)
    run = simulate_3d(path, duration, params=params, speed=speed, motor=motor, rider=rider, seed=seed,
                      radius=radius, external_force=external_force)
    rec = spatial_recording(run, noise=noise, seed=seed, hide_torques=hide_torques)
    e_y = run["e_y"].to_numpy()
    ts = run["t"].to_numpy()
    meta = {
        "params": {k: v for k, v in params.as_dict().items() if k != "h"},
        "maneuver": path,
        # the plan the rider was given (as the planar sidecars' maneuver_options): what the
        # diagnosis re-simulates to calibrate the lateral term (diagnosis.lateral_calibration)
        "maneuver_options": {"speed": float(run.attrs["speed"]),
                             "radius": None if path in ("straight", "slalom") else float(RADIUS if radius is None else radius)},
        "source": (f"euc-sim simulate --model 3d: mjcf/euc_3d.xml, {path} at {run.attrs['speed']:g} m/s, "
                   f"{duration:g} s at 1 kHz sampled at 120 Hz, noise {noise}, seed {seed}"),
        "duration": duration, "noise": noise,
        "torques": "hidden" if hide_torques else "true M_d, M_h of the simulation",
    }
    truth = {
        "params": params.as_dict(), "model": "3d", "path": path, "speed": run.attrs["speed"],
        "radius": None if path in ("straight", "slalom") else (RADIUS if radius is None else radius),
        "seed": seed, "motor": motor.as_dict(), "rider": rider.as_dict(),
        "lateral": run.attrs["lateral"], "tyre": run.attrs["tyre"], "effects": {},
        "path_error": {"rms_m": float(np.sqrt(np.mean(e_y ** 2))), "max_m": float(np.max(np.abs(e_y)))},
        # lateral_dynamics' peak tilt (CONTRACT): over the couplings' bandwidth, from the true
        # 1 kHz tilt; the raw peak includes the rider's balance wobble
        "peak_tilt_rad": effects.band_peak_tilt(run["theta"].to_numpy(), float(np.mean(np.diff(ts)))),
        "peak_tilt_raw_rad": float(np.max(np.abs(run["theta"].to_numpy()))),
    }
    if external_force is not None:
        truth["out_of_catalog"] = run.attrs["external_force"]
    return io.write_recording(rec, out, meta, truth)

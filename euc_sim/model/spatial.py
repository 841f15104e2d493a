"""The spatial MuJoCo model (``mjcf/euc_3d.xml``): an EUC with a rounded tyre rolling on a
plane through frictional contact, and a rider hinged at the ankle in pitch, lateral lean
and twist.

Parameters go in through :class:`mujoco.MjSpec`; everything is read by name.  The EUC
body's orientation is Rz(ψ) Rx(ϑ) Ry(γ) (yaw, tilt, pitch of Fig. 2); the rider's pitch
is φ = γ + rider_pitch.  See docs/spatial.md.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import mujoco
import numpy as np

from euc_sim.errors import InputError
from euc_sim.model.mujoco_model import (ModelError, _find, check_settings, compile_spec, load_spec, set_bodies,
                                       settle_height)
from euc_sim.model.parameters import Params, TABLE3

__all__ = ["MJCF_3D_PATH", "TyreContact", "build_spatial_spec", "load_spatial_model",
           "euler_yaw_tilt_pitch", "euler_rates", "EucSpatial"]

#: The hand-written spatial model, beside the package.
MJCF_3D_PATH = Path(__file__).resolve().parents[2] / "mjcf" / "euc_3d.xml"
HINGES = ("wheel_spin", "rider_pitch", "rider_lean", "rider_twist")
ACTUATORS = ("motor", "ankle", "lean", "twist")


@dataclass(frozen=True)
class TyreContact:
    """The tyre's shape and its frictional contact with the floor.

    Attributes
    ----------
    crown_radius : float
        Radius of the tread's cross-section, m; the collision ellipsoid has semi-axes (R, √(r_c R), R).
    timeconst : float
        Contact ``solref`` time constant, s (≥ 2 timesteps).
    dampratio : float
        Contact ``solref`` damping ratio.
    friction : float
        Sliding friction coefficient of tyre on floor.
    impratio : float
        Frictional to normal impedance ratio.
    torsional : float
        Torsional friction of the contact patch, m (``condim`` 4): it carries a turn's yaw moment.
    """

    crown_radius: float = 0.04
    timeconst: float = 0.004
    dampratio: float = 1.0
    friction: float = 1.5
    impratio: float = 10.0
    torsional: float = 0.02

    def __post_init__(self) -> None:
        check_settings(self, "tyre", non_negative=("torsional",))


def build_spatial_spec(params: Params = TABLE3, tyre: TyreContact | None = None,
                       mjcf: str | Path | None = None) -> mujoco.MjSpec:
    """Load ``mjcf/euc_3d.xml`` and apply the parameters and the tyre through MjSpec.

    Bodies as :func:`~euc_sim.model.mujoco_model.set_bodies` (the rider's and EUC's lateral
    inertias J, J0).  ``ModelError`` for a missing or unparsable file or a missing named element.
    """
    tyre = tyre or TyreContact()
    path = Path(mjcf) if mjcf is not None else MJCF_3D_PATH
    spec = load_spec(path)
    p = params
    set_bodies(spec, p, path, ("root",) + HINGES, ACTUATORS)
    _find(spec, "site", "G", path).pos = [0.0, 0.0, p.h]
    geom = _find(spec, "geom", "tyre_contact", path)
    geom.size = [p.R, math.sqrt(tyre.crown_radius * p.R), p.R]   # crown radius w²/R = r_c
    geom.solref = [tyre.timeconst, tyre.dampratio]
    geom.solimp = [0.99, 0.999, 0.001, 0.5, 2.0]
    geom.friction = [tyre.friction, tyre.torsional, 0.0]
    geom.condim = 4 if tyre.torsional > 0 else 3
    _find(spec, "geom", "floor", path).friction = [tyre.friction, tyre.torsional, 0.0]
    visual = spec.geom("tyre")
    if visual is not None:
        visual.size = [p.R, visual.size[1], 0.0]
    spec.option.impratio = tyre.impratio
    return spec


def load_spatial_model(params: Params = TABLE3, tyre: TyreContact | None = None,
                       mjcf: str | Path | None = None) -> mujoco.MjModel:
    """Compile :func:`build_spatial_spec`."""
    return compile_spec(build_spatial_spec(params, tyre, mjcf))


def euler_yaw_tilt_pitch(xmat) -> tuple[float, float, float]:
    """(ψ, ϑ, γ), rad, of a rotation matrix Rz(ψ) Rx(ϑ) Ry(γ) (row-major, 9 or 3x3)."""
    r = np.asarray(xmat, dtype=float).ravel()
    psi = math.atan2(-r[1], r[4])
    theta = math.asin(max(-1.0, min(1.0, r[7])))
    gamma = math.atan2(-r[6], r[8])
    return psi, theta, gamma


def euler_rates(psi: float, theta: float, omega_world) -> tuple[float, float, float]:
    """(ψ̇, ϑ̇, γ̇), rad/s, from the body's ground-frame angular velocity ω, rad/s:
    ω = ψ̇ e_Z + ϑ̇ Rz(ψ) e_x + γ̇ Rz(ψ) Rx(ϑ) e_y solved for the rates.
    """
    cp, sp, ct, st = math.cos(psi), math.sin(psi), math.cos(theta), math.sin(theta)
    wx, wy, wz = (float(w) for w in omega_world)
    # e_x' = (cp, sp, 0), e_y'' = (−sp ct, cp ct, st)
    gamma_d = (-sp * wx + cp * wy) / ct
    theta_d = cp * wx + sp * wy
    psi_d = wz - gamma_d * st
    return psi_d, theta_d, gamma_d


class EucSpatial:
    """The compiled spatial model with its data and named readouts.

    Parameters
    ----------
    params : Params
    tyre : TyreContact, optional
    timestep : float, optional
        Overrides the XML's 1 ms, s.
    mjcf : path, optional
    integrator : {"implicitfast", "RK4", "Euler"}, optional
        Overrides the XML's ``implicitfast``.
    """

    def __init__(self, params: Params = TABLE3, tyre: TyreContact | None = None,
                 timestep: float | None = None, mjcf=None, integrator: str | None = None):
        self.params = params
        self.tyre = tyre or TyreContact()
        self.model = load_spatial_model(params, self.tyre, mjcf)
        if timestep is not None:
            if not (math.isfinite(timestep) and timestep > 0):
                raise ModelError(f"timestep must be positive, got {timestep!r}")
            self.model.opt.timestep = timestep
        if integrator is not None:
            kinds = {"implicitfast": mujoco.mjtIntegrator.mjINT_IMPLICITFAST,
                     "RK4": mujoco.mjtIntegrator.mjINT_RK4, "Euler": mujoco.mjtIntegrator.mjINT_EULER}
            if integrator not in kinds:
                raise ModelError(f"integrator must be one of {', '.join(kinds)}, got {integrator!r}")
            self.model.opt.integrator = kinds[integrator]
        self.data = mujoco.MjData(self.model)
        m = self.model
        jid = lambda n: mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_JOINT, n)  # noqa: E731
        self.qadr = {n: int(m.jnt_qposadr[jid(n)]) for n in ("root",) + HINGES}
        self.vadr = {n: int(m.jnt_dofadr[jid(n)]) for n in ("root",) + HINGES}
        self.act = {n: mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_ACTUATOR, n) for n in ACTUATORS}
        self.site = {n: mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_SITE, n) for n in ("C", "E", "G")}
        self.body = {n: mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, n) for n in ("euc", "wheel", "rider")}
        self.tyre_geom = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_GEOM, "tyre_contact")

    # -- state -----------------------------------------------------------------------
    def set_straight(self, speed: float, gamma: float = 0.0, phi: float = 0.0,
                     heading: float = 0.0) -> None:
        """Upright rolling at ``speed`` (m/s) along ``heading``, body pitch γ and rider pitch φ
        (rad), at the contact's static sinkage.
        """
        for name, v in (("speed", speed), ("gamma", gamma), ("phi", phi), ("heading", heading)):
            if not math.isfinite(v):
                raise InputError(f"initial {name} must be finite, got {v!r}")
        a, v = self.qadr, self.vadr
        d = self.data
        d.qpos[:] = 0.0
        d.qvel[:] = 0.0
        quat = np.empty(4)
        mat = (_rot_z(heading) @ _rot_y(gamma)).ravel()
        mujoco.mju_mat2Quat(quat, mat)
        d.qpos[a["root"] + 3:a["root"] + 7] = quat
        d.qpos[a["rider_pitch"]] = phi - gamma
        settle_height(self.model, d, a["root"] + 2, v["root"] + 2, self.params.R - 0.01, self.params.R, 50)
        d.qvel[v["root"]:v["root"] + 2] = speed * math.cos(heading), speed * math.sin(heading)
        d.qvel[v["wheel_spin"]] = speed / self.params.R
        d.qacc_warmstart[:] = 0.0
        d.time = 0.0
        mujoco.mj_forward(self.model, self.data)

    # -- readouts ----------------------------------------------------------------------
    def euler(self) -> tuple[float, float, float]:
        """(ψ, ϑ, γ) of the EUC body, rad (yaw, tilt, pitch of Fig. 2)."""
        return euler_yaw_tilt_pitch(self.data.xmat[self.body["euc"]])

    def site_pos(self, name: str) -> np.ndarray:
        """Ground-frame position of site ``C``, ``E`` or ``G``, m (a copy)."""
        return self.data.site_xpos[self.site[name]].copy()

    def contact(self) -> tuple[np.ndarray, np.ndarray]:
        """Tyre contact point (m) and the floor's force on the tyre (N), ground frame; NaN and
        zeros when the tyre is off the floor.
        """
        d = self.data
        for i in range(d.ncon):
            c = d.contact[i]
            if self.tyre_geom in (c.geom1, c.geom2):
                f6 = np.zeros(6)
                mujoco.mj_contactForce(self.model, d, i, f6)
                frame = c.frame.reshape(3, 3)             # rows: normal, tangent 1, tangent 2
                f = frame.T @ f6[:3]
                if f[2] < 0:                               # the floor pushes the tyre up
                    f = -f
                return c.pos.copy(), f
        return np.full(3, np.nan), np.zeros(3)

    def set_torques(self, M_d: float, M_h: float, M_lean: float = 0.0, M_twist: float = 0.0) -> None:
        """Motor, ankle-pitch, lateral-lean and twist torques, N·m (+ on the EUC body)."""
        c, a = self.data.ctrl, self.act
        c[a["motor"]], c[a["ankle"]], c[a["lean"]], c[a["twist"]] = M_d, M_h, M_lean, M_twist

    def step(self, n: int = 1) -> None:
        """Advance n timesteps with the torques held."""
        mujoco.mj_step(self.model, self.data, nstep=n)


def _rot_z(a: float) -> np.ndarray:
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def _rot_y(a: float) -> np.ndarray:
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])

"""The MuJoCo model: ``mjcf/euc_planar.xml`` built through :class:`mujoco.MjSpec` with any
parameters, read in the paper's coordinates (see docs/simulation.md).

Ground variants: ``ideal``, pure rolling in exact reduced coordinates (no wheel hinge: its
spin inertia is the slide's armature J_w/R², the motor acts on the tendon ``motor_shaft`` =
x/R − gamma, eq. 8; physics only) and ``contact``, the wheel rolling on the floor through
friction (a vertical slide ``z``; the wheel may slip).  Joints are read by name:

=============== ================================= ===================
joint           meaning                           paper coordinates
=============== ================================= ===================
``x``           slide of the wheel centre C       x
``z``           (contact) height of C above R     0 when rolling
``euc_pitch``   EUC body pitch                    gamma
``wheel_spin``  (contact) wheel relative to body  x / R − gamma
``rider_pitch`` rider relative to the EUC body    phi − gamma
=============== ================================= ===================
"""

from __future__ import annotations

import copy
import dataclasses
import math
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path

import mujoco
import numpy as np

from euc_sim.errors import BadInputFile, InputError
from euc_sim.model.parameters import Params, TABLE3

__all__ = [
    "MJCF_PATH", "VARIANTS", "ModelError", "ContactSettings", "JointIndex", "build_spec",
    "load_model", "SHAFT_TENDON", "paper_jacobian", "to_mujoco", "from_mujoco", "EucMujoco",
]

#: The hand-written model, beside the package.
MJCF_PATH = Path(__file__).resolve().parents[2] / "mjcf" / "euc_planar.xml"
#: Ground models.
VARIANTS = ("ideal", "contact")

JOINTS = ("x", "euc_pitch", "wheel_spin", "rider_pitch")
#: Joints a compiled model may lack: ``z`` (ideal) and ``wheel_spin`` (ideal: reduced coordinates).
OPTIONAL_JOINTS = ("z", "wheel_spin")
ACTUATORS = ("motor", "ankle")
#: The ideal variant's motor transmission: the rotor angle x/R − gamma, rad.
SHAFT_TENDON = "motor_shaft"


#: MuJoCo's warnings that mean the state was not finite and MuJoCo reset it.
_UNSTABLE = ("BADQACC", "BADQVEL", "BADQPOS")


def _quiet_warning(message: str) -> None:
    """Swallow MuJoCo's warnings (read from ``data.warning`` by :func:`instability`, never printed)."""


mujoco.set_mju_user_warning(_quiet_warning)


def instability(data) -> str | None:
    """What MuJoCo's warning counters say of a run it reset (a NaN, infinite or huge state), or None.

    Returns
    -------
    str or None
        e.g. ``"QACC 412 times"``.
    """
    parts = []
    for name in _UNSTABLE:
        n = int(data.warning[getattr(mujoco.mjtWarning, f"mjWARN_{name}")].number)
        if n:
            parts.append(f"{name[3:]} {n} time{'s' if n > 1 else ''}")
    return ", ".join(parts) or None


def settle_height(model, data, qpos_index: int, dof_index: int, lo: float, hi: float, steps: int) -> None:
    """Bisect the height ``data.qpos[qpos_index]``, m, in [lo, hi] over ``steps`` halvings until the
    contact carries the weight (``qacc`` of ``dof_index`` changes sign), then ``mj_forward``.
    """
    for _ in range(steps):
        mid = 0.5 * (lo + hi)
        data.qpos[qpos_index] = mid
        mujoco.mj_forward(model, data)
        if data.qacc[dof_index] > 0:
            lo = mid
        else:
            hi = mid
    data.qpos[qpos_index] = 0.5 * (lo + hi)
    mujoco.mj_forward(model, data)


class ModelError(BadInputFile):
    """The MJCF file is missing, unreadable, lacks a named element, or does not compile."""


@dataclass(frozen=True)
class ContactSettings:
    """Wheel–floor contact of the ``contact`` variant.

    Attributes
    ----------
    timeconst : float
        Contact ``solref`` time constant, s (≥ 2 timesteps).
    dampratio : float
        Contact ``solref`` damping ratio.
    friction : float
        Sliding friction coefficient of the tyre on the floor.
    rolling_friction : float
        MuJoCo rolling-friction coefficient, m (C_rr × R); non-zero switches to ``condim`` 6.
    impratio : float
        Frictional to normal constraint impedance ratio (larger: less creep).
    """

    timeconst: float = 0.002
    dampratio: float = 1.0
    friction: float = 1.5
    rolling_friction: float = 0.0
    impratio: float = 100.0

    def __post_init__(self) -> None:
        check_settings(self, "contact", non_negative=("rolling_friction",))


def check_settings(settings, what: str, non_negative: tuple = ()) -> None:
    """``ModelError`` unless each field of the dataclass ``settings`` is a finite number, positive
    (≥ 0 for the fields in ``non_negative``); ``what`` names it in the message.
    """
    for field in dataclasses.fields(settings):
        value, floor_ok = getattr(settings, field.name), field.name in non_negative
        ok = isinstance(value, (int, float, np.floating)) and math.isfinite(value)
        if not (ok and (value >= 0 if floor_ok else value > 0)):
            raise ModelError(f"{what} setting {field.name!r} must be {'non-negative' if floor_ok else 'positive'} "
                             f"and finite, got {value!r}")


def _find(spec: mujoco.MjSpec, kind: str, name: str, path: Path):
    element = getattr(spec, kind)(name)
    if element is None:
        raise ModelError(f"{path}: {kind} {name!r} not found (euc-sim reads it by name)")
    return element


def load_spec(path: str | Path) -> mujoco.MjSpec:
    """An MJCF file as an editable ``mujoco.MjSpec``; ``ModelError`` naming the file if missing or unparsable."""
    path = Path(path)
    if not path.is_file():
        raise ModelError(f"MJCF file not found: {path}")
    try:
        return mujoco.MjSpec.from_file(str(path))
    except Exception as exc:  # mujoco raises a plain ValueError with a multi-line text
        raise ModelError(f"{path}: cannot parse MJCF: {str(exc).splitlines()[0]}") from None


def build_spec(params: Params = TABLE3, variant: str = "ideal", mjcf: str | Path | None = None,
               contact: ContactSettings | None = None) -> mujoco.MjSpec:
    """Load the MJCF file and apply parameters and the ground variant through MjSpec.

    Parameters
    ----------
    params : Params
        Model parameters (Table 3 by default).
    variant : {"ideal", "contact"}
        Ground model.
    mjcf : path, optional
        MJCF file; ``mjcf/euc_planar.xml`` by default.
    contact : ContactSettings, optional
        Used by the ``contact`` variant.

    Raises
    ------
    ModelError
        For an unknown variant, a missing file or a missing named element.
    """
    if variant not in VARIANTS:
        raise ModelError(f"unknown ground variant {variant!r}; expected one of {', '.join(VARIANTS)}")
    path = Path(mjcf) if mjcf is not None else MJCF_PATH
    spec = load_spec(path)
    p = params
    set_bodies(spec, p, path, JOINTS, ACTUATORS)
    _find(spec, "geom", "wheel_contact", path).size = [p.R, 0.0, 0.0]
    tyre = spec.geom("tyre")
    if tyre is not None:
        tyre.size = [p.R, tyre.size[1], 0.0]
    site_G = spec.site("G")
    if site_G is not None:
        site_G.pos = [0.0, 0.0, p.h]

    spec.delete(_find(spec, "equality", "rolling", path))
    spec.delete(_find(spec, "tendon", "rolling", path))
    if variant == "ideal":
        _make_reduced(spec, p, path)
    else:
        _make_contact(spec, p, contact or ContactSettings(), path)
    return spec


def set_bodies(spec: mujoco.MjSpec, p: Params, path: Path, joints: tuple, actuators: tuple) -> None:
    """Check that ``joints`` and ``actuators`` exist and set gravity and the bodies ``euc``, ``wheel``
    and ``rider`` from ``p``: pitch inertias J0, Jw, J (Table 3), the wheel's diametral 0.6 Jw, the
    EUC's and rider's yaw 0.2 J0, 0.2 J.
    """
    euc, wheel, rider = (_find(spec, "body", n, path) for n in ("euc", "wheel", "rider"))
    for name in joints:
        _find(spec, "joint", name, path)
    for name in actuators:
        _find(spec, "actuator", name, path)
    spec.option.gravity = [0.0, 0.0, -p.g]
    euc.pos = [0.0, 0.0, p.R]
    euc.mass, euc.ipos, euc.inertia = p.m0, [0.0, 0.0, p.h0], [p.J0, p.J0, 0.2 * p.J0]
    wheel.mass, wheel.ipos, wheel.inertia = p.mw, [0.0, 0.0, 0.0], [0.6 * p.Jw, p.Jw, 0.6 * p.Jw]
    rider.pos = [0.0, 0.0, -p.l0]
    rider.mass, rider.ipos, rider.inertia = p.m, [0.0, 0.0, p.h], [p.J, p.J, 0.2 * p.J]


def _make_reduced(spec: mujoco.MjSpec, p: Params, path: Path) -> None:
    """Pure rolling in reduced coordinates (x, gamma, rider_pitch), physics only."""
    # no contacts and no constraints exist in the ideal variant: skip both stages
    spec.option.disableflags |= int(mujoco.mjtDisableBit.mjDSBL_CONTACT | mujoco.mjtDisableBit.mjDSBL_CONSTRAINT)
    shaft = spec.add_tendon(name=SHAFT_TENDON)          # rotor angle: x/R − gamma
    shaft.wrap_joint("x", 1.0 / p.R)
    shaft.wrap_joint("euc_pitch", -1.0)
    motor = _find(spec, "actuator", "motor", path)
    motor.trntype = mujoco.mjtTrn.mjTRN_TENDON
    motor.target = SHAFT_TENDON
    spec.delete(_find(spec, "joint", "wheel_spin", path))
    # the wheel turns at x/R whatever gamma does: its spin inertia J_w moves from the
    # body (where it would turn with gamma) to the slide, ½ J_w (ẋ/R)² = ½ (J_w/R²) ẋ²
    wheel = _find(spec, "body", "wheel", path)
    wheel.inertia = [0.6 * p.Jw, 0.0, 0.6 * p.Jw]
    x = _find(spec, "joint", "x", path)
    x.armature = x.armature + p.Jw / p.R**2
    # physics only, for the closed loop's 1 kHz steps: the wheel body (no joint left) is
    # fused into the EUC body, and the geoms, sites, camera and light go (nothing collides,
    # nothing renders the planar model): 12 % of an RK4 step
    spec.compiler.fusestatic = True
    for element in list(spec.geoms) + list(spec.sites) + list(spec.cameras) + list(spec.lights):
        spec.delete(element)


def _make_contact(spec: mujoco.MjSpec, p: Params, c: ContactSettings, path: Path) -> None:
    """Turn the ideal model into the contact one: vertical slide, wheel–floor friction."""
    euc = spec.body("euc")
    # Joints of a body act in order; z must precede the pitch hinge so that it slides
    # along the world vertical, hence the pitch joint is re-added after it.
    pitch = spec.joint("euc_pitch")
    spec.delete(pitch)
    euc.add_joint(name="z", type=mujoco.mjtJoint.mjJNT_SLIDE, axis=[0, 0, 1])
    euc.add_joint(name="euc_pitch", type=mujoco.mjtJoint.mjJNT_HINGE, axis=[0, 1, 0])
    geom = _find(spec, "geom", "wheel_contact", path)
    geom.contype, geom.conaffinity = 1, 1
    geom.condim = 6 if c.rolling_friction > 0 else 3
    geom.friction = [c.friction, 0.0, c.rolling_friction]
    geom.solref = [c.timeconst, c.dampratio]
    geom.solimp = [0.99, 0.999, 0.001, 0.5, 2.0]
    floor = _find(spec, "geom", "floor", path)
    floor.friction = [c.friction, 0.0, c.rolling_friction]
    spec.option.impratio = c.impratio
    spec.option.cone = mujoco.mjtCone.mjCONE_ELLIPTIC


def load_model(params: Params = TABLE3, variant: str = "ideal", mjcf: str | Path | None = None,
               contact: ContactSettings | None = None) -> mujoco.MjModel:
    """Compile the model (see :func:`build_spec`); cached by parameters, variant, file
    (and its modification time) and contact settings, each call returning its own copy.
    """
    path = Path(mjcf) if mjcf is not None else MJCF_PATH
    stamp = path.stat().st_mtime_ns if path.is_file() else None     # a missing file: build_spec says so
    return copy.copy(_compiled(params, variant, str(path), stamp, contact))


@lru_cache(maxsize=16)
def _compiled(params: Params, variant: str, path: str, stamp, contact) -> mujoco.MjModel:
    return compile_spec(build_spec(params, variant, path, contact))


def compile_spec(spec: mujoco.MjSpec) -> mujoco.MjModel:
    """``spec.compile()``, a failure as one-line ``ModelError``."""
    try:
        return spec.compile()
    except Exception as exc:
        raise ModelError(f"MJCF does not compile with these parameters: {str(exc).splitlines()[0]}") from None


@dataclass(frozen=True)
class JointIndex:
    """qpos/qvel addresses of the named joints of a compiled model."""

    qpos: dict[str, int]
    dof: dict[str, int]
    nq: int
    nv: int

    @classmethod
    def of(cls, model: mujoco.MjModel) -> "JointIndex":
        qpos, dof = {}, {}
        for name in JOINTS + ("z",):
            jid = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, name)
            if jid < 0:
                if name in OPTIONAL_JOINTS:
                    continue
                raise ModelError(f"model has no joint {name!r}")
            qpos[name] = int(model.jnt_qposadr[jid])
            dof[name] = int(model.jnt_dofadr[jid])
        return cls(qpos, dof, int(model.nq), int(model.nv))

    @property
    def has_z(self) -> bool:
        return "z" in self.qpos

    @property
    def has_spin(self) -> bool:
        """Whether the wheel has its own hinge (contact variant) or turns at x/R (ideal)."""
        return "wheel_spin" in self.qpos


def paper_jacobian(index: JointIndex, R: float) -> np.ndarray:
    """T with qvel = T q̇ under pure rolling, shape (nv, 3).

    M_paper = Tᵀ M_mj T, bias_paper = Tᵀ bias_mj, Q_paper = Tᵀ Q_mj (exact in the ideal variant).
    """
    T = np.zeros((index.nv, 3))
    d = index.dof
    T[d["x"], 0] = 1.0
    T[d["euc_pitch"], 1] = 1.0
    if index.has_spin:
        T[d["wheel_spin"], 0] = 1.0 / R      # wheel_spin = x/R − gamma
        T[d["wheel_spin"], 1] = -1.0
    T[d["rider_pitch"], 1] = -1.0            # rider_pitch = phi − gamma
    T[d["rider_pitch"], 2] = 1.0
    return T


def to_mujoco(index: JointIndex, R: float, q, qd=None, qdd=None):
    """Paper coordinates (x, gamma, phi) and rates, (..., 3), → MuJoCo's (qpos, qvel, qacc),
    assuming pure rolling (z = 0 in the contact variant); ``qd``, ``qdd`` default to zero.
    """
    q = np.asarray(q, dtype=float)
    qd = np.zeros_like(q) if qd is None else np.asarray(qd, dtype=float)
    qdd = np.zeros_like(q) if qdd is None else np.asarray(qdd, dtype=float)
    T = paper_jacobian(index, R)
    qpos = np.zeros(q.shape[:-1] + (index.nq,))
    qpos[..., index.qpos["x"]] = q[..., 0]
    qpos[..., index.qpos["euc_pitch"]] = q[..., 1]
    if index.has_spin:
        qpos[..., index.qpos["wheel_spin"]] = q[..., 0] / R - q[..., 1]
    qpos[..., index.qpos["rider_pitch"]] = q[..., 2] - q[..., 1]
    return qpos, qd @ T.T, qdd @ T.T


def from_mujoco(index: JointIndex, qpos, qvel=None, qacc=None):
    """MuJoCo's (qpos, qvel, qacc) → paper coordinates (q, q̇, q̈), each (..., 3) or None
    when not given; phi = gamma + rider_pitch, the wheel's spin is not read.
    """
    def pick(arr, adr):
        arr = np.asarray(arr, dtype=float)
        x, g, r = arr[..., adr["x"]], arr[..., adr["euc_pitch"]], arr[..., adr["rider_pitch"]]
        return np.stack([x, g, g + r], axis=-1)

    q = pick(qpos, index.qpos)
    qd = None if qvel is None else pick(qvel, index.dof)
    qdd = None if qacc is None else pick(qacc, index.dof)
    return q, qd, qdd


class EucMujoco:
    """A compiled model with its data and named readouts in the paper's coordinates.

    Parameters
    ----------
    params, variant, mjcf, contact
        As :func:`build_spec`.
    timestep : float, optional
        Overrides the XML's 1 ms, s.

    Examples
    --------
    >>> sim = EucMujoco()
    >>> sim.set_state([0.0, 0.02, 0.05], [1.0, 0.0, 0.0])
    >>> sim.q.round(3).tolist()
    [0.0, 0.02, 0.05]
    """

    def __init__(self, params: Params = TABLE3, variant: str = "ideal", mjcf=None,
                 contact: ContactSettings | None = None, timestep: float | None = None):
        self.params = params
        self.variant = variant
        self.model = load_model(params, variant, mjcf, contact)
        if timestep is not None:
            if not np.isfinite(timestep) or timestep <= 0:
                raise ModelError(f"timestep must be positive, got {timestep!r}")
            self.model.opt.timestep = timestep
        self.data = mujoco.MjData(self.model)
        self.index = JointIndex.of(self.model)
        self.T = paper_jacobian(self.index, params.R)
        self._act = {name: mujoco.mj_name2id(self.model, mujoco.mjtObj.mjOBJ_ACTUATOR, name)
                     for name in ACTUATORS}
        self._M = np.zeros((self.model.nv, self.model.nv))
        if self.index.has_z:   # start resting on the floor, at the contact's equilibrium depth
            self.settle()

    # -- state --------------------------------------------------------------------
    def set_state(self, q, qd=None) -> None:
        """Set the state from paper coordinates (pure rolling) and run ``mj_forward``."""
        q = np.asarray(q, dtype=float)
        qd = np.zeros(3) if qd is None else np.asarray(qd, dtype=float)
        if q.shape != (3,) or qd.shape != (3,):
            raise ValueError(f"state must be q, qd of shape (3,), got {q.shape} and {qd.shape}")
        if not (np.all(np.isfinite(q)) and np.all(np.isfinite(qd))):
            raise InputError(f"state must be finite, got q={q.tolist()}, qd={qd.tolist()}")
        z = self.data.qpos[self.index.qpos["z"]] if self.index.has_z else 0.0
        qpos, qvel, _ = to_mujoco(self.index, self.params.R, q, qd)
        if self.index.has_z:
            qpos[self.index.qpos["z"]] = z
        self.data.qpos[:] = qpos
        self.data.qvel[:] = qvel
        self.data.qacc_warmstart[:] = 0.0
        self.data.time = 0.0
        mujoco.mj_forward(self.model, self.data)

    def settle(self) -> None:
        """Contact variant: put the wheel centre at the static sinkage of the soft contact."""
        self.data.qpos[:] = 0.0
        self.data.qvel[:] = 0.0
        settle_height(self.model, self.data, self.index.qpos["z"], self.index.dof["z"], -0.01, 0.0, 60)

    @property
    def q(self) -> np.ndarray:
        """(x [m], gamma [rad], phi [rad])."""
        return from_mujoco(self.index, self.data.qpos)[0]

    @property
    def qd(self) -> np.ndarray:
        """(ẋ [m/s], γ̇ [rad/s], φ̇ [rad/s])."""
        return from_mujoco(self.index, self.data.qpos, self.data.qvel)[1]

    @property
    def qdd(self) -> np.ndarray:
        """(ẍ, γ̈, φ̈) of the last ``mj_forward``/step, SI."""
        return from_mujoco(self.index, self.data.qpos, self.data.qvel, self.data.qacc)[2]

    def set_bearing_damping(self, c: float) -> None:
        """Viscous bearing friction, N·m·s/rad, on the rotor speed ẋ/R − γ̇ (damping of
        ``motor_shaft`` in the ideal variant, of ``wheel_spin`` in the contact one).
        """
        if self.index.has_spin:
            self.model.dof_damping[self.index.dof["wheel_spin"]] = c
        else:
            tid = mujoco.mj_name2id(self.model, mujoco.mjtObj.mjOBJ_TENDON, SHAFT_TENDON)
            self.model.tendon_damping[tid] = c

    # -- actuation and stepping ---------------------------------------------------------
    def set_torques(self, M_d: float, M_h: float) -> None:
        """Set the motor torque M_d and the ankle torque M_h, N·m (CONTRACT signs)."""
        self.data.ctrl[self._act["motor"]] = M_d
        self.data.ctrl[self._act["ankle"]] = M_h

    def step(self, n: int = 1) -> None:
        """Advance n timesteps with the torques held."""
        mujoco.mj_step(self.model, self.data, nstep=n)

    # -- quantities in paper coordinates ------------------------------------------------
    def mass_matrix(self) -> np.ndarray:
        """Tᵀ M_mj T at the current state, (3, 3): compare eq. (6)."""
        mujoco.mj_fullM(self.model, self.data, self._M)
        return self.T.T @ self._M @ self.T

    def bias(self) -> np.ndarray:
        """Tᵀ qfrc_bias at the current state, (3,): compare h − Q_gravity of eqs. (7)-(8)."""
        return self.T.T @ self.data.qfrc_bias

    def inverse(self, q, qd, qdd) -> np.ndarray:
        """Generalised forces for (q, q̇, q̈) by ``mj_inverse``, Tᵀ qfrc_inverse, (3,); replaces
        the state held in ``data``.
        """
        qpos, qvel, qacc = to_mujoco(self.index, self.params.R, q, qd, qdd)
        if self.index.has_z:
            qpos[self.index.qpos["z"]] = self.data.qpos[self.index.qpos["z"]]
        self.data.qpos[:], self.data.qvel[:], self.data.qacc[:] = qpos, qvel, qacc
        mujoco.mj_inverse(self.model, self.data)
        return self.T.T @ (self.data.qfrc_inverse + self.data.qfrc_constraint)

    def energy(self) -> float:
        """Kinetic plus gravitational potential energy, J (ground at z = 0)."""
        mujoco.mj_energyPos(self.model, self.data)
        mujoco.mj_energyVel(self.model, self.data)
        return float(self.data.energy[0] + self.data.energy[1])

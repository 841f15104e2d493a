"""From a recording to (q, q̇, q̈): the paper's Section 2 and the smoothing.

:class:`Smoothing` ``"consistent"`` (default): short Savitzky–Golay derivatives, then one
Gaussian low-pass applied identically to every torque term (:func:`term_filter`), so an
equation holding sample by sample still holds after filtering.  ``"savgol"`` (the
paper's): q, q̇, q̈ from one long Savitzky–Golay fit.  Compared in docs/identification.md.
Motion-capture files (:func:`mocap_state`): C from the pivot E, r_CG by eqs. (1)–(2),
φ by eq. (3) or exactly from the ankle A.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import pandas as pd

from euc_sim.errors import InputError
from euc_sim.identification.recordings import RecordingError, check_length, is_mocap
from euc_sim.model.parameters import Params

__all__ = [
    "Smoothing", "Kinematics", "DEFAULT_SMOOTHING", "savgol_derivatives",
    "term_filter", "T_psi", "T_theta", "T_pitch", "moving_frame", "wheel_centre",
    "mocap_state", "kinematics", "sample_period",
]

#: Gaussian truncation of :func:`term_filter`, standard deviations.
_TRUNCATE = 4.0


#: Highest Savitzky–Golay order: beyond it the least-squares fit loses all its digits.
MAX_ORDER = 12


@dataclass(frozen=True)
class Smoothing:
    """How derivatives are estimated and the torque terms filtered.

    Attributes
    ----------
    method : {"consistent", "savgol"}
    window : float or None
        Savitzky–Golay window, s (rounded to an odd number of samples); ``None``: 0.25 s
        consistent, 1.0 s savgol.
    order : int or None
        Savitzky–Golay order in [2, MAX_ORDER]; ``None``: 5 consistent, 3 savgol.
    term_sigma : float
        Standard deviation of the Gaussian term filter, s (consistent only; 0: off).
    """

    method: str = "consistent"
    window: float | None = None
    order: int | None = None
    term_sigma: float = 0.3

    def __post_init__(self) -> None:
        if self.method not in ("consistent", "savgol"):
            raise InputError(f"smoothing method must be 'consistent' or 'savgol', got {self.method!r}")
        if self.window is None:
            object.__setattr__(self, "window", 0.25 if self.method == "consistent" else 1.0)
        if self.order is None:
            object.__setattr__(self, "order", 5 if self.method == "consistent" else 3)
        if not (math.isfinite(self.window) and self.window > 0):
            raise InputError(f"smoothing window must be positive, got {self.window!r} s")
        if int(self.order) != self.order or not 2 <= self.order <= MAX_ORDER:
            raise InputError(f"smoothing order must be an integer from 2 (for q̈) to {MAX_ORDER} "
                             f"(higher fits are ill-conditioned), got {self.order!r}")
        if not (math.isfinite(self.term_sigma) and self.term_sigma >= 0):
            raise InputError(f"term filter sigma must be non-negative, got {self.term_sigma!r} s")
        if self.method == "savgol":
            object.__setattr__(self, "term_sigma", 0.0)

    def samples(self, dt: float) -> int:
        """The window in samples: odd, and larger than the order."""
        n = int(round(self.window / dt))
        n += 1 - n % 2
        return max(n, self.order + 1 + (self.order % 2))

    def sigma_samples(self, dt: float) -> float:
        """The term filter's standard deviation in samples (0: no filter)."""
        return self.term_sigma / dt

    def edge(self, dt: float) -> int:
        """Samples at each end where the filters lack support (dropped from fits)."""
        return self.samples(dt) // 2 + int(math.ceil(3.0 * self.sigma_samples(dt)))

    def min_samples(self, dt: float) -> int:
        """Shortest usable recording: both edges plus one window of interior."""
        return 2 * self.edge(dt) + self.samples(dt)

    def describe(self) -> dict:
        """JSON-friendly description."""
        return {"method": self.method, "window_s": self.window, "order": self.order,
                "term_sigma_s": self.term_sigma}


#: The default: consistent filtering.
DEFAULT_SMOOTHING = Smoothing()


@dataclass(frozen=True)
class Kinematics:
    """Coordinates and their derivatives on a uniform time grid.

    Attributes
    ----------
    t : ndarray, shape (N,)
        Time, s.
    q, qd, qdd : ndarray, shape (N, 3)
        (x, γ, φ) in m, rad, and their first and second time derivatives.
    extra : dict of str to ndarray
        Yaw and tilt (``psi``, ``theta``), rad, where recorded.
    smoothing : Smoothing
        Its term filter is still to be applied to the torque terms.
    """

    t: np.ndarray
    q: np.ndarray
    qd: np.ndarray
    qdd: np.ndarray
    extra: dict
    smoothing: Smoothing

    @property
    def dt(self) -> float:
        """Sample period, s."""
        return float(self.t[1] - self.t[0])

    @property
    def interior(self) -> slice:
        """The samples with full filter support."""
        e = self.smoothing.edge(self.dt)
        return slice(e, len(self.t) - e)


def sample_period(t: np.ndarray) -> float:
    """The (uniform) sample period of a time column, s."""
    t = np.asarray(t, dtype=float)
    return float((t[-1] - t[0]) / (len(t) - 1))


def savgol_derivatives(y: np.ndarray, dt: float, window: int, order: int, axis: int = 0):
    """Signal and first two derivatives (units y, y/s, y/s²) from one Savitzky–Golay fit along ``axis``.

    ``window`` (odd) in samples, ``dt`` in s; ``mode="interp"`` at the ends.
    """
    y = np.asarray(y, dtype=float)
    from scipy.signal import savgol_filter

    return tuple(savgol_filter(y, window, order, deriv=k, delta=dt, axis=axis, mode="interp")
                 for k in (0, 1, 2))


def term_filter(y: np.ndarray, sigma_samples: float, axis: int = -1) -> np.ndarray:
    """The consistent low-pass: a Gaussian of ``sigma_samples`` along ``axis`` (0: a copy of ``y``)."""
    y = np.asarray(y, dtype=float)
    if sigma_samples <= 0:
        return y.copy()
    from scipy.ndimage import gaussian_filter1d

    return gaussian_filter1d(y, sigma_samples, axis=axis, mode="nearest", truncate=_TRUNCATE)


# --- Section 2: rotations, eqs. (1)-(2) --------------------------------------------------
def T_psi(psi: np.ndarray) -> np.ndarray:
    """Yaw rotation T_ψ of eq. (2), shape (..., 3, 3)."""
    psi = np.asarray(psi, dtype=float)
    c, s = np.cos(psi), np.sin(psi)
    o, z = np.ones_like(psi), np.zeros_like(psi)
    return np.stack([np.stack([c, -s, z], -1), np.stack([s, c, z], -1), np.stack([z, z, o], -1)], -2)


def T_theta(theta: np.ndarray) -> np.ndarray:
    """Tilt rotation T_ϑ of eq. (2) (about the longitudinal axis), shape (..., 3, 3)."""
    theta = np.asarray(theta, dtype=float)
    c, s = np.cos(theta), np.sin(theta)
    o, z = np.ones_like(theta), np.zeros_like(theta)
    return np.stack([np.stack([o, z, z], -1), np.stack([z, c, -s], -1), np.stack([z, s, c], -1)], -2)


def T_pitch(gamma: np.ndarray) -> np.ndarray:
    """Pitch rotation about the lateral axis, positive tipping the top forward (+x)."""
    gamma = np.asarray(gamma, dtype=float)
    c, s = np.cos(gamma), np.sin(gamma)
    o, z = np.ones_like(gamma), np.zeros_like(gamma)
    return np.stack([np.stack([c, z, s], -1), np.stack([z, o, z], -1), np.stack([-s, z, c], -1)], -2)


def moving_frame(vec_ground: np.ndarray, psi: np.ndarray, theta: np.ndarray) -> np.ndarray:
    """Eq. (1): r = T_ϑᵀ T_ψᵀ R, ground-frame vectors (N, 3) in the moving frame, ψ and ϑ in rad."""
    rot = np.einsum("...ji,...kj->...ik", T_theta(theta), T_psi(psi))   # T_ϑᵀ T_ψᵀ
    return np.einsum("...ij,...j->...i", rot, np.asarray(vec_ground, dtype=float))


def wheel_centre(E: np.ndarray, psi, theta, gamma, d_CE: float) -> np.ndarray:
    """C (N, 3), m: E lies d_CE from C along the body axis T_ψ T_ϑ T_γ e_z."""
    rot = T_psi(psi) @ T_theta(theta) @ T_pitch(gamma)
    return np.asarray(E, dtype=float) - d_CE * rot[..., :, 2]


def mocap_state(df: pd.DataFrame, p: Params, smoothing: Smoothing, d_CE: float | None = None,
                phi_from: str = "A") -> Kinematics:
    """The paper's Section 2: motion-capture columns to (q, q̇, q̈).

    Parameters
    ----------
    df : DataFrame
        ``t``, ``psi, theta, gamma`` (rad), ``G_X..G_Z`` and ``C_X..C_Z`` or ``E_X..E_Z`` (m).
    p : Params
        Uses ``l0`` for ``phi_from="A"``.
    smoothing : Smoothing
    d_CE : float, optional
        Distance C–E along the EUC body, m; needed when C is not recorded.
    phi_from : {"A", "C"}
        ``"C"``: eq. (3), φ = atan2(x_CG, z_CG), which overstates the lean by about
        l0 (φ − γ)/(h − l0); ``"A"``: exact, φ = atan2(x_CG + l0 sin γ, z_CG + l0 cos γ).

    Returns
    -------
    Kinematics
        x = ∫ v_Cx dt, ẋ = v_Cx, ẍ = a_Cx (moving frame); ψ, ϑ in ``extra``.
    """
    if phi_from not in ("C", "A"):
        raise InputError(f"phi_from must be 'C' (eq. 3) or 'A' (exact), got {phi_from!r}")
    t = df["t"].to_numpy(dtype=float)
    dt = sample_period(t)
    w, o = smoothing.samples(dt), smoothing.order
    ang = {k: df[k].to_numpy(dtype=float) for k in ("psi", "theta", "gamma")}
    G = df[["G_X", "G_Y", "G_Z"]].to_numpy(dtype=float)
    if {"C_X", "C_Y", "C_Z"} <= set(df.columns):
        C = df[["C_X", "C_Y", "C_Z"]].to_numpy(dtype=float)
    else:
        if d_CE is None:
            raise InputError("column 'C_X' missing: the C–E distance (d_CE, m) is needed to "
                             "place the wheel centre from the pivot E")
        if not (math.isfinite(d_CE) and d_CE > 0):
            raise InputError(f"the C–E distance d_CE must be a positive length, got {d_CE!r} m")
        E = df[["E_X", "E_Y", "E_Z"]].to_numpy(dtype=float)
        C = wheel_centre(E, ang["psi"], ang["theta"], ang["gamma"], d_CE)
    C0, C1, C2 = savgol_derivatives(C, dt, w, o, axis=0)
    psi, _, _ = savgol_derivatives(ang["psi"], dt, w, o)
    theta, _, _ = savgol_derivatives(ang["theta"], dt, w, o)
    G0 = savgol_derivatives(G, dt, w, o, axis=0)[0]
    r_CG = moving_frame(G0 - C0, psi, theta)                                  # eq. (1)
    gam = savgol_derivatives(ang["gamma"], dt, w, o)
    if phi_from == "C":
        phi_raw = np.arctan2(r_CG[:, 0], r_CG[:, 2])                           # eq. (3)
    else:
        phi_raw = np.arctan2(r_CG[:, 0] + p.l0 * np.sin(gam[0]), r_CG[:, 2] + p.l0 * np.cos(gam[0]))
    v_C = moving_frame(C1, psi, theta)                                        # v_Cx
    a_C = moving_frame(C2, psi, theta)                                        # a_Cx
    from scipy.integrate import cumulative_trapezoid

    x = cumulative_trapezoid(v_C[:, 0], t, initial=0.0)
    phi = savgol_derivatives(phi_raw, dt, w, o)
    q = np.column_stack([x, gam[0], phi[0]])
    qd = np.column_stack([v_C[:, 0], gam[1], phi[1]])
    qdd = np.column_stack([a_C[:, 0], gam[2], phi[2]])
    return Kinematics(t=t, q=q, qd=qd, qdd=qdd, extra={"psi": psi, "theta": theta},
                      smoothing=smoothing)


def kinematics(df: pd.DataFrame, p: Params, smoothing: Smoothing = DEFAULT_SMOOTHING,
               d_CE: float | None = None, phi_from: str = "A", name: str = "recording",
               source: str = "auto") -> Kinematics:
    """(q, q̇, q̈) of a validated recording, state-level or motion-capture level.

    Parameters
    ----------
    df : DataFrame
        From :func:`euc_sim.identification.recordings.read_recording`.
    p : Params
    smoothing : Smoothing
    d_CE, phi_from
        Motion-capture only, see :func:`mocap_state`.
    name : str
        The file, for messages.
    source : {"auto", "state", "mocap"}
        ``"auto"``: x, γ, φ when present, else the motion-capture columns.

    Raises
    ------
    RecordingError
        when the recording is too short for the smoothing or lacks the columns.
    """
    t = df["t"].to_numpy(dtype=float)
    dt = sample_period(t)
    check_length(df, name, smoothing.min_samples(dt),
                 f"the smoothing window ({smoothing.samples(dt)} samples and "
                 f"{smoothing.edge(dt)} edge samples each side)")
    if source not in ("auto", "state", "mocap"):
        raise InputError(f"source must be 'auto', 'state' or 'mocap', got {source!r}")
    has_mocap = {"G_X", "G_Y", "G_Z", "psi", "theta", "gamma"} <= set(df.columns) and (
        {"C_X", "C_Y", "C_Z"} <= set(df.columns) or {"E_X", "E_Y", "E_Z"} <= set(df.columns))
    if source == "mocap" and not has_mocap:
        raise RecordingError(f"{name}: column 'G_X' row 0: motion-capture columns (C or E, G, "
                             f"psi, theta, gamma) are needed for Section 2 processing")
    if source == "mocap" or (source == "auto" and is_mocap(df)):
        return mocap_state(df, p, smoothing, d_CE=d_CE, phi_from=phi_from)
    w, o = smoothing.samples(dt), smoothing.order
    missing = [c for c in ("x", "gamma", "phi") if c not in df.columns]
    if missing:
        raise RecordingError(f"{name}: column {missing[0]!r} missing: the state source needs x, gamma "
                             f"and phi{' (or the motion-capture columns with --source mocap)' if has_mocap else ''}")
    Q = df[["x", "gamma", "phi"]].to_numpy(dtype=float)
    q, qd, qdd = savgol_derivatives(Q, dt, w, o, axis=0)
    extra = {k: df[k].to_numpy(dtype=float) for k in ("psi", "theta") if k in df.columns}
    return Kinematics(t=t, q=q, qd=qd, qdd=qdd, extra=extra, smoothing=smoothing)

"""Step 1, prepare: read, validate and differentiate a recording; its sensor noise.

One linear filter applied consistently to q, q̇, q̈ (and to M_d where recorded):
:mod:`euc_sim.identification.processing` (filter every term of the residual the same
way, or its noise is scaled unequally).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any, Mapping

import numpy as np
import pandas as pd

from euc_sim.diagnosis.common import LATERAL_WINDOW, RIDER_MASS_RANGE, SELECT_RATE, DiagnosisError
from euc_sim.identification import processing, recordings
from euc_sim.io import sidecar_paths
from euc_sim.model.parameters import Params
from euc_sim.model.rider_spatial import plane_coordinates

__all__ = ["Prepared", "prepare", "noise_sd", "lateral_inputs", "marker_tilt"]


# --- preparing the signals ----------------------------------------------------------------
@dataclass(frozen=True)
class Prepared:
    """A recording differentiated and ready for the residual.

    Attributes
    ----------
    kin : processing.Kinematics
        Short Savitzky–Golay (q, q̇, q̈) of every sample; the term filter is still to be applied.
    sigma : float
        The term filter's standard deviation, samples.
    M_d : numpy.ndarray or None
        (N,) recorded driving torque (unfiltered), N·m.
    lateral : dict or None
        The lateral term's inputs (:func:`lateral_inputs`) where ``psi`` and ``theta`` are recorded.
    keep : numpy.ndarray
        Indices of the residual samples used (interior, decimated to :data:`SELECT_RATE`).
    params : Params
        Nominal parameters (h is identified).
    meta : dict
    name : str
    noise_sd : dict
        White-noise standard deviation per channel, m or rad.
    raw : pandas.DataFrame
        The validated recording (not modified).
    """

    kin: Any
    sigma: float
    M_d: np.ndarray | None
    lateral: dict | None
    keep: np.ndarray
    params: Params
    meta: dict
    name: str
    noise_sd: dict
    raw: pd.DataFrame

    def shifted(self, tau: float) -> "Prepared":
        """The rider channel advanced by τ s: φ(t + τ), φ̇, φ̈ likewise (undoes a lag τ)."""
        k = self.kin
        arrs = []
        for a in (k.q, k.qd, k.qdd):
            b = a.copy()
            b[:, 2] = np.interp(k.t + tau, k.t, a[:, 2])
            arrs.append(b)
        return replace(self, kin=replace(k, q=arrs[0], qd=arrs[1], qdd=arrs[2]))

    def with_kin(self, q, qd, qdd) -> "Prepared":
        """The same recording with other (q, q̇, q̈) (for noise propagation)."""
        return replace(self, kin=replace(self.kin, q=q, qd=qd, qdd=qdd))

    def stacked_time(self, wheel_row: bool) -> np.ndarray:
        """Time of each residual sample, s: the kept samples, twice with the wheel row (M_d recorded)."""
        t = self.kin.t[self.keep]
        return np.concatenate([t, t]) if wheel_row else t

    def filtered(self, y: np.ndarray) -> np.ndarray:
        """The consistent term filter applied along the last axis, at the kept samples."""
        return processing.term_filter(y, self.sigma, axis=-1)[..., self.keep]


def _read(source, meta: Mapping | None):
    if isinstance(source, pd.DataFrame):
        name = str(dict(meta or {}).get("name", "<DataFrame>"))
        df = recordings.validate_recording(source.copy(), name)
        return df, dict(meta or {}), name
    path = Path(source)
    df, file_meta = recordings.read_recording(path)
    return df, {**file_meta, **dict(meta or {})}, path.name


def _nominal_params(params, meta: dict, source, name: str) -> Params:
    """``params`` when given, else the sidecar's (or Table 3); DiagnosisError, naming the source, for a rider mass
    outside :data:`RIDER_MASS_RANGE`."""
    if isinstance(params, Params):
        p, where = params, "params"
    elif params is not None:
        p, where = Params.from_mapping({k: v for k, v in dict(params).items() if k != "h"}), "params"
    else:
        if isinstance(source, pd.DataFrame):
            where = f"meta of {name}"
        else:
            where = f"{sidecar_paths(source)[0].name} (sidecar of {name})"
        p = recordings.params_from_meta(meta, where)
        where += ": field params.m"
    lo, hi = RIDER_MASS_RANGE
    if not lo <= p.m <= hi:
        raise DiagnosisError(f"{where}: rider's mass m = {p.m:g} kg is not a rider's mass; expected "
                             f"{lo:g} to {hi:g} kg (the total of rider and clothes, not a change)")
    return p


def prepare(source, params: Params | Mapping | None = None, meta: Mapping | None = None,
            smoothing=None) -> Prepared:
    """Read, validate and differentiate a recording by the consistent recipe.

    Parameters
    ----------
    source : path or pandas.DataFrame
        A CONTRACT recording (state or motion-capture columns) or its table.
    params : Params or mapping, optional
        Nominal parameters; default the sidecar's, else Table 3.
    meta : mapping, optional
        Metadata for a DataFrame source.
    smoothing : processing.Smoothing, optional
        Default ``processing.DEFAULT_SMOOTHING``.

    Raises
    ------
    DiagnosisError
        for a recording too short for the filters.
    """
    df, meta, name = _read(source, meta)
    p = _nominal_params(params, meta, source, name)
    sm = smoothing or processing.DEFAULT_SMOOTHING
    if sm.method != "consistent" or sm.term_sigma <= 0:
        raise DiagnosisError(f"smoothing must be the consistent recipe with a term filter, got {sm.describe()}")
    kin = processing.kinematics(df, p, sm, name=name)
    t = kin.t
    dt = kin.dt
    edge = sm.edge(dt)
    if t.size < 2 * edge + int(2.0 / dt):
        raise DiagnosisError(f"recording {name}: duration {t[-1] - t[0]:.2f} s too short; expected at "
                             f"least {(2 * edge) * dt + 2.0:.1f} s for the filters")
    M_d = df["M_d"].to_numpy(float) if "M_d" in df.columns else None
    lateral = lateral_inputs(df, kin.q, p, dt) if {"theta", "psi"} <= set(df.columns) else None
    step = max(1, int(round(1.0 / (dt * SELECT_RATE))))
    keep = np.arange(edge, t.size - edge, step)
    noise = {c: noise_sd(ch) for c, ch in _raw_channels(df).items()}
    return Prepared(kin, sm.sigma_samples(dt), M_d, lateral, keep, p, meta, name, noise, df)


def lateral_inputs(df: pd.DataFrame, q: np.ndarray, p: Params, dt: float, window: float = LATERAL_WINDOW) -> dict:
    """The lateral term's inputs from a recording's ``theta`` and ``psi`` (and C, E, G).

    A longer cubic Savitzky–Golay fit (``window``, s) keeps their noise out of the column
    (errors in variables).  Keys :data:`euc_sim.simulation.effects.LATERAL_INPUTS`, with the
    markers also ``LEAN_INPUTS`` and ``RIDER_MARKER_INPUTS``; (N,) arrays in rad, rad/s, rad/s²
    (m/s² for accelerations).  ``q`` (N, 3): x, γ, φ (m, rad, rad); ``p``: l0 and R; ``dt``, s.
    """
    gamma, l0 = q[:, 1], p.l0
    w = int(round(window / dt)) | 1
    o = 3
    theta, theta_d, theta_dd = processing.savgol_derivatives(df["theta"].to_numpy(float), dt, w, o)
    psi, psi_d, psi_dd = processing.savgol_derivatives(np.unwrap(df["psi"].to_numpy(float)), dt, w, o)
    lateral = {"theta": theta, "theta_d": theta_d, "psi_d": psi_d, "psi_dd": psi_dd}
    lean = _rider_lean(df, psi, gamma, l0, dt, w, o)
    if lean is not None:
        lateral.update(lean=lean[0], lean_d=lean[1], lean_dd=lean[2], theta_dd=theta_dd)
        # G's own acceleration, ẍ and G in the plane through the same fit
        G = df[["G_X", "G_Y", "G_Z"]].to_numpy(float)
        C = df[["C_X", "C_Y", "C_Z"]].to_numpy(float)
        xi, zeta = plane_coordinates(G, C, psi, marker_tilt(df, psi), p.R, gamma, lean[0], l0)
        lateral.update(psi=psi, G_dd=processing.savgol_derivatives(G, dt, w, o)[2],
                       x_dd=processing.savgol_derivatives(np.asarray(q, dtype=float)[:, 0], dt, w, o)[2],
                       xi_dd=processing.savgol_derivatives(xi, dt, w, o)[2],
                       zeta_dd=processing.savgol_derivatives(zeta, dt, w, o)[2])
    return lateral


def marker_tilt(df: pd.DataFrame, psi) -> np.ndarray | None:
    """The EUC's tilt from its own markers, ϑ_E = atan2(−b_y, b_z) with b = T_ψᵀ (E − C), rad,
    in the heading ``psi`` (rad, (N,)); None without the C and E columns (see :func:`_rider_lean`)."""
    cols = ("C_X", "C_Y", "C_Z", "E_X", "E_Y", "E_Z")
    if not set(cols) <= set(df.columns):
        return None
    psi = np.asarray(psi, dtype=float)
    b = processing.moving_frame(df[list(cols[3:])].to_numpy(float) - df[list(cols[:3])].to_numpy(float),
                                psi, np.zeros_like(psi))                  # T_ψᵀ (E − C)
    return np.arctan2(-b[:, 1], b[:, 2])


def _rider_lean(df: pd.DataFrame, psi, gamma, l0: float, dt: float, w: int, o: int):
    """The rider's lateral lean λ relative to the EUC body and its rates (rad, rad/s, rad/s²), or None without C,
    E and G.

    The tilt is taken from the markers, ϑ_E = atan2(−b_y, b_z), b = T_ψᵀ (E − C) (finer than
    the recorded angle); G seen from A in the tilted frame is (h cos λ sin φ, −h sin λ,
    h cos λ cos φ), so λ = atan2(−y_AG, z_AG).
    """
    cols = ("C_X", "C_Y", "C_Z", "E_X", "E_Y", "E_Z", "G_X", "G_Y", "G_Z")
    if not set(cols) <= set(df.columns):
        return None
    C = df[list(cols[:3])].to_numpy(float)
    G = df[list(cols[6:])].to_numpy(float)
    theta_E = marker_tilt(df, psi)
    r = processing.moving_frame(G - C, psi, theta_E)                    # eq. (1)
    lam = np.arctan2(-r[:, 1], r[:, 2] + l0 * np.cos(gamma))
    return processing.savgol_derivatives(lam, dt, w, o)


def _raw_channels(df: pd.DataFrame) -> dict[str, np.ndarray]:
    """Unsmoothed x, γ, φ for the noise estimate (motion capture: φ the lean of C→G in the heading plane, x as C_X)."""
    out = {}
    base = "C" if {"C_X", "C_Y", "C_Z"} <= set(df.columns) else "E"
    out["x"] = df["x" if "x" in df.columns else f"{base}_X"].to_numpy(float)
    out["gamma"] = df["gamma"].to_numpy(float)
    if "phi" in df.columns:
        out["phi"] = df["phi"].to_numpy(float)
    else:
        psi = np.unwrap(df["psi"].to_numpy(float))
        dx = df["G_X"].to_numpy(float) - df[f"{base}_X"].to_numpy(float)
        dy = df["G_Y"].to_numpy(float) - df[f"{base}_Y"].to_numpy(float)
        dz = df["G_Z"].to_numpy(float) - df[f"{base}_Z"].to_numpy(float)
        out["phi"] = np.arctan2(dx * np.cos(psi) + dy * np.sin(psi), dz)
    return out


def noise_sd(y: np.ndarray) -> float:
    """White-noise level of a channel from its third differences (MAD; Δ³ of white noise σ has sd σ√20)."""
    d3 = np.diff(np.asarray(y, float), 3)
    return float(1.4826 * np.median(np.abs(d3 - np.median(d3))) / math.sqrt(20.0))


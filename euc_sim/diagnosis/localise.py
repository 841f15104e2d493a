"""Localisation: windows where the squared residual concentrates, and what it moves with."""

from __future__ import annotations

from typing import Mapping, TypedDict

import numpy as np

from euc_sim.diagnosis.common import DiagnosisError
from euc_sim.diagnosis.prepare import Prepared

__all__ = ["Localisation", "localise", "signals_of", "hot_windows"]


class Localisation(TypedDict):
    """Where a residual concentrates: ``windows`` [[t0, t1], ...] s, the ``share`` of its energy
    inside them, and its Pearson ``correlations`` with each signal by name."""

    windows: list[list[float]]
    share: float | None
    correlations: dict[str, float]


# --- localisation --------------------------------------------------------------------------
def hot_windows(t: np.ndarray, hot: np.ndarray, min_len: float) -> list[list[float]]:
    """Runs of True in ``hot`` lasting at least ``min_len`` s, as [[t0, t1], ...] (s)."""
    edges = np.flatnonzero(np.diff(np.r_[False, np.asarray(hot, bool), False]))
    first, last = edges[::2], edges[1::2] - 1
    return [[float(t[i]), float(t[j])] for i, j in zip(first, last) if t[j] - t[i] >= min_len]


def localise(t: np.ndarray, r: np.ndarray, signals: Mapping[str, np.ndarray],
             smooth: float = 1.0, min_len: float = 0.5) -> Localisation:
    """Where the residual concentrates (its smoothed power above twice its median) and what it moves with.

    Parameters
    ----------
    t, r : numpy.ndarray
        Time (s) and residual (N·m), uniformly sampled.
    signals : mapping of str to numpy.ndarray
        Signals to correlate with, same length.
    smooth : float
        Moving-average length of the residual's power, s.
    min_len : float
        Shortest window, s.

    Returns
    -------
    Localisation
    """
    t = np.asarray(t, float)
    r = np.asarray(r, float)
    if t.size != r.size or t.size < 4:
        raise DiagnosisError(f"t and r must have the same length ≥ 4, got {t.size} and {r.size}")
    dt = float(np.median(np.diff(t)))
    w = max(1, int(round(smooth / dt)))
    power = np.convolve(r ** 2, np.ones(w) / w, mode="same")
    thr = 2.0 * max(float(np.median(power)), 1e-12)
    windows = hot_windows(t, power > thr, min_len)
    inside = np.zeros(t.size, bool)
    for a, b in windows:
        inside |= (t >= a) & (t <= b)
    energy = float(np.sum(r ** 2))
    corr = {}
    for name, s in signals.items():
        s = np.asarray(s, float)
        if s.size != r.size or np.std(s) < 1e-12 or np.std(r) < 1e-12:
            continue
        corr[name] = float(np.corrcoef(s, r)[0, 1])
    return {"windows": windows, "share": float(np.sum(r[inside] ** 2) / energy) if energy > 0 else 0.0,
            "correlations": corr}


def signals_of(prep: Prepared) -> dict[str, np.ndarray]:
    k = prep.keep
    out = {"speed": prep.kin.qd[k, 0], "acceleration": prep.kin.qdd[k, 0], "lean_phi": prep.kin.q[k, 2],
           "pitch_gamma": prep.kin.q[k, 1]}
    if prep.lateral is not None:
        out["tilt_theta"] = prep.lateral["theta"][k]
        out["yaw_rate"] = prep.lateral["psi_d"][k]
    return out



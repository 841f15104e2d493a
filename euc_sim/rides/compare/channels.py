"""The pair fit's other channels: the road's load read through voltage sag, phase current and duty.

Each is turned into the power model's units through the ride's drivetrain constants:
voltage sag (W, V·(E₀ − k_Q·Q − V)/R_int; only where the app computes the current),
signed phase current (N, I_ph = k·F + b fitted on LOG) and measured duty (N, d·V =
K_v·v + r_F·F solved for F).  Each keeps a constant per ride, and the current and duty a
gain on OTHER, so calibration drift is not read as a road difference.  The channels'
rows of one moment are combined by the whitening of their held-out residuals on LOG
(:func:`whitening`), keeping their times and the 30 s blocks.  Study: docs/concealed.md
("Every channel of the log").
"""

from __future__ import annotations

import numpy as np

from euc_sim.rides.drive.pwm import BASE, EXTRA, pwm_columns
from euc_sim.stats import time_blocks

__all__ = ["ALL_CHANNELS", "CHANNELS", "DRIFTING", "MECHANICAL", "readings", "whitening"]

#: Every channel this module can read beside battery power, in the order they are stacked.
ALL_CHANNELS = ("sag", "phase_current", "pwm")
#: The channels measured for the pair fit, the duty left out; the ride's comparison stacks none by
#: default (docs/concealed.md, "Every channel of the log").
CHANNELS = ("sag", "phase_current")
#: Channels whose gain drifts with the motor's temperature (the magnets' flux, the winding's
#: resistance): OTHER's gain is a nuisance.
DRIFTING = ("phase_current", "pwm")
#: The power model's columns that are forces at the wheel times speed, and the differences among them.
MECHANICAL = ("inertia", "rolling", "drag", "grade", "total_mass", "rolling_resistance", "aerodynamic_drag")


def _over(cols: dict, v: np.ndarray, keep=None) -> dict[str, np.ndarray]:
    """Each column over speed (N per unit where the column is W per unit); zero outside ``keep``."""
    return {n: (c / v if keep is None or n in keep else np.zeros_like(c)) for n, c in cols.items()}


def _sag(r) -> tuple | None:
    V, I = r.sig.extra.get("voltage"), r.sig.extra.get("current")
    b = r.drivetrain.battery_coef
    if V is None or I is None or not b or not b.get("R_int", 0.0) > 0:
        return None
    E = b["E0"] - b["k_Q"] * r.drivetrain.charge
    return V * (E - V) / b["R_int"], None, {}, None


def _phase(r, cols: dict, v: np.ndarray, coef: dict, calib: tuple | None):
    I = r.sig.extra.get("phase_current")
    if I is None:
        return None
    if not (I < -0.5).mean() > 0.005:              # a magnitude: its braking rows fold over
        return None
    F = sum(coef.get(n, 0.0) * cols[n] for n in MECHANICAL if n in cols) / v
    if calib is None:                               # LOG: k and b against its own force
        ok = np.isfinite(I) & np.isfinite(F)
        if ok.sum() < 200:
            return None
        calib = tuple(np.linalg.lstsq(np.column_stack([F[ok], np.ones(ok.sum())]), I[ok], rcond=None)[0])
    if not calib[0] > 0:
        return None
    return (I - calib[1]) / calib[0], MECHANICAL, {"calib": calib}, v


def _duty(r, y, coef: dict | None):
    d, V = r.sig.extra.get("pwm"), r.sig.extra.get("voltage")
    if d is None or V is None or not coef or not coef.get("r_F", 0.0) > 0 or r.pwm_note:
        return None
    v = r.sig.v / r.sig.scale.estimate
    names = [n for n in BASE + tuple(EXTRA) if n in coef and n != "r_F"]
    F = y / np.maximum(v, 1e-3)
    rest = pwm_columns(v, F, V, names, coef.get("v_fw", np.inf)) @ np.array([coef[n] for n in names])
    return (d / 100.0 * V - rest) / coef["r_F"], None, {"speed": v / coef["r_F"]}, np.where(v > 1e-3, v, np.nan)


def readings(fit, test, sides: list, channels=CHANNELS) -> dict[str, list[tuple]]:
    """Each channel both rides can give, as rows of the power model's columns in its own unit.

    Parameters
    ----------
    fit, test : RideDrivetrain
        LOG's and OTHER's analyses (LOG's constants calibrate the phase current
        and the duty).
    sides : list of (shared, delta, y) per ride
        The power design's columns at the pair's lag (W per unit, unscaled) and
        its signed battery power, W.
    channels : sequence of str
        Of :data:`ALL_CHANNELS`.

    Returns
    -------
    dict of str -> list of (y, shared, delta, own)
        Per channel, per ride: the reading (W or N), the shared and difference
        columns in its unit, and its own nuisance columns (named per ride).
    """
    out = {}
    calib = None
    for c in channels:
        rows = []
        for k, (r, (sh, de, y)) in enumerate(zip((fit, test), sides)):
            v = np.where(np.abs(r.sig.v) > 1e-3, r.sig.v, np.nan)
            if c == "sag":
                got = _sag(r)
            elif c == "phase_current":
                got = _phase(r, sh, v, fit.mass.coef, calib)
                calib = None if got is None else got[2].pop("calib")
            else:
                got = _duty(r, y, fit.drivetrain.pwm_coef)
            if got is None:
                break
            yc, keep, own, over = got
            if over is not None:
                sh, de = _over(sh, over, keep), _over(de, over, keep)
                if k == 1 and c in DRIFTING:    # OTHER's gain of this channel against LOG's
                    own["scale"] = sum(fit.mass.coef.get(n, 0.0) * x for n, x in sh.items())
            ride = ("log", "other")[k]
            rows.append((yc, sh, de, {f"{c}:{n}_{ride}": x for n, x in
                                      {"offset": np.ones_like(yc), **own}.items()}))
        calib = None
        if len(rows) == 2:
            out[c] = rows
    return out


def _heldout_residuals(t: np.ndarray, Z: np.ndarray, scale: np.ndarray | None = None) -> np.ndarray:
    """Each channel's held-out residual (C, n) over 5 time folds: each channel alone, or with
    ``scale`` all fitted together with one coefficient per column.
    """
    fold = time_blocks(t, 5)
    E = np.zeros(Z.shape[:2])
    for f in range(5):
        test = fold == f
        if not test.any():
            continue
        if scale is None:
            for c, z in enumerate(Z):
                live = np.flatnonzero(np.any(z[:, :-1] != 0, axis=0))
                beta = np.linalg.lstsq(z[~test][:, live], z[~test, -1], rcond=None)[0]
                E[c, test] = z[test, -1] - z[test][:, live] @ beta
        else:
            z = (Z / scale[:, None, None])[:, ~test].reshape(-1, Z.shape[-1])
            beta = np.linalg.lstsq(z[:, :-1], z[:, -1], rcond=None)[0]
            E[:, test] = Z[:, test, -1] - Z[:, test, :-1] @ beta
    return E


def whitening(t: np.ndarray, Z: np.ndarray) -> np.ndarray:
    """``L⁻¹`` (C, C) with LLᵀ = Σ, the covariance of the channels' held-out residuals of their
    shared model on LOG (rows ``Z`` (C, n, p) at times ``t``, each channel first scaled by its
    own residual's RMS): least squares on the combined rows is generalized least squares.
    """
    own = np.sqrt(np.mean(_heldout_residuals(t, Z) ** 2, axis=1))
    own = np.where(np.isfinite(own) & (own > 0), own, 1.0)
    S = np.atleast_2d(np.cov(_heldout_residuals(t, Z, own)))
    S += np.eye(len(S)) * 1e-9 * np.trace(S)
    return np.linalg.inv(np.linalg.cholesky(S))

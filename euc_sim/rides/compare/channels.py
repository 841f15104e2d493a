"""The pair fit's other channels: the road's load read through voltage sag, phase current and duty.

Battery power is one reading of the load a ride puts on the wheel; a log often
holds three more, each turned into the power model's own units through the
constants the ride's drivetrain fit found (:mod:`euc_sim.rides.drive.drivetrain`):

* **voltage sag** (W): the battery's power from its terminal voltage,
  ``V·(E₀ − k_Q·Q − V)/R_int``, each ride through its own open-circuit line
  and internal resistance; the columns are battery power's.  Only where the
  app computes the current (:func:`euc_sim.rides.source.channels.current_from_phase`,
  the caller's choice):
  a measured current's sag repeats battery power with the voltage's noise and
  the pack's drift along the ride (its warming, its charge), which the
  channels' combination would read as information;
* **phase current** (N): the motor's torque, ``I_ph = k·F + b`` with ``k`` and
  ``b`` fitted on LOG against LOG's mechanical force (inertia, rolling, drag,
  climb over speed); the columns are the mechanical ones over speed (copper
  loss and drain are battery power, not torque).  Only a signed phase current:
  a magnitude folds the braking rows over, where a difference moves it the
  other way;
* **duty** (N): ``d·V = K_v·v + r_F·F`` (+ the dead-time and flux-weakening
  terms LOG's fit kept) solved for ``F = P/v``, the force battery power implies,
  with LOG's constants; the columns are every power column over speed.  Only
  a measured duty (one the app does not compute from speed and voltage).

Each channel keeps a constant per ride (a sensor's zero, a pack's state; the
duty also a speed term per ride: the back-EMF constant moves with the magnets'
temperature), and the phase current and the duty a gain on OTHER (LOG's
predicted force on OTHER's rows: the magnets' flux falls 0.1 %/K and the
winding's resistance rises 0.4 %/K as the motor warms along a ride), so a
channel's calibration drift is not read as a road difference: the part of a
difference that scales every force at once is left to battery power.  On real
null pairs without it the phase current named a drag (blitz_4's halves) and a
mass (master_pro_V2_3's halves).  The difference columns carry the same coefficients in every
channel: a difference in mass, rolling or drag has its signature in each.
The channels' rows of one moment are combined by the whitening of their
held-out residuals on LOG (:func:`whitening`: each channel scaled by its own
noise, and what two channels share counted once), so the stacked least
squares weighs each by what it adds; the stacked rows keep their times, so
the pair fit's 30 s blocks hold every channel's rows of those 30 s and stay
the unit of independence of its test (the score test's spread is measured
across blocks).

Study: docs/concealed.md ("Every channel of the log").
"""

from __future__ import annotations

import numpy as np

from euc_sim.rides.drive.drivetrain import charge_drawn
from euc_sim.rides.drive.drivetrain_report import computed_pwm_note
from euc_sim.rides.drive.pwm import BASE, EXTRA, pwm_columns
from euc_sim.stats import time_blocks

__all__ = ["ALL_CHANNELS", "CHANNELS", "DRIFTING", "MECHANICAL", "readings", "whitening"]

#: Every channel this module can read beside battery power, in the order they are stacked.
ALL_CHANNELS = ("sag", "phase_current", "pwm")
#: The channels measured for the pair fit (docs/concealed.md "Every channel of the log"): the duty
#: left out (on real null pairs it names road differences its model's misfit makes).  The ride's
#: comparison stacks none by default: on the shared rides they resolve about as finely as battery
#: power alone (median 0.99) and name more on null pairs.
CHANNELS = ("sag", "phase_current")
#: Channels whose gain drifts with the motor's temperature (the magnets' flux, the winding's
#: resistance): OTHER's gain is a nuisance.
DRIFTING = ("phase_current", "pwm")
#: The power model's columns that are forces at the wheel times speed, and the differences among them.
MECHANICAL = ("inertia", "rolling", "drag", "grade", "total_mass", "rolling_resistance", "aerodynamic_drag")


def _over(cols: dict, v: np.ndarray, keep=None) -> dict[str, np.ndarray]:
    """Each column over speed (N per unit where the column is W per unit); zero outside ``keep``."""
    return {n: (c / v if keep is None or n in keep else np.zeros_like(c)) for n, c in cols.items()}


def _sag(r, y) -> tuple | None:
    V, I = r.sig.extra.get("voltage"), r.sig.extra.get("current")
    b = r.drivetrain.battery_coef
    if V is None or I is None or not b or not b.get("R_int", 0.0) > 0:
        return None

    E = b["E0"] - b["k_Q"] * charge_drawn(r.sig.t, I)
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
    if d is None or V is None or not coef or not coef.get("r_F", 0.0) > 0 or computed_pwm_note(r):
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
                got = _sag(r, y)
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
    """Each channel's held-out residual (C, n): 5 contiguous time folds, each fitted on the rest.

    Without ``scale`` each channel is fitted alone on its live columns; with
    it the channels (each divided by its ``scale``) are fitted together, one
    coefficient per column for all: the misfit of the shared model counts.
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
    """The matrix that whitens the channels' held-out residuals on LOG: ``L⁻¹`` with ``LLᵀ = Σ``.

    Parameters
    ----------
    t : ndarray (n,)
        Row times, s (the same rows in every channel).
    Z : ndarray (C, n, p)
        Each channel's ``[X y]`` rows of LOG.

    Returns
    -------
    ndarray (C, C)
        ``Σ`` is the covariance of the channels' held-out residuals of the
        model they share (one coefficient per column for all channels, each
        channel first scaled by the RMS of its own held-out residual): a
        channel its own fit explains well but the shared model does not (a
        calibration off by a few per cent) counts its misfit as noise.
        Combining the channels' rows by it makes those residuals uncorrelated
        with unit variance: least squares on the stacked rows is generalized
        least squares.
    """
    own = np.sqrt(np.mean(_heldout_residuals(t, Z) ** 2, axis=1))
    own = np.where(np.isfinite(own) & (own > 0), own, 1.0)
    S = np.atleast_2d(np.cov(_heldout_residuals(t, Z, own)))
    S += np.eye(len(S)) * 1e-9 * np.trace(S)
    return np.linalg.inv(np.linalg.cholesky(S))

"""The simulated rider's plan learned from his own run: the closed loop inverted up to the log's band.

The rider's speed amplifies his plan's quicker changes (2–3× at 0.2–0.7 Hz), and the
logged speed is the output of a real rider's riding, not his plan.  So the plan is
learned (model-inverting iterative learning control): :func:`closed_loop_response`
measures H(f) from one run, and :func:`inverse_correction` turns the speed error e(t)
into the plan correction F⁻¹[E(f)/H(f)] up to :func:`filter_band`, where plan and speed
are coherent.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.signal import csd, freqz, savgol_coeffs, welch

from euc_sim.errors import InputError
from euc_sim.rides.grids.signals import sg, window_samples

__all__ = ["filter_band", "closed_loop_response", "inverse_correction", "COHERENCE_MIN", "TREND_WINDOW",
           "SEGMENT_S"]

#: Frequencies where plan and simulated speed are less coherent than this (squared
#: coherence) are not corrected: the response measured there is not the plan's.
COHERENCE_MIN = 0.5
#: s: the trend removed from plan and speed before their spectra (the slow error is
#: corrected as it is, below the spectrum's resolution).
TREND_WINDOW = 30.0
#: s: Welch segment length (resolution 1/SEGMENT_S Hz).
SEGMENT_S = 51.2


def filter_band(rate: float = 10.0, window: float = 1.5, polyorder: int = 2) -> float:
    """Half-power frequency, Hz, of the log's Savitzky–Golay smoothing (``rate`` Hz, ``window`` s;
    0.72 Hz for the ride defaults).
    """
    n = window_samples(window, rate, polyorder)
    w, h = freqz(savgol_coeffs(n, polyorder), worN=8192, fs=rate)
    below = np.flatnonzero(np.abs(h) < 2 ** -0.5)
    return float(w[below[0]]) if below.size else rate / 2


def _detrend(x: np.ndarray, rate: float) -> np.ndarray:
    return x - sg(x, np.zeros(x.size, int), rate, TREND_WINDOW, 1)


def closed_loop_response(t: np.ndarray, plan: np.ndarray, v_sim: np.ndarray):
    """The rider's closed-loop response from ``plan`` to ``v_sim`` (m/s, on uniform ``t`` s): f (Hz),
    H (complex, speed over plan) and the squared coherence, by Welch spectra of the detrended series.
    """
    t = np.asarray(t, float)
    rate = 1.0 / float(np.median(np.diff(t)))
    x = _detrend(np.asarray(plan, float), rate)
    y = _detrend(np.asarray(v_sim, float), rate)
    nper = min(x.size, int(round(SEGMENT_S * rate)))
    f, Pxy = csd(x, y, fs=rate, nperseg=nper)
    _, Pxx = welch(x, fs=rate, nperseg=nper)
    _, Pyy = welch(y, fs=rate, nperseg=nper)
    with np.errstate(invalid="ignore", divide="ignore"):
        H = np.where(Pxx > 0, Pxy / Pxx, 1.0)
        coh = np.where(Pxx * Pyy > 0, np.abs(Pxy) ** 2 / (Pxx * Pyy), 0.0)
    return f, H, coh


def inverse_correction(t: np.ndarray, plan: np.ndarray, v_sim: np.ndarray, error: np.ndarray,
                       band: float) -> np.ndarray:
    """The plan correction removing ``error`` (target − simulated, m/s) through the inverted loop, m/s.

    Below the spectrum's resolution the error is added as it is; up to ``band`` Hz it is
    divided by H(f) where coherent (:data:`COHERENCE_MIN`), tapered to zero at 1.5·``band``.
    The error is mirrored before the FFT so its ends do not wrap.
    """
    if not (math.isfinite(band) and band > 0):
        raise InputError(f"band must be a positive number of Hz, got {band!r}")
    t = np.asarray(t, float)
    err = np.asarray(error, float)
    n = t.size
    rate = 1.0 / float(np.median(np.diff(t)))
    f, H, coh = closed_loop_response(t, plan, v_sim)
    nfft = 1 << int(math.ceil(math.log2(2 * n)))
    F = np.fft.rfftfreq(nfft, 1.0 / rate)
    Hf = np.interp(F, f, H.real) + 1j * np.interp(F, f, H.imag)
    ok = np.interp(F, f, coh) >= COHERENCE_MIN
    slow = F < f[1] if f.size > 1 else np.ones(F.size, bool)
    taper = np.clip((1.5 * band - F) / (0.5 * band), 0.0, 1.0)
    gain = np.where(slow, 1.0, np.where(ok & (np.abs(Hf) > 0), taper / np.where(Hf == 0, 1.0, Hf), 0.0))
    E = np.fft.rfft(np.concatenate([err, err[::-1]]), nfft)
    return np.fft.irfft(E * gain, nfft)[:n]

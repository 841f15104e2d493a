"""What a ride log shows of its rider: the channels, their bands and the features the rider is fitted to.

:func:`log_channels` puts the log's battery power, motor torque and pitch on a uniform
grid; :func:`band_features` splits a channel by Savitzky–Golay smoothers of
:data:`BAND_WINDOWS` into four bands and gives their log RMS (level and spectrum);
:func:`fit_windows` picks the stretches of the ride the simulated rider rides.  The fit
itself (simulated moments on a response surface) is :mod:`euc_sim.rides.rider_fit`.
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from euc_sim.rides.signals import RideAssumptions, as_log, resample, sg

__all__ = ["BAND_WINDOWS", "RiderFitError", "log_channels", "band_features", "fit_windows"]

#: Savitzky–Golay windows, s, whose differences split a channel into bands.
BAND_WINDOWS = (0.7, 1.5, 3.0, 6.0)


class RiderFitError(ValueError):
    """A ride or a setting the rider cannot be fitted on; the message names it."""


def log_channels(log, assumptions: RideAssumptions = RideAssumptions(), rate: float = 10.0,
                 max_gap: float = 1.0) -> pd.DataFrame:
    """The log's rider channels on a uniform grid (split at gaps over ``max_gap`` s).

    Parameters
    ----------
    log : RideLog or path
    assumptions : RideAssumptions
        ``torque_constant`` (N·m/A) turns phase current into torque.
    rate : float
        Grid rate, Hz.
    max_gap : float
        Longest interval between readings bridged, s (:func:`euc_sim.rides.signals.resample`).

    Returns
    -------
    pandas.DataFrame
        ``t`` s, ``segment``, ``v`` m/s, ``P`` W (battery power), and where the log has
        them ``M`` N·m (``torque`` column, else phase current × k_t) and ``pitch`` rad
        (``tilt``, any sign and offset).  ``attrs["stamps"]``: the log's time stamps, s.
    """
    log = as_log(log)
    raw, _ = resample(log, rate, max_gap=max_gap)
    out = {"t": raw["t"].to_numpy(), "segment": raw["segment"].to_numpy(), "v": raw["v"].to_numpy()}
    if log.has("voltage") and log.has("current"):
        out["P"] = raw["voltage"].to_numpy() * raw["current"].to_numpy()
    elif log.has("power"):
        out["P"] = raw["power"].to_numpy()
    else:
        raise RiderFitError(f"{log.path}: no voltage and current and no power column: the rider is "
                            f"fitted to battery power")
    if log.has("torque"):
        out["M"] = raw["torque"].to_numpy()
    elif log.has("phase_current") and assumptions.torque_constant is not None:
        out["M"] = raw["phase_current"].to_numpy() * assumptions.torque_constant
    if log.has("tilt"):
        out["pitch"] = raw["tilt"].to_numpy()
    frame = pd.DataFrame(out)
    frame.attrs["stamps"] = log.data["t"].to_numpy(float)
    return frame


def band_features(y: np.ndarray, segment: np.ndarray, rate: float, rows: np.ndarray,
                  block: np.ndarray | None = None) -> np.ndarray:
    """Log RMS of a channel's :data:`BAND_WINDOWS` bands over ``rows`` (or per block).

    Parameters
    ----------
    y : numpy.ndarray
        Channel on the uniform grid (any unit u).
    segment : numpy.ndarray of int
        Segment labels (the smoothers never cross one).
    rate : float
        Hz.
    rows : numpy.ndarray of bool
        Rows the RMS is taken over.
    block : numpy.ndarray of int, optional
        Block label of each row: then the mean squares per block are returned.

    Returns
    -------
    numpy.ndarray
        (4,) log RMS (log of u), or (n_blocks, 4) mean squares (u²) with ``block``.
    """
    levels = [np.asarray(y, float)] + [sg(y, segment, rate, w, 2) for w in BAND_WINDOWS]
    bands = np.stack([levels[i] - levels[i + 1] for i in range(len(BAND_WINDOWS))], axis=1)
    ok = rows & np.isfinite(bands).all(axis=1)
    if ok.sum() < 2:
        raise RiderFitError(f"band features need at least 2 finite rows, got {int(ok.sum())}")
    if block is None:
        return 0.5 * np.log(np.mean(bands[ok] ** 2, axis=0))
    labels = np.unique(block[ok])
    return np.stack([np.mean(bands[ok & (block == b)] ** 2, axis=0) for b in labels])


def fit_windows(channels: pd.DataFrame, n: int = 3, length: float = 60.0, v_min: float = 2.0,
                lead: float = 8.0) -> list[tuple[float, float]]:
    """``n`` windows of the ride, one per equal share of it, for the rider to ride.

    A window is ``length`` s of one unbroken segment in which the speed stays above
    ``v_min`` m/s, at least ``lead`` s after the log's start (the simulation's run-in);
    in each share of the ride the one nearest the share's middle is taken.

    Returns
    -------
    list of (t0, t1)
        s; fewer than ``n`` when the ride has fewer such stretches.

    Raises
    ------
    RiderFitError
        when no window fits.
    """
    t, v, seg = (channels[c].to_numpy() for c in ("t", "v", "segment"))
    rate = 1.0 / float(np.median(np.diff(t)))
    L = int(round(length * rate))
    step = max(1, int(round(5.0 * rate)))
    starts = [i for i in range(0, t.size - L, step) if t[i] >= lead and seg[i] == seg[i + L]
              and np.all(v[i:i + L + 1] > v_min)]
    if not starts:
        raise RiderFitError(f"no {length:g} s stretch of the ride above {v_min:g} m/s without a gap: "
                            f"the rider cannot be fitted (try a shorter window length)")
    edges = np.linspace(t[0], t[-1], n + 1)
    out = []
    for k in range(n):
        mid = 0.5 * (edges[k] + edges[k + 1])
        inside = [i for i in starts if edges[k] <= t[i] and t[i] + length <= edges[k + 1] + length / 2]
        if inside:
            i = min(inside, key=lambda j: abs(t[j] + length / 2 - mid))
            if not out or t[i] >= out[-1][1]:
                out.append((float(t[i]), float(t[i + L])))
    return out or [(float(t[starts[0]]), float(t[starts[0] + L]))]

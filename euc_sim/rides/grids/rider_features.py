"""What a ride log shows of its rider: the channels, their bands and the features the rider is fitted to.

:func:`log_channels` puts the log's battery power, motor torque and pitch on a uniform
grid; :func:`band_features` splits a channel by Savitzky–Golay smoothers of
:data:`BAND_WINDOWS` into eight bands and gives their log RMS (level and spectrum);
:func:`fit_windows` picks the stretches of the ride the simulated rider rides.  The fit
itself (simulated moments on a response surface) is :mod:`euc_sim.rides.rider.rider_fit`.
"""

from __future__ import annotations

import math

import numpy as np
import pandas as pd

from euc_sim.errors import InputError
from euc_sim.rides.grids.signals import RideAssumptions, battery_power_of, ride_grid, sg
from euc_sim.rides.source.gaps import GAP_POLICY, GapPolicy
from euc_sim.rides.source.ride import Ride

__all__ = ["BAND_WINDOWS", "RiderFitError", "log_channels", "reading_step", "band_features", "band_ratio_db",
           "fit_windows"]

#: Savitzky–Golay windows, s, whose differences split a channel into eight leaky bands, ~2 Hz
#: down to ~0.1 Hz (docs/rider_calibration.md).
BAND_WINDOWS = (0.5, 0.7, 1.0, 1.5, 2.1, 3.0, 4.2, 6.0)


class RiderFitError(InputError):
    """A ride or a setting the rider cannot be fitted on; the message names it."""


def log_channels(log: Ride, assumptions: RideAssumptions = RideAssumptions(), rate: float = GAP_POLICY.rate,
                 max_gap: float = GAP_POLICY.bridge) -> pd.DataFrame:
    """The log's rider channels on the ride's grid (``rate`` Hz, split at gaps over ``max_gap`` s).

    Returns
    -------
    pandas.DataFrame
        ``t`` s, ``segment``, ``v`` m/s, ``P`` W, and where logged ``M`` N·m (``torque``,
        else phase current × ``assumptions.torque_constant``) and ``pitch`` rad (``tilt``).
        ``attrs``: ``stamps`` (the log's times, s), ``quantum`` (the step ``M`` and ``pitch``
        are written in, :func:`reading_step`), ``gaps`` (``max_gap``, ``count`` and ``median``
        of the longer intervals, s).
    """
    raw, _ = ride_grid(log, GapPolicy(bridge=max_gap, rate=rate))
    out = {"t": raw["t"].to_numpy(), "segment": raw["segment"].to_numpy(), "v": raw["v"].to_numpy()}
    out["P"] = battery_power_of(raw)[0]
    if out["P"] is None:
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
    gaps = np.diff(frame.attrs["stamps"])
    frame.attrs["gaps"] = {"max_gap": float(max_gap), "count": int(np.sum(gaps > max_gap)),
                           "median": float(np.median(gaps[gaps > max_gap])) if np.any(gaps > max_gap) else 0.0}
    d = log.data
    steps = {"pitch": (d["tilt"], 1.0) if log.has("tilt") else None,
             "M": (d["torque"], 1.0) if log.has("torque") else
             ((d["phase_current"], assumptions.torque_constant) if "M" in out else None)}
    frame.attrs["quantum"] = {c: q * f for c, v in steps.items() if v is not None
                              for col, f in [v] for q in [reading_step(col.to_numpy(float))] if q}
    return frame


def reading_step(x: np.ndarray, share: float = 0.99) -> float | None:
    """The step a column is written in (0.1° pitch), or None: the smallest difference between
    distinct values, when at least ``share`` of the readings are whole multiples of it.
    """
    x = np.asarray(x, float)
    x = x[np.isfinite(x)]
    u = np.unique(x)
    if u.size < 3:
        return None
    q = float(np.min(np.diff(u)))
    if not q > 0:
        return None
    r = x / q
    return q if np.mean(np.abs(r - np.round(r)) < 1e-6 * np.maximum(1.0, np.abs(r)) + 1e-6) >= share else None


def band_features(y: np.ndarray, segment: np.ndarray, rate: float, rows: np.ndarray,
                  block: np.ndarray | None = None, windows: tuple | None = None) -> np.ndarray:
    """Log RMS of a channel's :data:`BAND_WINDOWS` bands over ``rows`` (or per block).

    Band k is S_{k-1} − S_k, the difference of successive Savitzky–Golay smoothers (S_{-1}
    the channel ``y`` itself, unit u), never crossing a ``segment``; ``rate`` Hz.

    Returns
    -------
    numpy.ndarray
        (bands,) log RMS (log of u), or with ``block`` labels (n_blocks, bands) mean squares (u²).
    """
    bands = _bands(y, segment, rate, windows)
    ok = rows & np.isfinite(bands).all(axis=1)
    if ok.sum() < 2:
        raise RiderFitError(f"band features need at least 2 finite rows, got {int(ok.sum())}")
    if block is None:
        return 0.5 * np.log(np.mean(bands[ok] ** 2, axis=0))
    labels = np.unique(block[ok])
    return np.stack([np.mean(bands[ok & (block == b)] ** 2, axis=0) for b in labels])


def band_ratio_db(y: np.ndarray, y_ref: np.ndarray, segment: np.ndarray, rate: float,
                  rows: np.ndarray) -> dict:
    """How a channel's level and spectrum differ from a reference's: the ratio of their bands' RMS, dB.

    Both channels get :func:`band_features` over the same ``rows`` (those where both are
    finite; a stretch where either is NaN splits its segment); band k's ratio is 20·log10(RMS_k(y) / RMS_k(y_ref)).  A simulated signal with
    the right level and spectrum but an independent realisation of its noise scores 0 dB
    in every band, where its RMS error would be √2 times either signal's RMS.

    Parameters
    ----------
    y, y_ref : numpy.ndarray
        The channel and its reference (a simulated and a logged battery power), on one
        uniform grid, same unit.
    segment : numpy.ndarray of int
        Segment labels (the smoothers never cross one).
    rate : float
        Hz.
    rows : numpy.ndarray of bool
        Rows compared.

    Returns
    -------
    dict
        ``windows_s``: the :data:`BAND_WINDOWS` (s) splitting the bands, fastest first;
        ``ratio_dB``: (bands,) list; ``rms_dB``: their root mean square, dB (0: the same
        level and spectrum).

    Raises
    ------
    RiderFitError
        when fewer than 2 rows have both channels finite in every band.
    """
    y, y_ref = np.asarray(y, float), np.asarray(y_ref, float)
    both = np.isfinite(y) & np.isfinite(y_ref)
    # a run of rows where either is NaN (a simulation after its fall) is a segment of its own,
    # so that the smoothers neither cross it nor spread its NaN
    seg = np.cumsum(np.r_[0, (np.diff(np.asarray(segment)) != 0) | (np.diff(both.astype(int)) != 0)])
    b, b_ref = (_bands(np.where(both, x, 0.0), seg, rate) for x in (y, y_ref))
    use = np.asarray(rows, bool) & both & np.isfinite(b).all(axis=1) & np.isfinite(b_ref).all(axis=1)
    if use.sum() < 2:
        raise RiderFitError(f"band features need at least 2 finite rows, got {int(use.sum())}")
    ratio = 10.0 / math.log(10.0) * np.log(np.mean(b[use] ** 2, axis=0) / np.mean(b_ref[use] ** 2, axis=0))
    return {"windows_s": list(BAND_WINDOWS), "ratio_dB": [float(r) for r in ratio],
            "rms_dB": float(np.sqrt(np.mean(ratio ** 2)))}


def _bands(y: np.ndarray, segment: np.ndarray, rate: float, windows: tuple | None = None) -> np.ndarray:
    """(rows, bands) the channel's bands: band k is S_{k-1} − S_k of the smoothers of ``windows``."""
    windows = BAND_WINDOWS if windows is None else tuple(windows)
    levels = [np.asarray(y, float)] + [sg(y, segment, rate, w, 2) for w in windows]
    return np.stack([levels[i] - levels[i + 1] for i in range(len(windows))], axis=1)


def fit_windows(channels: pd.DataFrame, n: int = 3, length: float = 60.0, v_min: float = 2.0,
                lead: float = 8.0, spacing: float = 1.5) -> list[tuple[float, float]]:
    """Up to ``n`` windows (t0, t1) s of the ride, in time order, for the rider to ride.

    A window is ``length`` s of one segment with the speed above ``v_min`` m/s, at least
    ``lead`` s after the start; the ride is tiled from its start, ``spacing`` s between
    tiles, and ``n`` tiles spread evenly are kept.  :class:`RiderFitError` when none fits.
    """
    t, v, seg = (channels[c].to_numpy() for c in ("t", "v", "segment"))
    rate = 1.0 / float(np.median(np.diff(t)))
    L = int(round(length * rate))
    good = (t >= lead) & (np.nan_to_num(v, nan=-np.inf) > v_min)
    gap = int(math.ceil(spacing * rate - 1e-9))
    bad = np.concatenate([[0], np.cumsum(~good)])              # bad samples before index i
    tiles, i = [], 0
    while i + L < t.size:
        if bad[i + L + 1] - bad[i] == 0 and seg[i] == seg[i + L]:
            tiles.append((float(t[i]), float(t[i + L])))
            i += L + gap
        else:
            i += 1
    if not tiles:
        raise RiderFitError(_no_window(t, good, seg, length, v_min, channels.attrs.get("gaps")))
    if len(tiles) > n:
        tiles = [tiles[k] for k in np.unique(np.round(np.linspace(0, len(tiles) - 1, n)).astype(int))]
    return tiles


def _no_window(t, good, seg, length: float, v_min: float, gaps: dict | None) -> str:
    """Why no window fits: the longest stretch, and the gaps between readings that split the ride."""
    run = longest = 0.0
    for k in range(1, t.size):
        run = run + (t[k] - t[k - 1]) if good[k] and good[k - 1] and seg[k] == seg[k - 1] else 0.0
        longest = max(longest, run)
    text = (f"no {length:g} s stretch of the ride above {v_min:g} m/s without a gap: the longest is "
            f"{longest:.1f} s")
    if gaps and gaps["count"]:
        text += (f"; the log's readings stop for more than {gaps['max_gap']:g} s {gaps['count']} times "
                 f"(median {gaps['median']:.2g} s), which splits the ride into {len(np.unique(seg))} pieces")
    return text + ": the rider cannot be fitted"

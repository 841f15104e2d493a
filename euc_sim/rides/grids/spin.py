"""The wheel spinning off the ground in a ride log: lifted at a stop, or fallen with the motor on.

:func:`free_spin` finds such rows from the log's stamps and speed alone; every grid of a
ride leaves them out and the summary says them apart (:func:`spin_json`).  See
docs/ride_model.md, "The wheel spinning free".
"""

from __future__ import annotations

import numpy as np

from euc_sim.rides.source.gaps import GAP_POLICY

__all__ = ["free_spin", "spin_rows", "spin_json", "SPIN_ACCEL", "SPIN_TOL_MPS"]

#: Acceleration or braking no tyre on the road carries, m/s² (grip μ ≈ 1).
SPIN_ACCEL = 9.81
#: Speed beyond the tyre's reach, m/s, that makes a row a free spin (timestamp jitter stays below).
SPIN_TOL_MPS = 2.5


def _reach(t: np.ndarray, v: np.ndarray, bridge_s: float) -> np.ndarray:
    """The highest speed a tyre reaches at each row from the rows before it, m/s (restarting
    after an interval over ``bridge_s`` s): r_i = a·t_i + min_{j ≤ i}(v_j − a·t_j), a =
    :data:`SPIN_ACCEL`, a running minimum.
    """
    x = np.where(np.isfinite(v), v - SPIN_ACCEL * t, np.inf)
    starts = np.flatnonzero(np.r_[True, np.diff(t) > bridge_s])
    out = np.empty(v.size)
    for a, b in zip(starts, np.r_[starts[1:], v.size]):
        out[a:b] = np.minimum.accumulate(x[a:b])
    return out + SPIN_ACCEL * t


def free_spin(t: np.ndarray, v: np.ndarray, bridge_s: float = GAP_POLICY.bridge) -> np.ndarray:
    """Rows where the wheel spins off the ground: a speed (``v`` |m/s| at ``t`` s) no tyre
    reaches from the rows before or after it (more than :data:`SPIN_TOL_MPS` beyond
    :data:`SPIN_ACCEL`), with the spin-up before and the coast-down after; no reach carried
    across an interval over ``bridge_s`` s.
    """
    t, v = np.asarray(t, float), np.asarray(v, float)
    if v.size == 0:
        return np.zeros(0, bool)
    fwd = _reach(t, v, bridge_s)
    bwd = _reach(-t[::-1], v[::-1], bridge_s)[::-1]
    spin = np.isfinite(v) & ((v > fwd + SPIN_TOL_MPS) | (v > bwd + SPIN_TOL_MPS))
    return _whole_spins(spin, np.nan_to_num(v))


def spin_rows(data) -> np.ndarray:
    """:func:`free_spin` of a log's rows (``data``: a frame with ``t``, s, and ``v``, m/s)."""
    return free_spin(data["t"].to_numpy(float), np.abs(data["v"].to_numpy(float)))


def _whole_spins(seed: np.ndarray, v: np.ndarray) -> np.ndarray:
    """``seed`` grown by each spin's coast-down after it and spin-up before it (the speed
    falling, or rising, row after row above the speed it started from or ends at); a run
    whose top is not above both its neighbours' speeds by :data:`SPIN_TOL_MPS` (a step in
    the log, a sudden stop) is no spin."""
    out = np.zeros_like(seed)
    edges = np.flatnonzero(np.diff(np.r_[0, seed.astype(int), 0]))
    for a, b in zip(edges[::2], edges[1::2]):
        base = v[a - 1] if a > 0 else 0.0
        while b < v.size and not seed[b] and v[b] < v[b - 1] and v[b] > base + SPIN_TOL_MPS:
            b += 1
        after = v[b] if b < v.size else 0.0
        while a > 0 and not seed[a - 1] and v[a - 1] < v[a] and v[a - 1] > after + SPIN_TOL_MPS:
            a -= 1
        top, before = float(v[a:b].max()), (v[a - 1] if a > 0 else 0.0)
        if top > before + SPIN_TOL_MPS and top > after + SPIN_TOL_MPS:
            out[a:b] = True
    return out


def spin_json(t: np.ndarray, v: np.ndarray, spin: np.ndarray) -> dict | None:
    """``{"count", "total_s", "speed_max_mps", "at_s"}`` of the free spins, or None without one."""
    if not spin.any():
        return None
    i = int(np.flatnonzero(spin)[np.argmax(v[spin])])
    runs = np.flatnonzero(np.diff(np.r_[0, spin.astype(int), 0]))
    total = sum(float(t[min(b, t.size - 1)] - t[max(a - 1, 0)]) for a, b in zip(runs[::2], runs[1::2]))
    return {"count": int(runs.size // 2), "total_s": total, "speed_max_mps": float(v[i]), "at_s": float(t[i])}

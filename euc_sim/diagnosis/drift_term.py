"""The candidate term of ``cog_height_drift``: h(t) = h + θ·g(t), g a smooth shape the data choose.

Shapes (:func:`choose_shape`): a half-cosine ramp or 1 − cos dip of any start and length
(:data:`SHAPE_LENGTHS`; start and length count two BIC parameters), the catalog's 12 s
sine, or a slow wander (:func:`wander_basis`, zero mean so h and the drift do not alias).
To first order r ≈ −∂r/∂h · Δh(t) + κ·F[R Q_x + Q_γ + Q_φ](Q_drift(ḣ, ḧ)), the second part
G's inertial forces along the rider's axis (:func:`euc_sim.simulation.drift.drift_forces`).
The estimate is the peak-to-peak Δh, its se by the delta method; see docs/diagnosis.md.
"""

from __future__ import annotations

import numpy as np

from euc_sim.diagnosis.localise import hot_windows
from euc_sim.diagnosis.prepare import Prepared
from euc_sim.model import analytic
from euc_sim.model.parameters import Params
from euc_sim.simulation import drift

__all__ = ["WANDER_RESOLUTION", "wander_basis", "shape_profile", "choose_shape",
           "drift_columns", "drift_curve", "peak_to_peak", "unit_shape_limit", "drift_windows",
           "blind_windows"]

#: Resolution of the drift's basis, s: a crouch or a stand-up takes one to a few
#: seconds; finer terms would follow the rider's sway (the residual's own band).
WANDER_RESOLUTION = 4.0


def wander_basis(t: np.ndarray, t0: float, t1: float, spacing: float = WANDER_RESOLUTION,
                 derivative: int = 0) -> np.ndarray:
    """Half-range cosines cos(jπ(t − t0)/(t1 − t0)), j = 1 … round((t1 − t0)/``spacing``), or a derivative, at
    ``t`` (s): (n, k).

    Global and zero-mean, so every coefficient is fixed by the whole ride and a held-out
    block is interpolated, not extrapolated.
    """
    L = float(t1 - t0)
    k = max(int(round(L / spacing)), 2)
    j = np.arange(1, k + 1)
    w = j * np.pi / L
    u = np.clip(np.asarray(t, float), t0, t1)[:, None] - t0
    if derivative == 0:
        return np.cos(w * u)
    if derivative == 1:
        return -w * np.sin(w * u)
    if derivative == 2:
        return -(w ** 2) * np.cos(w * u)
    raise ValueError(f"derivative must be 0, 1 or 2, got {derivative!r}")


#: Lengths (s) of the ramp and dip shapes scanned, and the step of their start (s).
SHAPE_LENGTHS = (2.0, 3.0, 4.0, 6.0, 8.0)
START_STEP = 1.0


def shape_profile(shape: dict, t: np.ndarray, derivative: int = 0) -> np.ndarray:
    """Unit profile g(t) (or ġ, g̈) of a drift shape, (n, k).

    ``{"kind": "ramp"|"dip", "start", "length"}`` (s): one column, unit peak to peak;
    ``{"kind": "sine"}``: the 12 s sine and cosine (½ each); ``{"kind": "smooth", "span": (t0, t1)}``:
    :func:`wander_basis`.
    """
    t = np.asarray(t, float)
    kind = shape["kind"]
    if kind == "smooth":
        return wander_basis(t, *shape["span"], derivative=derivative)
    if kind == "sine":
        w = 2.0 * np.pi / 12.0
        base = [np.sin(w * t), np.cos(w * t)]
        if derivative == 1:
            base = [w * np.cos(w * t), -w * np.sin(w * t)]
        elif derivative == 2:
            base = [-w * w * np.sin(w * t), -w * w * np.cos(w * t)]
        return 0.5 * np.column_stack(base)
    L = shape["length"]
    if derivative == 0:
        return _unit_profiles(kind, L, np.array([shape["start"]], float), t)
    u = (t - shape["start"]) / L
    inside = (u > 0.0) & (u < 1.0)
    f = np.pi if kind == "ramp" else 2.0 * np.pi
    if derivative == 1:
        g = np.where(inside, 0.5 * f / L * np.sin(f * u), 0.0)
    else:
        g = np.where(inside, 0.5 * (f / L) ** 2 * np.cos(f * u), 0.0)
    return g[:, None]


def choose_shape(t: np.ndarray, y: np.ndarray, drdh: np.ndarray, n_eff: float,
                 given: np.ndarray | None = None) -> dict:
    """The shape whose first-order term −∂r/∂h·g(t) best explains ``y`` with h free, by BIC with ``n_eff``.

    ``t``, ``y``, ``drdh``: the stacked residual's times, values and ∂r/∂h; ``given``: columns
    (n, k) of other effects fitted beside every shape.
    """
    t0, t1 = float(np.min(t)), float(np.max(t))
    base = drdh[:, None] if given is None or given.size == 0 else np.column_stack([drdh, given])
    # the base fitted with every shape: both projected off the base once (Frisch-Waugh-Lovell)
    Qb, _ = np.linalg.qr(base)
    y_r = y - Qb @ (Qb.T @ y)
    yy = float(y_r @ y_r)
    best, best_crit = None, np.inf
    for shape in ({"kind": "sine"}, {"kind": "smooth", "span": (t0, t1)}):     # groups of columns
        G = -drdh[:, None] * shape_profile(shape, t)
        G_r = G - Qb @ (Qb.T @ G)
        coef, *_ = np.linalg.lstsq(G_r, y_r, rcond=None)
        rss = float(np.sum((y_r - G_r @ coef) ** 2))
        crit = n_eff * np.log(max(rss, 1e-300)) + G.shape[1] * np.log(n_eff)
        if crit < best_crit:
            best, best_crit = shape, crit
    for kind in ("ramp", "dip"):                          # one column each, every start at once
        for L in SHAPE_LENGTHS:
            starts = np.arange(t0, t1 - L + 1e-9, START_STEP)
            if starts.size == 0:
                continue
            G = -drdh[:, None] * _unit_profiles(kind, L, starts, t)
            G_r = G - Qb @ (Qb.T @ G)
            gg = np.einsum("ij,ij->j", G_r, G_r)
            gy = G_r.T @ y_r
            rss = yy - np.where(gg > 1e-300, gy ** 2 / np.maximum(gg, 1e-300), 0.0)
            crit = n_eff * np.log(np.maximum(rss, 1e-300)) + 3 * np.log(n_eff)   # start and length chosen too
            j = int(np.argmin(crit))
            if crit[j] < best_crit:
                best, best_crit = {"kind": kind, "start": float(starts[j]), "length": float(L)}, float(crit[j])
    return best


def _unit_profiles(kind: str, L: float, starts: np.ndarray, t: np.ndarray) -> np.ndarray:
    """:func:`shape_profile` of a ramp or dip of length ``L`` for every start at once, (n, m)."""
    u = (np.asarray(t, float)[:, None] - starts[None, :]) / L
    f = np.pi if kind == "ramp" else 2.0 * np.pi
    g = 0.5 * (1.0 - np.cos(f * np.clip(u, 0.0, 1.0)))
    return g if kind == "ramp" else np.where((u > 0.0) & (u < 1.0), g, 0.0)


def drift_columns(prep: Prepared, p: Params, h0: float, drdh: np.ndarray, has_w: bool,
                  shape: dict) -> np.ndarray:
    """Stacked residual columns of a drift ``shape`` (per unit θ_j, m of Δh), with the ḣ terms.

    ``h0`` (m): where the columns are evaluated; ``drdh``: ∂r/∂h there, N·m/m; ``has_w``: the
    wheel row is stacked below.
    """
    kin = prep.kin
    k = prep.keep
    B = shape_profile(shape, kin.t[k])
    Bd = shape_profile(shape, kin.t, derivative=1)
    Bdd = shape_profile(shape, kin.t, derivative=2)
    ph = p.replace(h=h0)
    kappa = analytic.residual_gain(ph, kin.q[k])
    nk = k.size
    cols = []
    for j in range(B.shape[1]):
        Q = drift.drift_forces(ph, kin.q, kin.qd, h0, Bd[:, j], Bdd[:, j])
        kin_col = -drdh[:nk] * B[:, j] + kappa * prep.filtered(analytic.moment_about_contact(ph, Q))
        if has_w:
            wh = -drdh[nk:] * B[:, j] + p.R * prep.filtered(Q[:, 0])
            cols.append(np.concatenate([kin_col, wh]))
        else:
            cols.append(kin_col)
    return np.column_stack(cols)


def drift_curve(t: np.ndarray, shape: dict, theta: np.ndarray, cov: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Δh(t) (m) and, from θ's covariance, its standard error at each time (m)."""
    B = shape_profile(shape, t)
    return B @ theta, np.sqrt(np.maximum(np.einsum("ij,jk,ik->i", B, cov, B), 0.0))


def peak_to_peak(shape: dict, span: tuple, theta: np.ndarray, cov: np.ndarray) -> tuple[float, float]:
    """max Δh − min Δh over the recording's ``span`` (s), m, and its standard error (delta method, m)."""
    grid = np.linspace(span[0], span[1], 801)
    B = shape_profile(shape, grid)
    dh = B @ theta
    g = B[int(np.argmax(dh))] - B[int(np.argmin(dh))]
    return float(np.ptp(dh)), float(np.sqrt(max(g @ cov @ g, 0.0)))


def unit_shape_limit(shape: dict, span: tuple, theta: np.ndarray, cov: np.ndarray, min_t: float) -> float:
    """Smallest peak-to-peak change of this shape the selection would accept, m: Δ = √((min_t² + k − 1) / sᵀC⁻¹s),
    s the unit shape of ``theta``."""
    ptp, _ = peak_to_peak(shape, span, theta, np.zeros((theta.size, theta.size)))
    if ptp <= 0:
        return float("inf")
    s = theta / ptp
    info = float(s @ np.linalg.pinv(cov) @ s)
    return float(np.sqrt((min_t ** 2 + theta.size - 1) / info)) if info > 0 else float("inf")


def drift_windows(t: np.ndarray, shape: dict, theta: np.ndarray, share: float = 0.25,
                  min_len: float = 0.5) -> list[list[float]]:
    """Where h changes: |dΔh/dt| above ``share`` of its maximum, windows of at least ``min_len`` s."""
    rate = np.abs(shape_profile(shape, t, derivative=1) @ theta)
    hot = rate >= share * float(np.max(rate)) if np.max(rate) > 0 else np.zeros(t.size, bool)
    return hot_windows(t, hot, min_len)


#: Time step of the placements scanned by :func:`blind_windows`, s.
BLIND_STEP = 0.5


def blind_windows(t: np.ndarray, drdh: np.ndarray, floor_rms: float, tau_int: float, min_t: float,
                  dh_max: float) -> list[list[float]]:
    """Where even the largest plausible drift would stay hidden: [[t0, t1], ...], s.

    A drift placed at [a, b] (a dip of each :data:`SHAPE_LENGTHS`, or a ramp from a) has
    first-order term −∂r/∂h·g(t) and is nameable from ``min_t`` σ √(τ / Σ(∂r/∂h g)²); each
    window is a longest interval holding no placement seen at ``dh_max`` (m).  ``t``, ``drdh``:
    times (s) and ∂r/∂h (N·m/m) of the stacked residual; ``floor_rms``: noise floor, N·m;
    ``tau_int``: its correlation time, samples.
    """
    t = np.asarray(t, float)
    t0, t1 = float(np.min(t)), float(np.max(t))
    visible = []                         # (start, end) of every placement this recording could see
    for L in SHAPE_LENGTHS:
        for a in np.arange(t0, t1 - L + 1e-9, BLIND_STEP):
            for kind, end in (("dip", a + L), ("ramp", t1)):
                g = shape_profile({"kind": kind, "start": float(a), "length": float(L)}, t)[:, 0]
                info = float(np.sum((drdh * g) ** 2)) / (floor_rms ** 2 * max(tau_int, 1.0))
                if info > 0 and min_t / np.sqrt(info) <= dh_max:
                    visible.append((float(a), float(end)))
    windows: list[list[float]] = []
    for u in np.arange(t0, t1 - SHAPE_LENGTHS[0] + 1e-9, BLIND_STEP):
        # the window from u ends where the first visible placement starting at or after u ends
        e = min((b for a, b in visible if a >= u - 1e-9), default=t1 + BLIND_STEP) - BLIND_STEP
        e = min(e, t1)
        if e - u >= SHAPE_LENGTHS[0] and not any(w0 <= u and e <= w1 for w0, w1 in windows):
            windows.append([float(u), float(e)])
    return windows

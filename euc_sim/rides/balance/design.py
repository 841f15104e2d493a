"""The wheel's longitudinal balance of a ride, every term filtered alike, ready to fit.

The balance of EUC and rider along the road, m_eq·a·R = M_wheel − R·(C_rr·N·sign v +
k·v|v| + m·g·sin α), is used in its energy form (losses added, no efficiency)::

    D = m_eq·a·v + C_rr·m·g·|v| + k·|v|³ + m·g·sin α·v
    P = P₀ + D + k_cu·F²,   F = m_eq·a

(P₀ a constant drain, W; k_cu the copper loss, W/N²; speed-linear and |v|³ losses fold
into rolling and drag).  Battery power is the target, not a regressor, so the rider's
unmeasured lean torque stays in the target's noise.  Linear in every parameter but the
current lag (:mod:`~euc_sim.rides.balance.normal`).  The candidates (:data:`CANDIDATES`),
their plausible ranges and the ride's regressors (:func:`balance_design`) live here; the
fit in :mod:`euc_sim.rides.balance.fit`.  See docs/ride_model.md.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from functools import cached_property
from types import SimpleNamespace
from typing import Mapping, Sequence

import numpy as np
import pandas as pd

from euc_sim.rides.grids.power import RHO_AIR
from euc_sim.rides.grids.route import gps_grade
from euc_sim.simulation.effects import RECORDS
from euc_sim.stats import label_rows
from euc_sim.rides.grids.signals import RideSignals, sg, window_samples

__all__ = ["RHO_AIR", "CANDIDATES", "term_role", "role_index", "NOMINAL", "PLAUSIBLE", "BOUNDS", "PRE_WINDOW", "Design",
           "Operator", "Basis", "balance_design", "filter_matrices", "on_bound", "standstill_power",
           "MIN_STANDSTILL"]


#: Candidate parameters (the catalog's records with a balance face): name -> (symbol, unit,
#: meaning, regressor column or None, column unit).
CANDIDATES = RECORDS.view("balance", lambda b: (b.symbol, b.unit, b.meaning, b.column, b.column_unit))
#: The inertia-only model: the paper's balance with no resistance and no loss,
#: P̂ = L₂[m_eq·a·v], nothing fitted (every term is a candidate).
NOMINAL: tuple[str, ...] = ()
#: Plausible ranges of the physical estimates, with units.
PLAUSIBLE = RECORDS.view("balance", lambda b: (*b.plausible, b.unit))
#: Bounds of the fit: a resistance or loss from 0 (absent) to the top of its plausible range, a
#: grade or GPS gain over its plausible range (an estimate on an edge: :func:`on_bound`).
BOUNDS = RECORDS.view("balance", lambda b: b.bounds)


def term_role(name: str) -> str | None:
    """How the balance applies ``name`` (:attr:`euc_sim.model.catalog.Balance.role`), or None."""
    face = RECORDS.get(name).balance if name in RECORDS else None
    return None if face is None else face.role


def role_index(names: Sequence[str], role: str) -> int | None:
    """Index in ``names`` of the parameter whose balance term has ``role`` (``"lag"``, ``"constant"``), or None."""
    return next((j for j, n in enumerate(names) if term_role(n) == role), None)


def on_bound(name: str, value: float) -> bool:
    """True when ``value`` sits on a bound of :data:`BOUNDS` that is not "absent" (0): the most
    plausible physics gives (docs/ride_model.md, "accepted on the edge").
    """
    lo, hi = BOUNDS.get(name, (-np.inf, np.inf))
    tol = 1e-6 * max(abs(hi - lo), 1.0) if np.isfinite(hi - lo) else 0.0
    return bool((value >= hi - tol) or (lo != 0.0 and value <= lo + tol))


@dataclass(frozen=True)
class Design:
    """A ride's longitudinal balance, ready to fit: target and named regressors.

    Model (power domain, W)::

        D = inertia + C_rr·rolling + k·drag + sin α·slope + gain·gps_climb + k_cu·copper
        P̂ = P₀ + (L₂ − τ_I·L₂' + τ_I²·L₂'')[D]

    τ_I (``current_lag``) is a first-order lag of the logged current to second order, L₂'
    and L₂'' the derivatives of the same Savitzky–Golay fit L₂.  Every regressor first
    passes a short fit L₁ (``copper`` squared after it); the measured power gets L₂∘L₁, so
    both sides carry the same linear filter.

    Attributes
    ----------
    columns_full : pandas.DataFrame
        L₁-filtered on the whole grid: ``inertia`` m_eq·d/dt(v²/2) W, ``rolling`` m·g·|v| W,
        ``drag`` |v|³ m³/s³, ``slope`` m·g·v W, ``gps_climb`` m·g·v·sin α W (where supported).
    P_full : numpy.ndarray
        Battery power V·I filtered by L₂∘L₁, W.
    segment : numpy.ndarray of int
    use : numpy.ndarray of bool
        Rows that enter the residual.
    kernel, dkernel, d2kernel : numpy.ndarray
        L₂'s convolution coefficients and its first (1/s) and second (1/s²) derivatives.
    weight_full : numpy.ndarray
        Residual weight: 1 (power), or R/v s (torque: residuals in N·m).
    t_full, v_full : numpy.ndarray
        s; L₂∘L₁-smoothed speed, m/s.
    domain, unit : str
        ``"power"``/``"W"`` or ``"torque"``/``"N·m"``.
    candidates : tuple of str
        Parameters this ride supports.
    aliases : dict
        Candidate -> candidates this ride cannot tell apart from it.
    notes : tuple of str
    path : str
    idle_cap : float or None
        :func:`standstill_power`, W: P₀ above it is not plausible on this ride.
    """

    columns_full: pd.DataFrame
    P_full: np.ndarray
    segment: np.ndarray
    use: np.ndarray
    kernel: np.ndarray
    dkernel: np.ndarray
    d2kernel: np.ndarray
    weight_full: np.ndarray
    t_full: np.ndarray
    v_full: np.ndarray
    domain: str
    unit: str
    candidates: tuple[str, ...]
    aliases: Mapping[str, tuple[str, ...]]
    notes: tuple[str, ...]
    path: str = ""
    idle_cap: float | None = None

    # rows in use --------------------------------------------------------------
    @property
    def P(self) -> np.ndarray:
        """Measured (filtered) battery power on the rows in use, W."""
        return self.P_full[self.use]

    @property
    def t(self) -> np.ndarray:
        return self.t_full[self.use]

    @property
    def v(self) -> np.ndarray:
        return self.v_full[self.use]

    @property
    def weight(self) -> np.ndarray:
        return self.weight_full[self.use]

    def rows(self, mask: np.ndarray) -> "Design":
        """The same design with fewer rows in use (``mask`` over the rows in use), reusing this
        one's filter matrices.
        """
        mask = np.asarray(mask, bool)
        use = self.use.copy()
        use[np.flatnonzero(self.use)[~mask]] = False
        out = replace(self, use=use)
        op = self.operator
        out.__dict__["operator"] = replace(op, K=op.K[mask], Kd=op.Kd[mask], Kdd=op.Kdd[mask])
        out.__dict__["basis"] = replace(self.basis, Z=self.basis.Z[mask])
        return out

    @cached_property
    def operator(self) -> "Operator":
        """The model's linear pieces on the rows it touches (built once per design)."""
        rows = np.flatnonzero(self.use)
        (K, Kd, Kdd), support = filter_matrices(self.segment, (self.kernel, self.dkernel, self.d2kernel), rows)
        X = self.columns_full.iloc[support]
        return Operator(K=K, Kd=Kd, Kdd=Kdd, columns={c: X[c].to_numpy() for c in X.columns},
                        support=support)

    @cached_property
    def basis(self) -> "Basis":
        """The weighted residual's basis on the rows in use (:mod:`~euc_sim.rides.balance.normal`)."""
        op = self.operator
        cols = ["inertia"] + sorted({CANDIDATES[n][3] for n in self.candidates
                                     if CANDIDATES[n][3] is not None})
        parts = []
        for c in cols:
            x = op.columns[c]
            parts += [op.K @ x, op.Kd @ x, op.Kdd @ x]
        Z = np.column_stack([np.asarray(p) for p in parts] + [np.ones(len(self.weight)), self.P])
        return Basis(columns=tuple(cols), Z=Z * self.weight[:, None])

    @cached_property
    def gram(self) -> np.ndarray:
        """ZᵀZ of :attr:`basis` over the rows in use."""
        Z = self.basis.Z
        return Z.T @ Z

    def predict(self, params: Mapping[str, float]) -> np.ndarray:
        """Battery power P̂ = P₀ + (L₂ − τ_I·L₂′ + τ_I²·L₂″)[D], W, on the rows in use; D the demand
        inertia + Σ θ·column (missing resistances are 0).
        """
        names = list(params)
        theta = np.array([params[k] for k in names], float)[:, None]      # one parameter set
        op = self.operator
        D = op.columns["inertia"][:, None].copy()
        for j, name in enumerate(names):
            col = CANDIDATES[name][3] if name in CANDIDATES else None
            if col is not None:
                D += op.columns[col][:, None] * theta[j]
        P_hat = np.asarray(op.K @ D)
        lag, const = role_index(names, "lag"), role_index(names, "constant")
        if lag is not None:
            tau = theta[lag]
            P_hat += -tau * np.asarray(op.Kd @ D) + tau ** 2 * np.asarray(op.Kdd @ D)
        if const is not None:
            P_hat += theta[const]
        return P_hat[:, 0]

    def residual(self, params: Mapping[str, float], target: np.ndarray | None = None) -> np.ndarray:
        """Weighted residual (measured, or ``target``, − predicted) on the rows in use, W or N·m."""
        return self.weight * ((self.P if target is None else target) - self.predict(params))


@dataclass(frozen=True)
class Basis:
    """The basis ``Z`` of a design's weighted residual w·(P − P̂) on its rows in use.

    Column ``3·i + s`` of ``Z`` is w·L₂⁽ˢ⁾[columns[i]] (s = 0, 1, 2), ``"inertia"`` first;
    the last two are w (the constant P₀) and w·P (the measured power), W or N·m.
    """

    columns: tuple[str, ...]
    Z: np.ndarray


@dataclass(frozen=True)
class Operator:
    """A design's model as matrices: P̂ = P₀ + K·g(D) on the rows in use.

    ``K``, ``Kd``, ``Kdd`` (sparse) are L₂ and its derivatives from the ``support`` rows they
    read to the rows in use; ``columns`` holds ``columns_full`` on the support.
    """

    K: object
    Kd: object
    Kdd: object
    columns: Mapping[str, np.ndarray]
    support: np.ndarray


def filter_matrices(segment: np.ndarray, kernels: Sequence[np.ndarray], rows: np.ndarray):
    """Segment-wise convolutions as sparse matrices on the rows they touch.

    Each kernel (one odd length M, as for ``numpy.convolve``) becomes a (len(rows),
    len(support)) matrix with ``K @ x[support]`` equal to the segment-wise
    ``numpy.convolve(x, kernel, mode="same")`` at ``rows``; ``support`` is the sorted samples
    read.  ValueError for a row within M//2 samples of its segment's end.
    """
    from scipy import sparse

    segment, rows = np.asarray(segment), np.asarray(rows, int)
    kernels = [np.asarray(k, float) for k in kernels]
    M = len(kernels[0])
    half = M // 2
    order = np.argsort(segment, kind="stable")       # samples grouped by segment, in time order
    where = np.empty(len(segment), int)
    where[order] = np.arange(len(segment))
    seg_sorted = segment[order]
    q = where[rows]
    lo = np.searchsorted(seg_sorted, seg_sorted[q], "left")
    hi = np.searchsorted(seg_sorted, seg_sorted[q], "right")
    if np.any(q - half < lo) or np.any(q + half >= hi):
        raise ValueError(f"rows must lie at least {half} samples inside their segment")
    # the samples some row reads: sorted positions q - half ... q + half
    count = np.zeros(len(segment) + 1, int)
    np.add.at(count, q - half, 1)
    np.add.at(count, q + half + 1, -1)
    covered = (np.cumsum(count[:-1]) > 0)[where]                  # by original index
    support = np.flatnonzero(covered)
    position = np.cumsum(covered) - 1                              # original index -> support column
    # numpy.convolve 'same': y[i] = sum_j kernel[j] * x[i + half - j]
    idx = position[order[q[:, None] + half - np.arange(M)[None, :]]].ravel()
    indptr = np.arange(0, idx.size + 1, M)
    Ks = [sparse.csr_matrix((np.broadcast_to(k, (len(rows), M)).ravel(), idx, indptr),
                            shape=(len(rows), len(support))) for k in kernels]
    return Ks, support


def _conv(x: np.ndarray, segment: np.ndarray, kernel: np.ndarray) -> np.ndarray:
    """Convolve each segment with ``kernel``; NaN where the kernel overhangs an end."""
    out = np.full(x.shape, np.nan)
    half = len(kernel) // 2
    for idx in label_rows(segment):
        if idx.size < len(kernel):
            continue
        y = np.convolve(x[idx], kernel, mode="same")
        y[:half] = np.nan
        y[idx.size - half:] = np.nan
        out[idx] = y
    return out


#: Short pre-filter L₁ applied to every regressor before the regime switch, s.
PRE_WINDOW = 0.5
#: ``road_slope`` is offered only when the speed changes sign on this share of the moving
#: samples; otherwise it aliases rolling resistance (docs/diagnosis.md).
SIGN_CHANGE_FRACTION = 0.02


def _regressors(sig: RideSignals, L1):
    """The L₁-filtered regressor columns of a ride and the candidates they support.

    A record whose ``regressor`` gives a reason instead of a column adds a note and its
    ``aliases_when_absent``.  Returns ``(columns, candidates, aliases, notes)``.
    """
    A = sig.assumptions
    raw = sig.raw
    v_raw = raw["v"].to_numpy()
    moving = np.abs(v_raw) > 0.3
    back = float((v_raw[moving] < -0.3).mean()) if moving.any() else 0.0
    fwd = float((v_raw[moving] > 0.3).mean()) if moving.any() else 0.0
    b = SimpleNamespace(v=v_raw, mg=A.total_mass * A.g, m_eq=A.m_eq, L1=L1,
                        gps_grade=gps_grade(raw) if sig.has_gps_alt else None,
                        sign_change=min(back, fwd), sign_change_fraction=SIGN_CHANGE_FRACTION)
    cols = {"inertia": A.m_eq * L1(0.5 * v_raw ** 2, 1)}       # m_eq·a·v = m_eq·d/dt(v²/2)
    cands: list[str] = []
    aliases: dict[str, tuple[str, ...]] = {}
    notes: list[str] = []
    for e in RECORDS.having("balance"):
        t = e.balance
        col = None if t.regressor is None else t.regressor(b)
        if isinstance(col, str):
            for other in t.aliases_when_absent:
                aliases[other] = (e.name,)
            if t.aliases_when_absent:
                aliases[e.name] = t.aliases_when_absent
            notes.append(col)
            continue
        if col is not None:
            cols[t.column] = col
        cands.append(e.name)
    return cols, cands, aliases, notes


#: Least standstill, s, from which the log's own idle power is read.
MIN_STANDSTILL = 10.0


def standstill_power(v: np.ndarray, P: np.ndarray, rate: float) -> float | None:
    """Upper quartile of the battery power at standstill (|v| < 0.05 m/s), W: a bound on P₀.
    None with less than :data:`MIN_STANDSTILL` s of standstill or mostly zero readings.
    """
    still = (np.abs(v) < 0.05) & np.isfinite(P)
    if still.sum() < MIN_STANDSTILL * rate or np.mean(P[still] == 0.0) > 0.5:
        return None
    return float(np.percentile(P[still], 75))


def balance_design(sig: RideSignals, domain: str = "power") -> Design:
    """The longitudinal balance of a ride, every term filtered alike.

    Parameters
    ----------
    sig : RideSignals
        Its ``window`` and ``polyorder`` give the main filter L₂.
    domain : {"power", "torque"}
        Residuals in W, or divided by ω = v/R (|v| ≥ v_min) in N·m.
    """
    from scipy.signal import savgol_coeffs

    if domain not in ("power", "torque"):
        raise ValueError(f"domain must be 'power' or 'torque', got {domain!r}")
    A = sig.assumptions
    raw = sig.raw
    seg = raw["segment"].to_numpy()
    v_raw = raw["v"].to_numpy()
    p1 = min(2, sig.polyorder)
    L1 = lambda x, d=0: sg(x, seg, sig.rate, PRE_WINDOW, p1, d)  # noqa: E731
    n2 = window_samples(sig.window, sig.rate, sig.polyorder)
    kernel = savgol_coeffs(n2, sig.polyorder)
    dkernel = savgol_coeffs(n2, sig.polyorder, deriv=1, delta=1.0 / sig.rate)
    d2kernel = savgol_coeffs(n2, sig.polyorder, deriv=2, delta=1.0 / sig.rate)
    L2 = lambda x: _conv(x, seg, kernel)  # noqa: E731
    cols, cands, aliases, notes = _regressors(sig, L1)
    X = pd.DataFrame(cols)
    P = L2(L1(raw["P"].to_numpy()))
    v = L2(L1(v_raw))
    weight = np.ones_like(P)
    unit = "W"
    use = np.isfinite(P) & np.isfinite(X.to_numpy()).all(axis=1) & np.isfinite(v)
    if domain == "torque":
        with np.errstate(divide="ignore", invalid="ignore"):
            weight = A.R / v
        use &= np.abs(v) >= A.v_min
        unit = "N·m"
    X = X.fillna(0.0)             # rows out of use; keeps the convolution finite inside
    return Design(columns_full=X, P_full=P, segment=seg, use=use, kernel=kernel, dkernel=dkernel,
                  d2kernel=d2kernel,
                  weight_full=weight, t_full=raw["t"].to_numpy(), v_full=v, domain=domain,
                  unit=unit, candidates=tuple(cands), aliases=aliases, notes=tuple(notes),
                  path=sig.path,
                  idle_cap=standstill_power(v_raw, raw["P"].to_numpy(), sig.rate))

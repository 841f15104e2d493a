"""The smallest difference a pair of rides can name, predicted from the pair's own noise.

A difference is named when its 95 % interval excludes zero *and* modelling it
lowers OTHER's blocked held-out RMS by more than ``min_gain``
(:mod:`euc_sim.rides.compare.differences_fit`).  Each test has a resolution:

* the interval's: a difference smaller than the interval's half-width leaves
  zero inside it;
* the gate's: a difference Δ leaves, in OTHER's residuals of the model without
  it, a systematic error of RMS ``Δ·s`` (``s``: the held-out RMS of the
  difference's column after the model's other columns, fitted on both rides,
  have absorbed what they can, per unit of the parameter).  With OTHER's
  held-out RMS ``σ`` when the difference is modelled and ``e = s·se·√(K/(K−1))``
  what estimating it on K−1 of K folds costs on the held-out rows (``se``: the
  interval's half-width over 1.96), the gate is passed when
  ``σ/√(σ² − e² + Δ²s²) < 1 − g``, i.e.

      Δ_gate = √((σ/s)²·((1 − g)⁻² − 1) + (K/(K−1))·se²),

  about 0.14·σ/s for the 1 % gate (removing an error of RMS b from residuals
  of RMS σ lowers the RMS by about b²/(2σ²)).

The smallest nameable difference is the larger of the two.  A shift (the
current's delay) has no column: only its interval (and the logs' finest delay)
resolves it.

Study: docs/concealed.md ("What a pair can resolve").
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

__all__ = ["Z95", "Resolution", "gate_factor", "gate_size", "predicted_gain", "heldout_signature_rms",
           "detectable_difference", "with_floor"]

#: Normal quantile of a two-sided 95 % interval.
Z95 = 1.959963984540054


@dataclass(frozen=True)
class Resolution:
    """The smallest difference of one parameter a pair of rides can name.

    Attributes
    ----------
    name : str
        The parameter.
    resolvable : float or None
        The larger of ``interval_halfwidth`` (plus ``floor``) and ``gate``, the
        parameter's unit; None without an interval.
    interval_halfwidth : float or None
        Half the 95 % interval's width, the parameter's unit.
    gate : float or None
        The size whose signature on OTHER's held-out rows passes the held-out
        gate (module docstring), the parameter's unit; None for a shift.
    residual_rms : float or None
        OTHER's blocked held-out RMS with the difference modelled, the fitted
        signal's unit (W for battery power, V, m/s).
    signature_rms : float or None
        Held-out RMS of the difference's column after the model's other
        columns, the fitted signal's unit per unit of the parameter.
    floor : float
        The finest value the logs resolve (the delay's row interval), added to
        the half-width; 0 elsewhere.
    gain_se : float or None
        Standard error of the difference's measured held-out gain, from its
        spread over the folds (fraction): where it is comparable with the
        threshold, whether a difference near ``resolvable`` is named is a
        matter of chance.
    """

    name: str
    resolvable: float | None
    interval_halfwidth: float | None
    gate: float | None = None
    residual_rms: float | None = None
    signature_rms: float | None = None
    floor: float = 0.0
    gain_se: float | None = None

    def to_json(self) -> dict:
        """The ``differences`` entry's ``resolution`` detail."""
        return {"interval_halfwidth": self.interval_halfwidth, "gate": self.gate,
                "residual_rms": self.residual_rms, "signature_rms": self.signature_rms,
                "floor": self.floor, "gain_se": self.gain_se}


def gate_factor(min_gain: float) -> float:
    """``√((1 − g)⁻² − 1)``: the systematic RMS, in units of the residual RMS, that the gate asks for."""
    return math.sqrt((1.0 - min_gain) ** -2 - 1.0)


def gate_size(residual_rms: float, signature_rms: float, se: float, min_gain: float,
              n_folds: int) -> float | None:
    """Smallest difference whose held-out gain passes ``min_gain`` (module docstring).

    Parameters
    ----------
    residual_rms : float
        σ, OTHER's held-out RMS with the difference modelled (signal's unit).
    signature_rms : float
        s, the held-out RMS of the difference's column after the other columns,
        per unit of the parameter.
    se : float
        Standard error of the difference (parameter's unit).
    min_gain : float
        The selection's fractional threshold g.
    n_folds : int
        K, the held-out folds.

    Returns
    -------
    float or None
        Δ_gate in the parameter's unit; None where the column vanishes (s = 0).
    """
    if not signature_rms > 0 or not np.isfinite(residual_rms):
        return None
    ratio = residual_rms / signature_rms
    return math.sqrt(ratio ** 2 * gate_factor(min_gain) ** 2 + n_folds / (n_folds - 1.0) * se ** 2)


def predicted_gain(size: float, residual_rms: float, signature_rms: float, se: float,
                   n_folds: int) -> float:
    """The held-out gain of modelling a difference of ``size``: ``1 − σ/√(σ² − e² + Δ²s²)``.

    Parameters as :func:`gate_size` (``size``: Δ, the parameter's unit); the
    inverse of :func:`gate_size` at the threshold.
    """
    e2 = n_folds / (n_folds - 1.0) * (signature_rms * se) ** 2
    return 1.0 - residual_rms / math.sqrt(max(residual_rms ** 2 - e2 + (size * signature_rms) ** 2, 1e-300))


def heldout_signature_rms(GL: np.ndarray, fold_log: np.ndarray, GO: np.ndarray, fold_other: np.ndarray,
                          count_other: np.ndarray, others: list, col: int) -> float:
    """Held-out RMS of column ``col`` on OTHER's rows after the columns ``others`` (both rides).

    For each fold f the ``others`` are fitted to the column on both rides'
    blocks outside f (how the model without the difference absorbs its
    signature), and the remainder is scored on OTHER's blocks of fold f: the
    systematic error a unit difference leaves in OTHER's held-out residuals.

    Parameters
    ----------
    GL, GO : ndarray (n_blocks, p, p)
        Per-block Gram matrices of LOG's and OTHER's rows
        (:func:`euc_sim.rides.compare.differences_fit.block_grams`).
    fold_log, fold_other : ndarray (n_blocks,)
        Each block's fold.
    count_other : ndarray (n_blocks,)
        OTHER's rows per block.
    others : list of int
        The model's other columns.
    col : int
        The difference's column (its coefficient's unit).

    Returns
    -------
    float
    """
    sse, n = 0.0, 0
    for f in np.unique(fold_other):
        test = fold_other == f
        A = GL[fold_log != f].sum(axis=0) + GO[~test].sum(axis=0)
        beta = np.linalg.lstsq(A[np.ix_(others, others)], A[others, col], rcond=None)[0] if others else []
        T = GO[test].sum(axis=0)
        sse += float(T[col, col] - 2.0 * np.dot(beta, T[others, col]) + beta @ T[np.ix_(others, others)] @ beta
                     if others else T[col, col])
        n += int(count_other[test].sum())
    return float(np.sqrt(max(sse, 0.0) / n)) if n else 0.0


def detectable_difference(name: str, ci95, residual_rms: float | None = None,
                          signature_rms: float | None = None, *, min_gain: float,
                          n_folds: int = 5) -> Resolution:
    """The smallest difference of ``name`` the pair can name: the interval's half-width or the gate's size.

    Parameters
    ----------
    name : str
    ci95 : (lo, hi) or None
        The difference's 95 % interval, the parameter's unit.
    residual_rms, signature_rms : float, optional
        σ and s (:func:`gate_size`); without them (a shift) only the interval resolves.
    min_gain : float
        The selection's threshold.
    n_folds : int

    Returns
    -------
    Resolution
    """
    if ci95 is None:
        return Resolution(name, None, None, None, residual_rms, signature_rms)
    half = 0.5 * float(ci95[1] - ci95[0])
    gate = None
    if residual_rms is not None and signature_rms is not None:
        gate = gate_size(residual_rms, signature_rms, half / Z95, min_gain, n_folds)
    best = half if gate is None else max(half, gate)
    return Resolution(name, float(best), half, gate, residual_rms, signature_rms)


def with_floor(res: Resolution, floor: float) -> Resolution:
    """``res`` with the logs' finest resolvable value added to the interval's half-width (the delay)."""
    if res.interval_halfwidth is None:
        return replace(res, floor=float(floor))
    best = res.interval_halfwidth + floor
    return replace(res, floor=float(floor), resolvable=float(best if res.gate is None else max(best, res.gate)))

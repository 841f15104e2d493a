"""What differs between two rides of one wheel: OTHER minus LOG for every parameter.

A difference is *named* when both hold:

1. its 95 % interval excludes zero.  The two rides are independent, so the
   interval of the difference combines the two rides' 95 % half-widths in
   quadrature, each side separately (a normal approximation: the rides' JSON
   carries intervals, not bootstrap draws); ``speed_scale`` is a ratio, its
   difference ``s_OTHER/s_LOG − 1`` combined the same way in logarithms;
2. modelling it improves OTHER's blocked held-out fit beyond LOG's model: the
   residual of LOG's model on OTHER (battery power for the road and mass terms
   and the current delay, terminal voltage for the battery resistance, GPS
   speed for the speed scale) is refitted with that one term on four of five
   time blocks and scored on the fifth (:func:`heldout_gain`); the gain must
   exceed :data:`MIN_GAIN`.

Which differences a pair of rides can tell apart follows from the correlation
of their power signatures over both rides (:func:`signature_columns`,
:func:`alias_table`): drag ∝ v³, rolling ∝ v, mass ∝ a·v plus the climb,
battery resistance ∝ I² (and the sag), the speed scale every speed term at
once, the current delay the phase of power against acceleration (dP/dt).

Study: docs/concealed.md.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field

import numpy as np

from euc_sim.stats import time_blocks
from euc_sim.rides.power import G, RHO_AIR

__all__ = ["Difference", "Differences", "MIN_GAIN", "ALIAS_CORRELATION", "PHYSICS",
           "parameters_from_ride", "difference_interval", "heldout_gain", "residual_coefficient", "signature_columns",
           "alias_table", "ride_differences", "rider_sentence"]

#: Fractional drop of OTHER's held-out RMS that names a difference.
MIN_GAIN = 0.02
#: |correlation| of two signatures over both rides beyond which the pair cannot tell them apart.
ALIAS_CORRELATION = 0.9
#: Blocks of the held-out test.
N_BLOCKS = 5
#: The physics a difference is tested for (the effect catalog's names).
PHYSICS = ("total_mass", "rolling_resistance", "aerodynamic_drag", "internal_resistance",
           "speed_scale", "current_delay")
#: Why a rider would see it, by parameter, for the page's sentence.
_HINT = {
    "aerodynamic_drag": ("kg/m more drag", "kg/m less drag", "{:.2f}", "(a jacket? a headwind?)"),
    "rolling_resistance": ("more rolling resistance", "less rolling resistance", "{:.3f}",
                           "(a softer tyre? a rougher road?)"),
    "total_mass": ("kg more mass", "kg less mass", "{:.0f}", "(a backpack? a passenger?)"),
    "internal_resistance": ("Ω more battery resistance", "Ω less battery resistance", "{:.3f}",
                            "(a colder or older pack?)"),
    "speed_scale": ("more ground per logged metre", "less ground per logged metre", "{:.1%}",
                    "(a tyre size set differently in the app? a worn tyre?)"),
    "current_delay": ("s more delay on the current channel", "s less delay on the current channel",
                      "{:.1f}", "(a different app or logging rate?)"),
}


@dataclass(frozen=True)
class Difference:
    """OTHER minus LOG for one parameter (CONTRACT's ``differences`` entry)."""

    name: str
    estimate: float | None
    ci95: tuple[float, float] | None
    unit: str
    named: bool
    why: str
    aliases: tuple[str, ...] = ()
    heldout_gain: float | None = None
    given_log_model: tuple[float, tuple[float, float]] | None = None
    named_given_log_model: bool = False

    def to_json(self) -> dict:
        """``{name, estimate, ci95, unit, named, why, aliases, heldout_gain, given_log_model}``."""
        g = self.given_log_model
        return {"name": self.name, "estimate": self.estimate,
                "ci95": list(self.ci95) if self.ci95 else None, "unit": self.unit,
                "named": self.named, "why": self.why, "aliases": list(self.aliases),
                "heldout_gain": self.heldout_gain,
                "given_log_model": None if g is None else {"estimate": g[0], "ci95": list(g[1])},
                "named_given_log_model": self.named_given_log_model}


@dataclass(frozen=True)
class Differences:
    """Every difference of a pair of rides, what the pair cannot see, and the page's sentence."""

    items: tuple[Difference, ...]
    cannot_see: dict = field(default_factory=dict)
    sentence: str = ""
    interval_method: str = ("normal approximation: the two rides' 95 % half-widths combined in "
                            "quadrature, each side separately (independent rides)")

    def to_json(self) -> dict:
        """The ride JSON's ``differences`` list and its companions."""
        return {"differences": [d.to_json() for d in self.items],
                "differences_cannot_see": dict(self.cannot_see),
                "differences_sentence": self.sentence,
                "differences_interval": self.interval_method}


# ---------------------------------------------------------------- adapter (until the merge)
def _entry(name, est, ci, unit) -> dict:
    return {"name": name, "estimate": est, "ci95": list(ci) if ci else None, "unit": unit}


def parameters_from_ride(rep: dict) -> list[dict]:
    """The ride's ``parameters`` list; ADAPTER from today's views where the list is absent.

    Until the balance model emits ``parameters``, the list is built from the
    ride JSON's ``drivetrain`` ``{NAME: {estimate, ci95, unit}}`` and
    ``total_mass`` views: ``C_rr`` → ``rolling_resistance``, ``C_dA`` →
    ``aerodynamic_drag`` (k = ½ρC_dA, kg/m), ``total_mass.lag_s`` →
    ``current_delay`` (no interval), the total mass with its statistical
    interval (the systematic parts a wheel shares cancel between two rides).
    """
    if rep.get("parameters"):
        return list(rep["parameters"])
    out = []
    tm = rep.get("total_mass") or {}
    out.append(_entry("total_mass", tm.get("estimate"),
                      tm.get("statistical_ci95") or tm.get("ci95"), "kg"))
    for name, t in (rep.get("drivetrain") or {}).items():
        est, ci = t.get("estimate"), t.get("ci95")
        if name == "C_rr":
            out.append(_entry("rolling_resistance", est, ci, "1"))
        elif name == "C_dA":
            k = 0.5 * RHO_AIR
            out.append(_entry("aerodynamic_drag", None if est is None else k * est,
                              [k * x for x in ci] if ci else None, "kg/m"))
        else:
            out.append(_entry(name, est, ci, t.get("unit") or ""))
    if tm.get("lag_s") is not None:
        out.append(_entry("current_delay", tm["lag_s"], None, "s"))
    return out


# ---------------------------------------------------------------- intervals
def difference_interval(a: float, a_ci, b: float, b_ci, ratio: bool = False):
    """``b − a`` (or ``b/a − 1``) and its 95 % interval from two independent intervals.

    Parameters
    ----------
    a, b : float
        LOG's and OTHER's estimates.
    a_ci, b_ci : (lo, hi)
        Their 95 % intervals.
    ratio : bool
        Combine in logarithms and return ``b/a − 1`` (positive estimates only).

    Returns
    -------
    estimate : float
    ci95 : (float, float)
    """
    f = math.log if ratio else (lambda x: x)
    fa, fb = f(a), f(b)
    lo_a, hi_a = fa - f(a_ci[0]), f(a_ci[1]) - fa
    lo_b, hi_b = fb - f(b_ci[0]), f(b_ci[1]) - fb
    d = fb - fa
    lo = d - math.hypot(max(lo_b, 0.0), max(hi_a, 0.0))
    hi = d + math.hypot(max(hi_b, 0.0), max(lo_a, 0.0))
    if ratio:
        return math.expm1(d), (math.expm1(lo), math.expm1(hi))
    return d, (lo, hi)


# ---------------------------------------------------------------- held-out gain
def _base_columns(residual, base, intercept: bool) -> list:
    cols = [np.ones_like(residual)] if intercept else []
    return cols + ([] if base is None else list(np.atleast_2d(base.T)))


def _ols_pred(Xf, yf, Xt):
    if Xf.shape[1] == 0:
        return np.zeros(len(Xt))
    beta, *_ = np.linalg.lstsq(Xf, yf, rcond=None)
    return Xt @ beta


def heldout_gain(t: np.ndarray, residual: np.ndarray, candidate: np.ndarray,
                 base: np.ndarray | None = None, n_blocks: int = N_BLOCKS,
                 intercept: bool = True) -> float | None:
    """Fractional drop of the blocked held-out RMS of ``residual`` when ``candidate`` is fitted.

    The base model (a constant plus ``base`` columns) and the base plus the
    candidate are fitted on ``n_blocks − 1`` contiguous time blocks and scored on
    the left-out one, every block in turn.  ``intercept`` False: no constant
    (a ratio through the origin, as a speed scale).

    Returns
    -------
    float or None
        ``1 − RMS(with)/RMS(base)``; None with too few finite rows.
    """
    cols = _base_columns(residual, base, intercept)
    B = np.column_stack(cols) if cols else np.empty((len(residual), 0))
    ok = np.isfinite(residual) & np.isfinite(candidate) & np.all(np.isfinite(B), axis=1)
    if ok.sum() < 20 * n_blocks or np.nanstd(candidate[ok]) == 0:
        return None
    t, y, B, x = t[ok], residual[ok], B[ok], candidate[ok]
    X = np.column_stack([B, x])
    fold = time_blocks(t, n_blocks)
    e0, e1 = np.empty_like(y), np.empty_like(y)
    for k in range(n_blocks):
        te = fold == k
        e0[te] = y[te] - _ols_pred(B[~te], y[~te], B[te])
        e1[te] = y[te] - _ols_pred(X[~te], y[~te], X[te])
    r0, r1 = math.sqrt(np.mean(e0 ** 2)), math.sqrt(np.mean(e1 ** 2))
    return None if r0 == 0 else 1.0 - r1 / r0


def residual_coefficient(t: np.ndarray, residual: np.ndarray, candidate: np.ndarray,
                         base: np.ndarray | None = None, n_boot: int = 200, seed: int = 0,
                         block: float = 30.0, intercept: bool = True
                         ) -> tuple[float, tuple[float, float]] | None:
    """The candidate's coefficient on the residual of LOG's model, with a block-bootstrap 95 % interval.

    The difference OTHER needs *given LOG's fitted model* (LOG's own estimation
    error not included): least squares of the residual on a constant, ``base``
    and the candidate; ``n_boot`` moving-block resamples of ``block`` s.

    Returns
    -------
    (estimate, (lo, hi)) or None with too few finite rows.
    """
    cols = _base_columns(residual, base, intercept)
    X = np.column_stack(cols + [candidate])
    ok = np.isfinite(residual) & np.all(np.isfinite(X), axis=1)
    if ok.sum() < 100 or np.nanstd(candidate[ok]) == 0:
        return None
    t, y, X = t[ok], residual[ok], X[ok]
    est = float(np.linalg.lstsq(X, y, rcond=None)[0][-1])
    label = np.floor((t - t[0]) / block).astype(int)
    blocks = [np.flatnonzero(label == b) for b in np.unique(label)]
    rng = np.random.default_rng(seed)
    draws = []
    for _ in range(n_boot):
        idx = np.concatenate([blocks[i] for i in rng.integers(0, len(blocks), len(blocks))])
        draws.append(np.linalg.lstsq(X[idx], y[idx], rcond=None)[0][-1])
    lo, hi = np.percentile(draws, [2.5, 97.5])
    return est, (float(lo), float(hi))


# ---------------------------------------------------------------- signatures and aliases
def signature_columns(v, av, P, t, current=None, climb=None, coef=None) -> dict:
    """Each physics' battery-power signature, W per unit of the parameter.

    Parameters
    ----------
    v, av, P, t : ndarray
        Speed (m/s), d/dt(v²/2) (W/kg), battery power (W), time (s).
    current : ndarray, optional
        Battery current, A.
    climb : ndarray, optional
        g·ḣ, W/kg (GPS altitude).
    coef : dict, optional
        LOG's ``total_mass`` (kg), ``rolling_resistance`` and ``aerodynamic_drag``
        (kg/m): the speed scale moves every speed term at once.

    Returns
    -------
    dict of str -> ndarray
    """
    c = {"total_mass": 80.0, "rolling_resistance": 0.0, "aerodynamic_drag": 0.0, **(coef or {})}
    s = np.abs(v)
    cols = {"aerodynamic_drag": s ** 3, "rolling_resistance": c["total_mass"] * G * s,
            "total_mass": av + (0.0 if climb is None else np.nan_to_num(climb)),
            "speed_scale": 2.0 * c["total_mass"] * av + c["rolling_resistance"] * c["total_mass"] * G * s
            + 3.0 * c["aerodynamic_drag"] * s ** 3,
            "current_delay": -np.gradient(P, t)}
    if current is not None:
        cols["internal_resistance"] = current ** 2
    return cols


def alias_table(columns: dict, threshold: float = ALIAS_CORRELATION) -> tuple[dict, dict]:
    """Which signatures a pair of rides cannot tell apart, from their correlations.

    Parameters
    ----------
    columns : dict of str -> ndarray
        :func:`signature_columns` over both rides (concatenated), same length.

    Returns
    -------
    aliases : dict of str -> list of str
        Each name's partners with |correlation| above ``threshold``.
    cannot_see : dict of str -> str
        Names whose signature is constant or absent on these rides, with why.
    """
    names = list(columns)
    M = np.column_stack([columns[n] for n in names])
    ok = np.all(np.isfinite(M), axis=1)
    sd = M[ok].std(axis=0) if ok.any() else np.zeros(len(names))
    cannot = {n: "its signature does not vary on these rides" for n, s in zip(names, sd) if s == 0}
    live = [i for i, s in enumerate(sd) if s > 0]
    R = np.corrcoef(M[ok][:, live].T) if len(live) > 1 else np.ones((1, 1))
    aliases = {n: [] for n in names}
    for a, i in enumerate(live):
        for b, j in enumerate(live):
            if a != b and abs(R[a, b]) > threshold:
                aliases[names[i]].append(names[j])
    return aliases, cannot


# ---------------------------------------------------------------- the differences
def _one(name, a, b, gain, aliases, cannot) -> Difference:
    unit = b.get("unit") or a.get("unit") or ""
    if a.get("estimate") is None or b.get("estimate") is None:
        return Difference(name, None, None, unit, False, "not identified on "
                          + ("this ride" if a.get("estimate") is None else "the compared ride"))
    if not a.get("ci95") or not b.get("ci95"):
        d = b["estimate"] - a["estimate"]
        return Difference(name, d, None, unit, False, "no interval on one ride: cannot be named",
                          tuple(aliases), gain)
    ratio = name == "speed_scale"
    d, ci = difference_interval(a["estimate"], a["ci95"], b["estimate"], b["ci95"], ratio)
    excl = ci[0] > 0 or ci[1] < 0
    if name in cannot:
        why, named = cannot[name], False
    elif name not in PHYSICS:
        why, named = "not a physics the held-out test covers (state of the pack or controller)", False
    elif gain is None:
        why, named = "no held-out test possible on the compared ride", False
    else:
        better = gain > MIN_GAIN
        named = excl and better
        why = (("interval excludes zero" if excl else "interval includes zero") + "; modelling it "
               + ("lowers" if better else "does not lower") + f" the compared ride's held-out RMS "
               f"beyond the fitted ride's model ({100 * gain:+.1f} %)")
    if named and aliases:
        why += f"; this pair cannot tell it from {', '.join(aliases)}"
    return Difference(name, d, tuple(ci), "1" if ratio else unit, named, why, tuple(aliases), gain)


def ride_differences(log_params: list, other_params: list, gains: dict, aliases: dict,
                     cannot_see: dict, log_name: str = "the other ride",
                     mass_view: dict | None = None, given: dict | None = None) -> Differences:
    """OTHER minus LOG for every parameter of both lists.

    Parameters
    ----------
    log_params, other_params : list of dict
        ``parameters`` of the two rides (:func:`parameters_from_ride`).
    gains : dict of str -> float or None
        :func:`heldout_gain` of each physics on the compared ride.
    aliases, cannot_see : dict
        :func:`alias_table`.
    log_name : str
        How the sentence names LOG ("the 16 May ride").
    mass_view : dict, optional
        The existing ``mass_difference`` (its interval carries the systematic
        parts): the ``total_mass`` entry takes its estimate and interval.
    given : dict of str -> (estimate, (lo, hi)), optional
        :func:`residual_coefficient` of each physics on the compared ride
        (reported beside the difference; not used to name it).
    """
    a = {p["name"]: p for p in log_params}
    b = {p["name"]: p for p in other_params}
    items = []
    for name in [n for n in a if n in b]:
        pa, pb = a[name], b[name]
        if name == "total_mass" and mass_view and mass_view.get("estimate") is not None:
            pa = {**pa, "estimate": 0.0, "ci95": [0.0, 0.0]}
            pb = {**pb, "estimate": mass_view["estimate"], "ci95": mass_view["ci95"]}
        d = _one(name, pa, pb, gains.get(name), aliases.get(name, []), cannot_see)
        g = (given or {}).get(name)
        cond = (g is not None and name in PHYSICS and name not in cannot_see
                and d.heldout_gain is not None and d.heldout_gain > MIN_GAIN
                and (g[1][0] > 0 or g[1][1] < 0))
        items.append(dataclasses.replace(d, given_log_model=g, named_given_log_model=cond))
    items = _one_of_aliases(items)
    return Differences(tuple(items), dict(cannot_see), rider_sentence(items, log_name))


def _one_of_aliases(items: list) -> list:
    """Of named differences whose signatures alias, keep the one whose held-out gain is largest."""
    by = {d.name: d for d in items}
    out = []
    for d in items:
        rivals = [by[n] for n in d.aliases if n in by and (by[n].heldout_gain or 0) > (d.heldout_gain or 0)]
        named = d.named and not any(r.named for r in rivals)
        cond = d.named_given_log_model and not any(r.named_given_log_model for r in rivals)
        why = d.why
        if (d.named or d.named_given_log_model) and not (named or cond):
            why += f"; {rivals[0].name} explains more of the compared ride (their signatures alias)"
        out.append(dataclasses.replace(d, named=named, named_given_log_model=cond, why=why))
    return out


def rider_sentence(items, log_name: str) -> str:
    """One sentence for the page: the named differences in a rider's words."""
    parts = []
    for d in items:
        if not d.named or d.name not in _HINT:
            continue
        more, less, fmt, hint = _HINT[d.name]
        parts.append(f"{fmt.format(abs(d.estimate))} {more if d.estimate > 0 else less} {hint}")
    if not parts:
        return f"this ride needed nothing its log can show that {log_name} did not."
    return f"this ride needed {'; '.join(parts)} than {log_name}."

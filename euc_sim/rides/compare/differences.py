"""What differs between two rides of one wheel: OTHER minus LOG for every parameter.

Each physics is sized by one least-squares fit of both rides
(:mod:`euc_sim.rides.compare.differences_fit`): shared terms on both, the difference Δθ
on OTHER's rows.  A difference is named when its q-value (a paired held-out test over
OTHER's 30 s blocks, Benjamini–Hochberg across the pair's tested physics;
:mod:`euc_sim.rides.compare.resolution`) is below :data:`FALSE_NAME_RATE` and its 95 %
interval (hull of a two-ride block bootstrap and a jackknife-t over paired fractions)
excludes zero.  The rides' own estimates differenced are kept as ``independent``
(pack-state and controller parameters have only that, never named).  Differences the
pair cannot tell apart (correlated estimates or power signatures, :func:`alias_table`)
are carried as an ``alias_set``.  Study: docs/concealed.md.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from types import SimpleNamespace

import numpy as np

from euc_sim.rides.compare.resolution import Resolution, bh_qvalues
from euc_sim.rides.grids.power import RHO_AIR
from euc_sim.simulation.effects import RECORDS

__all__ = ["Measured", "Tested", "Difference", "Differences", "FALSE_NAME_RATE", "ALIAS_CORRELATION", "physics",
           "parameters_from_fit", "difference_interval", "signature_columns",
           "alias_table", "with_qvalues", "ride_differences", "rider_sentence"]

#: The false-name rate controlled across a pair's tested physics (Benjamini–Hochberg q-values below it).
FALSE_NAME_RATE = 0.05
#: |correlation| of two signatures over both rides beyond which the pair cannot tell them apart.
ALIAS_CORRELATION = 0.9
def physics() -> tuple[str, ...]:
    """The physics a difference may be named for: the catalog's records with a compare face
    that is not a nuisance of the pair fit."""
    return tuple(e.name for e in RECORDS.having("compare") if e.compare.named)


@dataclass(frozen=True)
class Measured:
    """One ride's own estimate of a parameter: ``name``, ``estimate`` (in ``unit``, None where
    not identified) and its 95 % interval ``ci95``.
    """

    name: str
    estimate: float | None = None
    ci95: tuple[float, float] | None = None
    unit: str = ""


@dataclass(frozen=True)
class Tested:
    """One physics' pair fit (:func:`euc_sim.rides.compare.differences_report.pair_tests`).

    Attributes
    ----------
    estimate, ci95 : float, (float, float) or None
        OTHER minus LOG in the parameter's unit, and its 95 % interval.
    heldout_gain : float or None
        Fraction of OTHER's held-out error it removes.
    selected : bool
        Kept by the pair fit's forward selection.
    p_value, q_value : float or None
        One-sided p-value of the held-out test; its Benjamini–Hochberg q-value.
    alias_set, aliases : tuple of str
        The candidates the pair cannot tell it from (itself included); those correlating
        beyond :data:`ALIAS_CORRELATION`.
    detectable : Resolution or None
        The smallest difference the pair can name.
    resolution : float or None
        The finest delay the logs resolve, s.
    """

    estimate: float | None
    ci95: tuple[float, float] | None
    heldout_gain: float | None = None
    selected: bool = False
    p_value: float | None = None
    alias_set: tuple[str, ...] = ()
    aliases: tuple[str, ...] = ()
    detectable: Resolution | None = None
    resolution: float | None = None
    q_value: float | None = None


@dataclass(frozen=True)
class Difference:
    """OTHER minus LOG for one parameter (CONTRACT's ``differences`` entry): the pair fit's
    estimate where the physics is tested, else the rides' own differenced (``independent``).
    """

    name: str
    estimate: float | None
    ci95: tuple[float, float] | None
    unit: str
    named: bool
    why: str
    aliases: tuple[str, ...] = ()
    heldout_gain: float | None = None
    independent: tuple[float, tuple[float, float] | None] | None = None
    detectable: Resolution | None = None
    p_value: float | None = None
    q_value: float | None = None
    alias_set: tuple[str, ...] = ()

    @property
    def resolvable(self) -> float | None:
        """The smallest difference the pair can name, the parameter's unit; None where not tested."""
        return None if self.detectable is None else self.detectable.resolvable


@dataclass(frozen=True)
class Differences:
    """Every difference of a pair of rides, what the pair cannot see, and the page's sentence."""

    items: tuple[Difference, ...]
    cannot_see: dict = field(default_factory=dict)
    sentence: str = ""
    interval_method: str = ("one least-squares fit of both rides (shared terms, the difference on the "
                            "compared ride); 95 % interval: hull of a block bootstrap (each ride's 30 s "
                            "blocks drawn independently) and a jackknife-t over paired fifths of the "
                            "two rides")


# ---------------------------------------------------------------- the rides' parameters
def _entry(name, est, ci, unit) -> Measured:
    return Measured(name, est, tuple(ci) if ci else None, unit)


def parameters_from_fit(mass, terms) -> list[Measured]:
    """A ride's parameters as the pair comparison reads them: the total mass (statistical
    interval, kg), the drivetrain's ``terms`` (``C_rr`` → ``rolling_resistance``, ``C_dA`` →
    ``aerodynamic_drag`` k = ½ρC_dA kg/m) and the mass fit's lag → ``current_delay`` (s).
    """
    out = [_entry("total_mass", mass.estimate, mass.stat_ci95 or mass.ci95, "kg")]
    for name, t in terms.items():
        est, ci = t.estimate, t.ci95
        if name == "C_rr":
            out.append(_entry("rolling_resistance", est, ci, "1"))
        elif name == "C_dA":
            k = 0.5 * RHO_AIR
            out.append(_entry("aerodynamic_drag", None if est is None else k * est,
                              tuple(k * x for x in ci) if ci else None, "kg/m"))
        else:
            out.append(_entry(name, est, ci, t.unit or ""))
    if mass.lag is not None:
        out.append(_entry("current_delay", mass.lag, None, "s"))
    return out


# ---------------------------------------------------------------- intervals
def difference_interval(a: float, a_ci, b: float, b_ci, ratio: bool = False):
    """``b − a`` (or ``b/a − 1`` with ``ratio``, combined in logarithms) and its 95 % interval from
    the two rides' independent intervals ``a_ci``, ``b_ci``, added in quadrature side by side.
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


# ---------------------------------------------------------------- signatures and aliases
def signature_columns(v, av, P, t, current=None, climb=None, coef=None) -> dict[str, np.ndarray]:
    """Each physics' battery-power signature, W per unit of the parameter (its record's
    ``compare.signature``, in the records' ``compare.order``).

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
    faces = sorted((e for e in RECORDS.having("compare") if e.compare.signature is not None),
                   key=lambda e: e.compare.order)
    c = {e.name: e.compare.coef for e in RECORDS.having("compare") if e.compare.coef is not None}
    s = SimpleNamespace(v=v, av=av, P=P, t=t, current=current, climb=climb, coef={**c, **(coef or {})})
    cols = {e.name: e.compare.signature(s) for e in faces}
    return {n: col for n, col in cols.items() if col is not None}


def alias_table(columns: dict) -> tuple[dict, dict]:
    """Which signatures (:func:`signature_columns` over both rides) a pair cannot tell apart:
    each name's partners with |correlation| above :data:`ALIAS_CORRELATION`, and the names whose
    signature is constant or absent, with why.
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
            if a != b and abs(R[a, b]) > ALIAS_CORRELATION:
                aliases[names[i]].append(names[j])
    return aliases, cannot


# ---------------------------------------------------------------- the differences
def _independent(name, a: Measured, b: Measured):
    """(estimate, ci95) of the two rides' own estimates differenced, or None."""
    if a.estimate is None or b.estimate is None:
        return None
    if not a.ci95 or not b.ci95:
        return b.estimate - a.estimate, None
    d, ci = difference_interval(a.estimate, a.ci95, b.estimate, b.ci95, _ratio(name))
    return d, tuple(ci)


def _tested_why(name, tested: Tested, cannot: dict) -> tuple[bool, str]:
    ci, p, q = tested.ci95, tested.p_value, tested.q_value
    if name in cannot:
        return False, cannot[name]
    if ci is None:
        return False, "no interval from the pair fit: cannot be named"
    res = float(tested.resolution or 0.0)
    excl = bool(ci[0] > res or ci[1] < -res)
    sig = q is not None and q < FALSE_NAME_RATE
    g = (lambda x: "n/a" if x is None else f"{x:.2g}")   # noqa: E731
    why = (("significant" if sig else "not significant") + f" on the compared ride's held-out blocks (p = {g(p)}, "
           f"q = {g(q)} after the false-name control across the tested physics, level "
           f"{100 * FALSE_NAME_RATE:.0f} %); its interval " + ("excludes" if excl else "includes")
           + (" zero" if not res else f" ±{res:.2g} s (the finest delay these logs resolve: their row "
                                      "interval or the fit's grid step)"))
    return sig and excl, why


def _ratio(name) -> bool:
    """Whether the difference in ``name`` is a ratio minus 1 (its record's ``compare.ratio``)."""
    e = RECORDS.get(name) if name in RECORDS else None
    return bool(e is not None and e.compare is not None and e.compare.ratio)


def _one(name, a: Measured, b: Measured, tested, aliases, cannot) -> Difference:
    e = RECORDS.get(name) if name in RECORDS else None
    unit = b.unit or a.unit or (e.unit if name in physics() else "")
    unit = "1" if _ratio(name) else unit
    ind = _independent(name, a, b)
    if tested is not None and tested.estimate is not None:
        named, why = _tested_why(name, tested, cannot)
        if name not in physics():
            named, why = False, why + "; a nuisance of the pair fit, never named"
        ci = tested.ci95
        alias_set = tuple(x for x in tested.alias_set if x in physics()) if named else ()
        alias_set = alias_set if len(alias_set) > 1 else ()
        if alias_set:
            why += f"; this pair cannot tell {' from '.join(alias_set)} apart: each is possible, none certain"
        elif named and aliases:
            why += (f"; its estimate correlates beyond {ALIAS_CORRELATION:g} with {', '.join(aliases)}'s "
                    "in this pair (held out, it explains more than they do)")
        return Difference(name, tested.estimate, None if ci is None else tuple(ci), unit, named,
                          why, tuple(aliases), tested.heldout_gain, ind, tested.detectable,
                          tested.p_value, tested.q_value, alias_set)
    if ind is None:
        return Difference(name, None, None, unit, False, "not identified on "
                          + ("this ride" if a.estimate is None else "the compared ride"))
    why = ("not a physics the pair fit tests (state of the pack or controller)"
           if name not in physics() else "no pair fit possible on these rides: cannot be named")
    if ind[1] is None:
        why = "no interval on one ride: cannot be named"
    return Difference(name, ind[0], ind[1], unit, False, why, tuple(aliases), None, ind)


def with_qvalues(tested: Mapping[str, Tested]) -> dict[str, Tested]:
    """``tested`` (physics name -> its pair fit) with each tested physics' ``q_value``:
    Benjamini–Hochberg across those with a p-value.

    Nuisance candidates of the pair fit (never named) are not in the family.
    """
    family = [n for n in tested if n in physics() and tested[n].p_value is not None]
    q = bh_qvalues([tested[n].p_value for n in family])
    return {n: (replace(e, q_value=float(q[family.index(n)])) if n in family else e) for n, e in tested.items()}


def ride_differences(log_params: list, other_params: list, tested: Mapping[str, Tested], aliases: dict,
                     cannot_see: dict, log_name: str = "the other ride",
                     views: dict | None = None) -> Differences:
    """OTHER minus LOG for every parameter of both lists.

    Parameters
    ----------
    log_params, other_params : list of Measured
        The two rides' own estimates (:func:`parameters_from_fit`).
    tested : mapping of str -> Tested
        The pair fit of each physics tested.
    aliases, cannot_see : dict
        :func:`alias_table`.
    log_name : str
        How the sentence names LOG ("the 16 May ride").
    views : dict, optional
        The rides' own measures of a difference by key (``mass_difference``), taken as the
        ``independent`` detail of the physics whose record names it (``compare.view``).
    """
    a = {p.name: p for p in log_params}
    b = {p.name: p for p in other_params}
    tested = with_qvalues(tested)
    for name in tested:                 # a physics tested though one ride's list lacks it
        a.setdefault(name, Measured(name))
        b.setdefault(name, Measured(name))
    items = []
    for name in [n for n in a if n in b]:
        pa, pb = a[name], b[name]
        e = RECORDS.get(name) if name in RECORDS else None
        view = (views or {}).get(e.compare.view) if e is not None and e.compare is not None else None
        if view is not None and view.estimate is not None:
            pa = replace(pa, estimate=0.0, ci95=(0.0, 0.0))
            pb = replace(pb, estimate=view.estimate, ci95=tuple(view.ci95))
        items.append(_one(name, pa, pb, tested.get(name), aliases.get(name, []), cannot_see))
    return Differences(tuple(items), dict(cannot_see), rider_sentence(items, log_name))


def _word(name: str) -> str:
    """A physics in one word or two, for an alias set ("drag or rolling resistance")."""
    e = RECORDS.get(name) if name in RECORDS else None
    return e.words.word if e is not None and e.words is not None else name.replace("_", " ")


def rider_sentence(items, log_name: str) -> str:
    """One sentence for the page: the named differences in a rider's words, an ``alias_set``
    said as the set ("drag or rolling resistance: this pair cannot tell them apart").
    """
    parts, sets = [], []
    for d in items:
        w = RECORDS.get(d.name).words if d.named and d.name in RECORDS else None
        if w is None:
            continue
        more, less, fmt = w.said
        size = f"{fmt.format(abs(d.estimate))} {more if d.estimate > 0 else less}"
        if d.alias_set:
            words = " or ".join(_word(n) for n in d.alias_set)
            sets.append(f"{words}: this pair cannot tell them apart ({size} if it is {w.word})")
        else:
            parts.append(f"{size} ({w.hint})")
    if not parts and not sets:
        return f"this ride needed nothing its log can show that {log_name} did not."
    said = [f"this ride needed {'; '.join(parts)} than {log_name}"] if parts else []
    if sets:
        said.append(("it also differs by " if parts else f"this ride differs from {log_name} by ")
                    + "; ".join(sets))
    return "; ".join(said) + "."

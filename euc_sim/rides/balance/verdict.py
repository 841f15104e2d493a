"""The one-line verdict of a ride: what it names, and what it refuses to name.

An accepted effect whose estimate is implausible is a candidate, not the verdict, and a
log whose V·I is not battery power gets no battery-power verdict (:func:`ride_verdict`).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Mapping, Sequence

__all__ = ["Verdict", "ride_verdict", "verdict_of", "unit_label", "on_the_edge", "NOT_EXPLAINED"]

#: The verdict when every accepted effect is implausible.
NOT_EXPLAINED = "the mismatch is not explained by a plausible effect"


def unit_label(unit: str) -> str:
    """A unit for people: ``"1"`` (a ratio) is written "dimensionless", the rest as given."""
    return "dimensionless" if unit in ("1", "", None) else str(unit)


@dataclass(frozen=True)
class Verdict:
    """The ride's one-line verdict: ``battery_power`` (whether V·I is battery power), ``named``
    (the accepted, plausible effects in order), ``candidates`` (accepted but implausible:
    never named), ``text`` (one sentence), ``why`` (no battery-power verdict).
    """

    battery_power: bool
    named: tuple[str, ...]
    candidates: tuple[str, ...]
    text: str
    why: str | None = None


def verdict_of(cross, parameters, not_power: str | None = None, error_unit: str = "W") -> Verdict:
    """:func:`ride_verdict` of a CrossRide and the ride's ``parameters``; ``not_power`` says why
    V·I is not battery power, if it is not.
    """
    by = {p.name: p for p in parameters if p.source == "balance"}
    held = [c for c in cross.selected if c not in cross.accepted]
    return ride_verdict([by[c] for c in cross.accepted], cross.selection, held, error_unit, not_power)


def ride_verdict(effects: Sequence, selection: Sequence[Mapping] = (), held: Sequence[str] = (),
                 error_unit: str = "W", not_power: str | None = None) -> Verdict:
    """The verdict of a ride's balance fit.

    ``effects``: the accepted effects' Parameter entries in the order kept; ``selection``:
    the held-out steps (``term``, ``heldout_rmse`` in ``error_unit``); ``held``: terms kept but
    left out of the balance; ``not_power``: why V·I is not battery power (nothing named).
    """
    named = tuple(e.name for e in effects if e.plausible)
    cand = tuple(e.name for e in effects if not e.plausible)
    shown = {e.name: _with_numbers(e) for e in effects}
    if not_power is not None:
        return Verdict(False, (), tuple(e.name for e in effects),
                       "no battery-power verdict: this log's V·I is not battery power, so "
                       "nothing is named from it", not_power)
    if named:
        text = "the inertia-only model leaves out " + ", ".join(named)
        edge = [e.name for e in effects if e.plausible and e.on_bound]
        if edge:
            text += "; " + on_the_edge(edge)
        if cand:
            text += (f"; also accepted but implausible (candidates, not named): "
                     f"{'; '.join(shown[c] for c in cand)}")
        left = [c for c in held if c not in named]
        if left:
            text += (f"; {', '.join(left)} would lower the held-out error further only in a "
                     f"model with a term outside its plausible range: not named")
    elif cand:
        text = f"{NOT_EXPLAINED} (candidates, each implausible: {'; '.join(shown[c] for c in cand)})"
    elif held:
        text = NOT_EXPLAINED + _why_nothing(selection, held, error_unit)
    else:
        text = "nothing is missing that this ride can reveal" + _why_nothing(selection, held, error_unit)
    return Verdict(True, named, cand, text)


def on_the_edge(names: list[str]) -> str:
    """The named terms that sit on an edge of their plausible ranges, in words (their values
    are the estimates' table's)."""
    one = len(names) == 1
    listed = names[0] if one else ", ".join(names[:-1]) + " and " + names[-1]
    return (f"{listed} {'sits' if one else 'sit'} on the edge of {'its' if one else 'their'} plausible "
            f"range{'' if one else 's'}: the ride asks for more than plausible physics gives, and the "
            f"rest is not explained")


def _why_nothing(selection, held, unit: str) -> str:
    """Why no effect was accepted, with the numbers: the held-out selection kept none."""
    if not selection:
        return ""
    if held:
        return (f": {', '.join(held)} would lower the held-out error only in a model with a "
                f"term outside its plausible range, so nothing is named")
    return (f": no candidate lowers the blocked held-out error of the inertia-only balance "
            f"({selection[0]['heldout_rmse']:.0f} {unit}) enough to be kept")


def _with_numbers(e) -> str:
    """``name estimate unit (plausible lo–hi)``: an effect in words."""
    u = unit_label(e.unit)
    rng = e.plausible_range
    out = f"{e.name} {e.estimate:.3g} {u}"
    return out + (f" (plausible {rng[0]:.3g}–{rng[1]:.3g})" if rng else "")

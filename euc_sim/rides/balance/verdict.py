"""The one-line verdict of a ride: what it names, and what it refuses to name.

A ride page must never contradict itself: an effect the balance fit
accepts but whose estimate lies outside its plausible range is a *candidate*,
not the verdict, and a log whose V·I is not battery power gets no
battery-power verdict at all.  :func:`ride_verdict` turns the ``euc-sim ride``
report into ``{"text", "named", "candidates", "battery_power"}``; the page
and the console print it as it is.
"""

from __future__ import annotations

__all__ = ["ride_verdict", "unit_label", "on_the_edge", "NOT_EXPLAINED"]

#: The verdict when every accepted effect is implausible.
NOT_EXPLAINED = "the mismatch is not explained by a plausible effect"


def unit_label(unit: str) -> str:
    """A unit for people: ``"1"`` (a ratio) is written "dimensionless", the rest as given."""
    return "dimensionless" if unit in ("1", "", None) else str(unit)


def ride_verdict(report: dict) -> dict:
    """The verdict of an ``euc-sim ride`` report.

    Parameters
    ----------
    report : dict
        The ride JSON (``effects``, ``unidentified``, ``heldout_error_nominal``,
        ``heldout_error_augmented``, ``ratio``, ``error_unit``).

    Returns
    -------
    dict
        ``battery_power`` (bool: whether the log's V·I is battery power),
        ``named`` (the accepted effects whose estimates are plausible, strongest
        first), ``candidates`` (accepted but implausible: listed, never named),
        ``text`` (one sentence) and ``why`` (the reason, when there is no
        battery-power verdict).
    """
    not_power = (report.get("unidentified") or {}).get("battery_power")
    effects = report.get("effects") or []
    named = [e["name"] for e in effects if e.get("plausible", True)]
    cand = [e["name"] for e in effects if not e.get("plausible", True)]
    shown = {e["name"]: _with_numbers(e) for e in effects}
    out = {"battery_power": not_power is None, "named": named, "candidates": cand}
    if not_power is not None:
        out["text"] = ("no battery-power verdict: this log's V·I is not battery power, so "
                       "nothing is named from it")
        out["why"] = not_power
        out["named"], out["candidates"] = [], [e["name"] for e in effects]
        return out
    if named:
        text = "the inertia-only model leaves out " + ", ".join(named)
        edge = [e["name"] for e in effects if e.get("plausible", True) and e.get("on_bound")]
        if edge:
            text += "; " + on_the_edge(edge)
        if cand:
            text += (f"; also accepted but implausible (candidates, not named): "
                     f"{'; '.join(shown[c] for c in cand)}")
        held = [c for c in report.get("selected_not_accepted") or [] if c not in named]
        if held:
            text += (f"; {', '.join(held)} would lower the held-out error further only in a "
                     f"model with a term outside its plausible range: not named")
    elif cand:
        text = f"{NOT_EXPLAINED} (candidates, each implausible: {'; '.join(shown[c] for c in cand)})"
    elif report.get("selected_not_accepted"):
        text = NOT_EXPLAINED + _why_nothing(report)
    else:
        text = "nothing is missing that this ride can reveal" + _why_nothing(report)
    out["text"] = text
    return out


def on_the_edge(names: list[str]) -> str:
    """The named terms that sit on an edge of their plausible ranges, in words (their values
    are the estimates' table's)."""
    one = len(names) == 1
    listed = names[0] if one else ", ".join(names[:-1]) + " and " + names[-1]
    return (f"{listed} {'sits' if one else 'sit'} on the edge of {'its' if one else 'their'} plausible "
            f"range{'' if one else 's'}: the ride asks for more than plausible physics gives, and the "
            f"rest is not explained")


def _why_nothing(report: dict) -> str:
    """Why no effect was accepted, with the numbers: the held-out selection kept none."""
    sel = report.get("selection") or []
    if not sel:
        return ""
    u = report.get("error_unit", "W")
    held = report.get("selected_not_accepted") or []
    if held:
        return (f": {', '.join(held)} would lower the held-out error only in a model with a "
                f"term outside its plausible range, so nothing is named")
    return (f": no candidate lowers the blocked held-out error of the inertia-only balance "
            f"({sel[0]['heldout_rmse']:.0f} {u}) enough to be kept")


def _with_numbers(e: dict) -> str:
    """``name estimate unit (plausible lo–hi)``: an effect entry in words."""
    u = unit_label(e.get("unit"))
    rng = e.get("plausible_range")
    out = f"{e['name']} {e['estimate']:.3g} {u}"
    return out + (f" (plausible {rng[0]:.3g}–{rng[1]:.3g})" if rng else "")

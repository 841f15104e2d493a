"""The ride page's notes in words for people: each said once, beside the tile that counts it.

:func:`summarise_notes` folds a ride's gaps, too-short pieces and empty cells into one line
each (the JSON keeps every one); :func:`said_once` drops from a simulation note the fitted
values the page's tables already give; :func:`as_the_tile` words the reader's sampling note
as the Data quality tile counts; :func:`missing_spec_effect` says what a value the wheel's
specification lacks changes.
"""

from __future__ import annotations

import re

from euc_sim.rides.source.gaps import GAP_POLICY

__all__ = ["summarise_notes", "said_once", "as_the_tile", "missing_spec_effect"]


#: A simulation note's repeat of a fitted value the page gives in its own table: (pattern, words kept).
_REPEATS = ((re.compile(r"\b(\w+) = [-+\d.e]+ (is electrical)"), r"\1 \2"),
            (re.compile(r"\b(\w+) = [-+\d.e]+ [^ ]* ?(measured but not simulated)"), r"\1 \2"),
            (re.compile(r"\bK_d measured [-+\d.e]+ N·m·s/rad, 95 % interval \[[^\]]*\]: "),
             "K_d as measured (the law's table): "))


def said_once(note: str) -> str:
    """A simulation note without the fitted values the page's tables already give
    (an electrical loss, a law term not simulated, the measured K_d)."""
    for rx, keep in _REPEATS:
        note = rx.sub(keep, note)
    return note


_OWN_GAPS = re.compile(r"\d+ gap\(s\) longer than ([\d.]+) s")
_MEDIAN_HZ = re.compile(r"\(median ([\d.]+) s, about ([\d.]+) Hz\)")


def as_the_tile(note: str, hz: float | None) -> str:
    """The reader's sampling note beside the Data quality tile: its gap count said as the
    tile counts gaps, and its median interval's rate not as a second rate of the log (the
    tile's ``hz``, samples/s, is the whole log's): well above it, as the rate within bursts
    between gaps; near it, left out (the median interval said alone)."""
    note = _OWN_GAPS.sub(r"gaps longer than \1 s as the tile counts", note)
    m = _MEDIAN_HZ.search(note)
    if m is None or not hz:
        return note
    if float(m[2]) <= 2.0 * hz:
        return note.replace(m[0], f"(median {m[1]} s between rows; the tile's rate counts the whole log)")
    return note.replace(m[0], f"(median {m[1]} s: {m[2]} Hz within bursts between gaps; the tile's rate "
                              f"counts the whole log)")


def missing_spec_effect(missing) -> str:
    """What a spec value not given changes, in words."""
    out = []
    if "wheel radius" in missing:
        out.append("the balance fit takes Table 3's R = 0.2 m, the back-EMF constant is not converted")
    if "net weight" in missing:
        out.append("the mass found is m_eq, the wheel's rotating inertia not taken out")
    if "battery voltage" in missing:
        out.append("the cut-out chart and the envelope turn the charge into volts from the log's voltage alone")
    return "; ".join(out)


_GAP = re.compile(r"^(?P<who>.*?)gap of (?P<len>[\d.]+) s at t = (?P<t>[\d.]+) s "
                  r"\(> max_gap (?P<max>[\d.]+) s\): ride split there, not bridged$")
_BRIDGED = re.compile(r"^(?P<who>.*?)gap of (?P<len>[\d.]+) s at t = (?P<t>[\d.]+) s bridged linearly$")
_SHORT = re.compile(r"^(?P<who>.*?)segment \d+ has (?P<n>\d+) samples, fewer than the "
                    r"(?P<win>\d+)-sample filter window: left out$")
_EMPTY = re.compile(r"^(?P<who>(?:\S+\.csv: )?)(?P<col>\w+): (?P<n>\d+) of (?P<rows>\d+) cells empty "
                    r"\(kept as NaN\)$")


def _empty_cells(g: list, rows: str) -> str:
    """"empty cells ... : a, b 540 each, c 5" of ``[(column, count), ...]``, equal counts together."""
    by: dict[int, list[str]] = {}
    for col, n in g:
        by.setdefault(n, []).append(col)
    parts = [", ".join(cols) + (f" {n} each" if len(cols) > 1 else f" {n}") for n, cols in by.items()]
    return f"empty cells (of {rows} rows; kept as NaN): " + "; ".join(parts)


def _gap_summary(g: list, shown: int, at=None) -> str:
    """"count (total, longest; at …)" of gaps ``[(length, t), ...]``, s; each moment as ``at(t)``
    says it, else "t = … s"."""
    lens = [x[0] for x in g]
    more = ", …" if len(g) > shown else ""
    when = (", ".join(at(x[1]) for x in g[:shown]) + more if at else
            "t = " + ", ".join(f"{x[1]:.0f}" for x in g[:shown]) + more + " s")
    return f"{len(g)} logging gap(s) (total {sum(lens):.1f} s, longest {max(lens):.2f} s; at {when})"


def summarise_notes(notes, shown: int = 5, at=None) -> list[str]:
    """The notes for people: a ride's gaps (count, total, longest), its too-short segments
    and its columns' empty cells in one line each (the JSON keeps every one); the other
    notes as they are, in order.  ``at(who, t)``, given a note's ride prefix ("2.csv: " or
    '') and a time in s from that log's start, says the gaps' moments (clock time and time
    into the ride); without it they are said in s."""
    groups: dict[tuple, list] = {}
    out: list = []
    for n in notes:
        m, b, k, e = _GAP.match(n), _BRIDGED.match(n), _SHORT.match(n), _EMPTY.match(n)
        key = (("split", m["who"], m["max"]) if m else ("bridged", b["who"], "") if b
               else ("short", k["who"], k["win"]) if k else ("empty", e["who"], e["rows"]) if e else None)
        if key is None:
            out.append(n)
            continue
        if key not in groups:
            out.append(key)
        x = m or b
        groups.setdefault(key, []).append((float(x["len"]), float(x["t"])) if x else
                                          (e["col"], int(e["n"])) if e else int(k["n"]))
    lines = []
    for item in out:
        if isinstance(item, str):
            lines.append(item)
            continue
        kind, who, arg = item
        g = groups[item]
        moment = (lambda t, who=who: at(who, t)) if at else None
        if kind == "split":
            lines.append(f"{who}{_gap_summary(g, shown, moment)} longer than {arg} s split the ride there "
                         f"for every fit (balance, mass, law): not bridged (every one is listed in "
                         f"the JSON's notes)")
        elif kind == "empty":
            lines.append(who + _empty_cells(g, arg))
        elif kind == "bridged":
            lines.append(f"{who}{_gap_summary(g, shown, moment)} longer than {GAP_POLICY.gap:g} s bridged linearly "
                         f"in the simulated speed profile (every one is listed in the JSON's notes)")
        else:
            lines.append(f"{who}{len(g)} piece(s) between gaps shorter than the "
                         f"{arg}-sample filter window ({sum(g)} samples in all) left out")
    return lines

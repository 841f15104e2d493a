"""What differs between two rides, in a rider's words: the ``--compare`` page's first block.

Read from the ride's :class:`~euc_sim.rides.compare.differences.Differences` (OTHER minus LOG per
parameter: ``name``, ``estimate``, ``ci95``, ``unit``, ``named``, ``aliases``) and its ``sentence``
(which names LOG's day); nothing is computed here but people's units: drag as a drag
area (m², k = ½ρC_dA), rolling resistance as a share of the weight (%), battery
resistance in mΩ, the speed scale in %, mass in kg, a delay in s.  Each named
difference comes with its 95 % interval and what the pair cannot tell it from; with
nothing named, one sentence says so and what the pair could have seen (each
entry's ``resolvable``, the smallest difference the pair can name, computed with the
differences; the interval's half-width where there is none), and, where an
estimate lies below it, that the pair cannot resolve less.  A difference the key figures
show both values of (the mass, the battery's resistance) is said once, as those values'
difference with its interval, and the paired test's verdict beside it.

Given LOG's path, where both logs sit beside an euc_core ``meta.csv`` (rider weight,
tyre pressure, temperature, wind), the recorded values are said beside the
difference they bear on, once, in the block both pages share.
"""

from __future__ import annotations

import csv
import re
from pathlib import Path
from euc_sim.model.catalog import Words
from euc_sim.simulation.effects import RECORDS

__all__ = ["Shown", "SHOWN", "TITLE", "KEY_FIGURES", "difference_lines", "difference_section", "recorded_metadata"]

#: The block's heading, on the page and in index.md.
TITLE = "What differs in the compared ride"


#: Each physics a difference is said for (the catalog's records with words), in the catalog's
#: order, read live: name -> :class:`~euc_sim.model.catalog.Words`.
SHOWN = RECORDS.view("words")
Shown = Words
#: meta.csv columns said beside a difference: (words, unit).
META_WORDS = {"rider_weight": ("rider weight", " kg"), "tire_pressure": ("tyre pressure", " bar"),
              "temperature": ("temperature", " °C"), "wind": ("wind", "")}


def _size(s: Shown, x: float) -> str:
    return s.fmt.format(abs(s.scale(x))) + s.unit


def _signed(s: Shown, x: float) -> str:
    v, shown = s.scale(x), s.fmt.format(abs(s.scale(x)))
    return ("" if float(shown) == 0 else "+" if v > 0 else "−" if v < 0 else "") + shown


def _interval(s: Shown, ci) -> str:
    return f"{_signed(s, ci[0])} to {_signed(s, ci[1])}{s.unit}"


def _log_day(sentence: str) -> str:
    """LOG's day as the differences' sentence names it ("16 May"), or ''."""
    m = re.search(r"\bthe (\d{1,2} [A-Z]\w+) ride\b", sentence or "")
    return m[1] if m else ""


def _meta_row(log_path) -> dict | None:
    f = Path(str(log_path)).parent / "meta.csv"
    try:
        with open(f, newline="") as fh:
            return next(csv.DictReader(fh), None)
    except (OSError, csv.Error, UnicodeDecodeError):
        return None


def _sibling(log_path, other_name: str) -> Path:
    """OTHER beside LOG in euc_core's layout (``trips/BRAND/MODEL/N/N.csv``), else in LOG's folder."""
    log_path = Path(str(log_path))
    stem = Path(other_name).stem
    cand = log_path.parents[1] / stem / other_name if len(log_path.parents) > 1 else None
    return cand if cand is not None and cand.is_file() else log_path.parent / other_name


def recorded_metadata(compare: str | None, log_path=None) -> dict[str, str]:
    """``{parameter: "the logs record rider weight 85 → 92 kg"}`` from both logs' ``meta.csv``
    (euc_core's layout: LOG at ``log_path``, OTHER its sibling ride of the file name ``compare``);
    empty without ``log_path``, where either log has none or a value is blank."""
    if log_path is None or not compare:
        return {}
    other = _sibling(log_path, Path(str(compare)).name)
    if other.resolve() == Path(str(log_path)).resolve():
        return {}
    a, b = _meta_row(log_path), _meta_row(other)
    if not a or not b:
        return {}
    out = {}
    for name, s in SHOWN.items():
        if s.meta and (a.get(s.meta) or "").strip() and (b.get(s.meta) or "").strip():
            words, unit = META_WORDS[s.meta]
            out[name] = f"the logs record {words} {a[s.meta].strip()} → {b[s.meta].strip()}{unit}"
    return out


def _aliases(d) -> str:
    names = " or ".join(SHOWN[a].label if a in SHOWN else a.replace("_", " ") for a in d.alias_set or d.aliases)
    if d.alias_set:
        return f"{names}: this pair cannot tell them apart"
    return (f"cannot be told apart from {names} on these two rides" if names
            else "told apart from the other physics on these two rides")


#: The differences whose two values the key figures show, each ride's own fit (the tiles):
#: said as those fits' difference (``independent``), never as the paired test's size.
KEY_FIGURES = ("total_mass", "internal_resistance")


def _own_fits(d) -> bool:
    """Whether the :class:`~euc_sim.rides.compare.differences.Difference` ``d`` is said as the key
    figures' difference (:data:`KEY_FIGURES`, with an interval)."""
    return d.name in KEY_FIGURES and bool(d.independent and d.independent[1])


def _own_words(d) -> str:
    """"each ride's own fit (the key figures) differs by +22 kg (95 % interval −21 to +51 kg)"."""
    s, (est, ci) = SHOWN[d.name], d.independent
    return (f"each ride's own fit (the key figures) differs by {_signed(s, est)}{s.unit} "
            f"(95 % interval {_interval(s, ci)})")


def _test_words(d) -> str:
    """The paired test's verdict on ``d`` in short: "not significant, p = 0.071, q = 0.14" (and
    "its own interval includes zero" where that is why), else its ``why`` as written."""
    why, p, q = d.why or "not significant", d.p_value, d.q_value
    sig = next((w for w in ("not significant", "significant") if why.startswith(w)), None)
    if sig is None or p is None:
        return why
    return (f"{sig}, p = {p:.2g}" + (f", q = {q:.2g}" if q is not None else "")
            + ("; its own interval includes zero" if "interval includes" in why else ""))


def _resolvable(d) -> float:
    """The smallest difference the pair can name: ``resolvable``, else the interval's half-width."""
    r = d.resolvable
    return float(r) if r is not None else 0.5 * (d.ci95[1] - d.ci95[0])


def _listed(ds: list) -> str:
    """"mass ±23 kg, rolling resistance ±1.1 % of the weight" (:func:`_resolvable`, the page's order)."""
    return ", ".join(f"{SHOWN[d.name].label} ±{_size(SHOWN[d.name], _resolvable(d))}"
                     for d in sorted(ds, key=lambda d: list(SHOWN).index(d.name)))


def difference_lines(res, compare: str | None, log_path=None) -> list[str]:
    """The block's Markdown lines (no heading) of the
    :class:`~euc_sim.rides.compare.differences.Differences` ``res`` (OTHER, the file ``compare``,
    minus LOG); empty without any.

    The first line is the rider's sentence (each named difference's size and hint),
    then one line per named difference (its 95 % interval, what it cannot be told
    from, the metadata recorded, :func:`recorded_metadata` of LOG at ``log_path``),
    then what the pair could have seen of the rest (each entry's ``resolvable``,
    the smallest difference the pair can name, else its interval's half-width),
    which of the rest the pair cannot resolve (an estimate below ``resolvable``), and
    each one the key figures show (:data:`KEY_FIGURES`) as the rides' own fits' difference
    (``independent``) with the paired test's why: one statement of it on the page (the mass
    section points here).
    """
    diffs = [d for d in (res.items if res is not None else ()) if d.name in SHOWN]
    if not diffs:
        return []
    other = f"the compared ride ({Path(str(compare or '')).name})"
    day = _log_day(res.sentence)
    this = f"this ride ({day})" if day else "this ride"
    meta = recorded_metadata(compare, log_path)
    named = sorted((d for d in diffs if d.named and d.estimate is not None and d.ci95),
                   key=lambda d: list(SHOWN).index(d.name))
    own = [d for d in diffs if d not in named and _own_fits(d)]
    rest = [d for d in diffs if d not in named and d not in own and d.estimate is not None and d.ci95]
    if named:
        parts = [f"{_size(s, d.estimate)} "
                 + (f"{s.more} ({s.hint})" if d.estimate > 0 else f"{s.less} ({s.hint_less})")
                 for d, s in ((d, SHOWN[d.name]) for d in named)]
        out = [f"**{other[0].upper() + other[1:]} needed {'; '.join(parts)} than {this}.**", ""]
        for d in named:
            s = SHOWN[d.name]
            out.append(f"- {s.label[0].upper() + s.label[1:]}: 95 % interval {_interval(s, d.ci95)}; "
                       f"{_aliases(d)}" + (f"; {meta[d.name]}" if d.name in meta else "")
                       + (f"; {_own_words(d)}" if _own_fits(d) else "") + ".")
    else:
        out = [f"**Nothing differs between {this} and {other} that this pair of rides can show.**"]
    below = [d for d in rest if d.resolvable is not None and abs(d.estimate) < d.resolvable]
    seen = _listed([d for d in rest if d not in below])
    if seen:
        if named:
            out.append(f"- Nothing else named; the smallest differences this pair could have seen: {seen}.")
        else:
            out[0] += f" The smallest differences it could have seen: {seen}."
    if below:
        said_below = (f"This pair cannot resolve differences smaller than {_listed(below)}: "
                      + ("its estimate lies below that, so whether the rides differ by it" if len(below) == 1
                         else "their estimates lie below that, so whether the rides differ by them")
                      + " cannot be said.")
        if named:
            out.append(f"- {said_below}")
        else:
            out[0] += f" {said_below}"
    for d in own:                   # the key figures' difference, with the paired test's verdict
        ci, s = d.independent[1], SHOWN[d.name]
        out.append(f"- {s.label[0].upper() + s.label[1:]}: {_own_words(d)}"
                   + (", but the paired test does not name it (" if ci[0] > 0 or ci[1] < 0 else
                      ": cannot tell, nor can the paired test (") + f"{_test_words(d)}).")
    said = list(dict.fromkeys(meta[d.name] for d in diffs if d.name in meta))
    if said and not named:
        out += ["", "For comparison, the logs' metadata record "
                + ", ".join(x.removeprefix("the logs record ") for x in said) + "."]
    return out


def difference_section(res, compare: str | None, log_path=None) -> list[str]:
    """index.md's section: :data:`TITLE` and :func:`difference_lines` (empty without differences)."""
    lines = difference_lines(res, compare, log_path)
    return [f"## {TITLE}", ""] + lines + [""] if lines else []

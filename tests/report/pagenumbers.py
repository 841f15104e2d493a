"""The quantities a ride page shows: labelled values, by section, for the "every number once" checks.

A quantity is a value next to a label the page uses for one of the ride's fitted or
summary quantities (:data:`VOCABULARY`: "Total mass", ``total_mass``, "m_eq", "Battery
resistance", ``internal_resistance``, ``C_rr``, ...): the first number after the label
(within :data:`SEP` characters holding no digit, no sentence end), or, for a difference,
the number before "more"/"less" and the label.  Values are read in SI (kg, Ω, W, m/s,
dimensionless) with the page's unit; a value preceded by "±" is a resolution, its own
quantity.  In the section of the differences every quantity is a difference (Δ).

:func:`html_sections` splits an ``index.html`` into the tiles, the boxes, the lead and each
section; :func:`md_sections` an ``index.md`` at its ``##`` headings.  :func:`problems`
lists what breaks "every number once": one quantity with two values, one quantity in two
sections, an efficiency above 100 %.
"""

from __future__ import annotations

import html
import re
from dataclasses import dataclass, replace

from euc_sim.rides.grids.power import RHO_AIR

#: canonical name -> (label pattern, case-insensitive, whole words; the units its value may carry).
VOCABULARY = {
    "total_mass": (r"total mass|total_mass|Total mass", ("kg",)),
    "m_eq": (r"m_eq", ("kg",)),
    "internal_resistance": (r"battery resistance|internal_resistance|internal resistance|R_int",
                            ("mΩ", "Ω", "ohm", "")),
    "rolling_resistance": (r"rolling_resistance|C_rr|rolling resistance", ("", "%")),
    "aerodynamic_drag": (r"aerodynamic_drag|C_dA|drag area", ("", "kg/m", "m²")),
    "eta_motor": (r"eta_motor|η_motor|η_m", ("", "%")),
    "eta_regen": (r"eta_regen|η_regen|η_r", ("", "%")),
    "speed_scale": (r"speed_scale|speed scale", ("", "%")),
    "top_speed": (r"top speed", ("km/h", "m/s")),
    "distance": (r"distance", ("km", "m")),
    "energy_drawn": (r"energy drawn", ("Wh",)),
    "consumption": (r"consumption", ("Wh/km",)),
    "heldout_inertia_only": (r"held-out error: inertia-only|\(held out\): RMS inertia-only", ("W", "N·m")),
    "heldout_augmented": (r"(?:held-out error: inertia-only|\(held out\): RMS inertia-only) [\d.]+ (?:W|N·m), "
                          r"augmented|balance fit's held-out battery-power error is", ("W", "N·m", "")),
    "heldout_ratio": (r"ratio", ("",)),
    "max_pwm": (r"Max PWM|motor used", ("%",)),
}
#: canonical name -> the words after a number that label it ("2.9 samples/s", "409 gap(s)").
AFTER = {"sampling_rate": r"samples/s", "gaps": r"gap\(s\)|gaps\b"}
#: Most characters between a label and its value.
SEP = 90
#: unit -> factor to SI (the unit as the page prints it).
UNITS = {"kg": 1.0, "mΩ": 1e-3, "ohm": 1.0, "Ω": 1.0, "%": 1e-2, "km/h": 1 / 3.6, "m/s": 1.0,
         "W": 1.0, "Wh": 1.0, "Wh/km": 1.0, "km": 1e3, "m": 1.0, "m²": 1.0, "kg/m": 1.0, "s": 1.0,
         "V": 1.0, "N·m": 1.0}
_NUM = r"([+\-−]?\d+(?:\.\d+)?(?:e[+\-]?\d+)?)"
_UNIT = r"(?:\s*(" + "|".join(re.escape(u) for u in sorted(UNITS, key=len, reverse=True)) + r"))?"
_END = r"(?=[\s,;:.)|*\]]|$)"
#: Words in the gap between a label and a number that make the number another's.
_OTHERS = re.compile(r"[.;]\s|\(|\b(?:to|from|of|per|at|over|against|by|than|on|in)\b")


@dataclass(frozen=True)
class Quantity:
    """One labelled value on the page."""

    name: str
    value: float          # SI (the page's unit converted)
    shown: str            # the number as printed
    unit: str
    section: str
    context: str

    @property
    def decimals(self) -> int:
        return len(self.shown.split(".")[1]) if "." in self.shown else 0


def _float(s: str) -> float:
    return float(s.replace("−", "-"))


def _q(name, num, unit, section, context) -> Quantity:
    si = _float(num) * UNITS.get(unit, 1.0)
    if name.lstrip("Δ±") == "aerodynamic_drag" and unit == "m²":
        si *= 0.5 * RHO_AIR                   # a drag area said as k = ½ρC_dA, the parameter's unit
    return Quantity(name, si, num, unit, section, context)


def canonical(label: str) -> str | None:
    """The vocabulary's name of a table's row label, or None."""
    label = label.strip().strip("`*+ ").strip()
    for name, (rx, _) in VOCABULARY.items():
        if re.fullmatch(rf"(?:{rx})", label, re.I):
            return name
    return None


def table_quantities(section: str, rows: list[list[str]], prefix: str = "") -> list[Quantity]:
    """A table's estimates: the row's label (first cell) and its ``estimate`` column."""
    if not rows:
        return []
    head = [h.lower() for h in rows[0]]
    col = next((i for i, h in enumerate(head) if "estimate" in h), None)
    unit_col = next((i for i, h in enumerate(head) if h.strip() == "unit"), None)
    out = []
    for r in rows[1:]:
        name = canonical(r[0]) if r else None
        if name is None or col is None or col >= len(r):
            continue
        m = re.fullmatch(rf"\s*\**{_NUM}\**\s*", r[col])
        if m:
            unit = r[unit_col].strip() if unit_col is not None and unit_col < len(r) else ""
            out.append(_q(prefix + name, m[1], unit if unit in UNITS else "", section, " | ".join(r)))
    return out


def prose_quantities(section: str, text: str, prefix: str = "") -> list[Quantity]:
    """Every labelled value of a section's prose (tables taken out)."""
    text = re.sub(r"95\s?%(?: interval)?:?\s*(?:[+\-−]?[\d.]+\s*(?:to|–|-)\s*[+\-−]?[\d.]+)?", " CI ", text)
    out = []
    for name, (label, units) in VOCABULARY.items():
        rx = re.compile(rf"(?<![\w])(?:{label})(?![\w])([^0-9\n]{{0,{SEP}}}?)(±)?{_NUM}{_UNIT}{_END}", re.I)
        for m in rx.finditer(text):
            if _OTHERS.search(re.sub(r"\([^()]*\)", "", m[1])) or (m[4] or "") not in units:
                continue                      # the number belongs to something else
            out.append(_q(("±" if m[2] else prefix) + name, m[3], m[4] or "", section,
                          text[max(0, m.start() - 20):m.end() + 20]))
        rx = re.compile(rf"{_NUM}{_UNIT}\s+(?:more|less)\s+(?:{label})", re.I)
        for m in rx.finditer(text):
            out.append(_q("Δ" + name, m[1], m[2] or "", section, text[max(0, m.start() - 20):m.end() + 20]))
    for name, label in AFTER.items():
        for m in re.finditer(rf"(?<![\w.]){_NUM}\s+(?:{label})", text):
            line = text[text.rfind("\n", 0, m.start()) + 1:m.start()]
            ride = re.match(r"\W*(\S+\.csv): ", line)          # a note on the compared ride
            out.append(_q((f"{ride[1]}: " if ride else "") + prefix + name, m[1], "", section,
                          text[max(0, m.start() - 20):m.end() + 20]))
    return out


def quantities(section: str, text: str, differences: bool = False) -> list[Quantity]:
    """Every labelled value of one section's text: its tables' estimates and its prose."""
    prefix = "Δ" if differences else ""
    prose, tables, cur = [], [], []
    for line in text.splitlines():
        if line.strip().startswith("|"):
            cells = [c.strip() for c in re.split(r"(?<!\\)\|", line.strip())[1:-1]]
            if not all(set(c) <= set("-: ") for c in cells):
                cur.append(cells)
            continue
        if cur:
            tables.append(cur)
            cur = []
        prose.append(line)
    if cur:
        tables.append(cur)
    out = prose_quantities(section, "\n".join(prose), prefix)
    for t in tables:
        out += table_quantities(section, t, prefix)
    return out


def _text(fragment: str) -> str:
    """Plain text; a table row becomes a ``| a | b |`` line as in Markdown."""
    t = re.sub(r"<script\b.*?</script>", " ", fragment, flags=re.S)
    t = re.sub(r"<tr>", "\n| ", t)          # one line per row, a blank line after the table
    t = re.sub(r"</(td|th)>", " | ", t)
    t = re.sub(r"</?(thead|tbody|tr)>", "", t)
    t = re.sub(r"</table>", "\n\n", t)
    t = re.sub(r"<(br|/p|/li|/div|/h\d|ul|/ul)\b[^>]*>", "\n", t)
    return html.unescape(re.sub(r"<[^>]+>", " ", t))


def html_sections(page: str) -> list[tuple[str, str]]:
    """(section title, its text) of an index.html: each tile, each box, the lead, each section."""
    body = page.split("<body>", 1)[-1]
    out = []
    m = re.search(r'<section><h2>Compared ride: [^<]*</h2>(<div class="kf">.*?</div>)</section>', body, flags=re.S)
    if m:                   # --compare: the other ride's own tiles, its own quantities
        out += [(COMPARED, t) for _, t in html_sections("<body>" + m[1])]
        body = body[:m.start()] + body[m.end():]
    for tile in re.findall(r'<div(?: class="\w+")?><div class="l">(.*?)</div><div class="v">(.*?)</div>'
                           r'(?:<div class="n">(.*?)</div>)?</div>', body, flags=re.S):
        out.append(("tile", _text(f"{tile[0]} {tile[1]}\n{tile[2]}")))
    for title, inner in re.findall(r'<section class="box"><h2>(.*?)</h2>(.*?)</section>', body, flags=re.S):
        out.append((html.unescape(title), _text(inner)))
    for inner in re.findall(r'<p class="lead">(.*?)</p>', body, flags=re.S):
        out.append(("lead", _text(inner)))
    for title, inner in re.findall(r"<details><summary>(.*?)</summary>(.*?)</details>", body, flags=re.S):
        out.append((html.unescape(title), _text(inner)))
    return out


def md_sections(md: str) -> list[tuple[str, str]]:
    """(heading, its text) of an index.md, split at its ``#``/``##`` headings."""
    out, title, lines = [], "top", []
    for line in md.splitlines():
        if line.startswith("- Compared ride, "):        # --compare: the other ride's key figures
            out.append((title, "\n".join(lines)))
            title, lines = COMPARED, []
        elif re.match(r"#{1,2} ", line):
            out.append((title, "\n".join(lines)))
            title, lines = line.lstrip("#").strip(), []
        else:
            lines.append(line)
    out.append((title, "\n".join(lines)))
    return out


#: The section of the compared ride's own key figures (``--compare``): its quantities are
#: another ride's, named apart ("compared:total_mass").
COMPARED = "compared ride"


def page_quantities(sections: list[tuple[str, str]], differences_title: str) -> list[Quantity]:
    """Every section's quantities, those of ``differences_title`` read as differences, the
    compared ride's named apart."""
    out = [q for title, text in sections for q in quantities(title, text, title == differences_title)]
    return [replace(q, name=f"compared:{q.name}") if q.section == COMPARED else q for q in out]


def _same(a: Quantity, b: Quantity) -> bool:
    """Equal at the coarser of the two printed precisions."""
    coarse = a if (a.decimals, a.value) < (b.decimals, b.value) else b
    scale = a.value / _float(a.shown) if coarse is a and _float(a.shown) else (
        b.value / _float(b.shown) if _float(b.shown) else 1.0)
    tol = 0.5 * 10 ** -coarse.decimals * abs(scale)
    if a.unit == "" and b.unit == "" and "." in a.shown + b.shown:
        tol = max(tol, 0.5 * 10 ** -min(a.decimals, b.decimals))
    return abs(a.value - b.value) <= tol * (1 + 1e-9) + 1e-12


def problems(qs: list[Quantity], tiles_are_one: bool = True) -> list[str]:
    """What breaks "every number once": two values of one quantity, one quantity in two
    sections (the tiles count as one section), an efficiency above 100 %."""
    out = []
    by: dict[str, list[Quantity]] = {}
    for q in qs:
        by.setdefault(q.name, []).append(q)
        if q.name.lstrip("Δ±").startswith("eta_") and q.value > 1.0 + 1e-9:
            out.append(f"efficiency above 100 %: {q.context!r} ({q.section})")
    for name, group in by.items():
        first = group[0]
        for q in group[1:]:
            if not _same(first, q):
                out.append(f"{name}: {first.shown} {first.unit} ({first.section}: {first.context!r}) and "
                           f"{q.shown} {q.unit} ({q.section}: {q.context!r})")
        secs = list(dict.fromkeys(q.section for q in group))
        if len(secs) > 1:
            out.append(f"{name} shown in {len(secs)} sections: " + "; ".join(
                f"{s}: {next(q.context for q in group if q.section == s)!r}" for s in secs))
    return out

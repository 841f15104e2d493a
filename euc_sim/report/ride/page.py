"""The ride's report page in Markdown: :func:`write_page` writes ``DIR/index.md``.

The notes are said for people, each once, beside the tile that counts it (:func:`summarise_notes`,
:func:`said_once`, :func:`as_the_tile`); the JSON keeps every one.
"""

from __future__ import annotations

import re
from pathlib import Path
from typing import Mapping, Sequence

import numpy as np

from euc_sim.io import write_text
from euc_sim.rides.balance.residual import SLOW_S
from euc_sim.rides.balance.verdict import unit_label
from euc_sim.rides.law.controller_report import describe
from euc_sim.report.ride.contract import error_measure
from euc_sim.report.ride.differences_page import difference_section
from euc_sim.report.ride.drivetrain_page import page_section
from euc_sim.report.ride.ride_time import clock_of, span_at, spans_legend, when
from euc_sim.report.ride.series import number
from euc_sim.rides.result import RideResult
from euc_sim.rides.grids.rider_features import BandRatio
from euc_sim.rides.sim.sim_steps import TARGET_RATIO
from euc_sim.rides.sim.simulate import StepScore
from euc_sim.rides.source.gaps import GAP_POLICY

__all__ = ["write_page", "falls_sentence", "markdown_sections", "law_md", "summarise_notes", "said_once", "as_the_tile",
           "missing_spec_effect"]


def _fmt(x, nd=3) -> str:
    if x is None:
        return "–"
    try:
        return f"{x:.{nd}g}"
    except (TypeError, ValueError):
        return str(x)


def _interval(ci) -> str:
    return f"[{_fmt(ci[0])}, {_fmt(ci[1])}]" if ci else "–"


def write_page(res: RideResult, out_dir, figures: Mapping[str, str], key_lines: Sequence[str] = (),
               shown=frozenset(), limits: Sequence[str] = ()) -> Path:
    """Write ``out_dir/index.md``: the ride's findings with its figures.

    Parameters
    ----------
    res : RideResult
    out_dir : path
    figures : mapping
        ``{"cross_ride"|"residuals"|"simulation": file name inside out_dir}``.
    key_lines : sequence of str
        The first screen's figures (the HTML tiles' strings), said first.
    shown : frozenset
        The fitted quantities those figures give, said later without their numbers.
    limits : sequence of str
        The wheel's limit and the cut-out, Markdown lines with their heading (the HTML page's
        sentences: :func:`euc_sim.report.ride.limits_page.limits_md`), after the verdict.

    Returns
    -------
    pathlib.Path
    """
    md = (_verdict_md(res, figures, key_lines, shown, limits) + _estimates_md(res) + _aliases_md(res)
          + _localisation_md(res, figures) + _simulation_md(res, figures) + _assumptions_md(res, shown))
    return write_text(Path(out_dir) / "index.md", "\n".join(md))


def _verdict_md(res: RideResult, figures: Mapping[str, str], key_lines: Sequence[str] = (),
                shown=frozenset(), limits: Sequence[str] = ()) -> list[str]:
    """Title, the key figures, what differs (with both logs' metadata, beside LOG's path), the
    verdict, the wheel's limit and the cut-out (``limits``), the cross-ride figure."""
    cut = next((i + 1 for i, line in enumerate(key_lines) if line.startswith("Compared ride, ")), len(key_lines))
    key = (["## Key figures", ""] + [f"- {line}" for line in key_lines[:cut]]      # the compared ride's nest
           + [f"  - {line}" for line in key_lines[cut:]] + [""] if key_lines else [])
    md = ([f"# Ride diagnosis: {Path(res.balance.recording).name}", ""] + key
          + difference_section(res.differences, res.balance.compare, res.mass.fit.path) + _verdict_lines(res)
          + list(limits) + page_section(res, figures, shown) + law_md(res.law))
    return md + _cross_ride_md(figures)


def _cross_ride_md(figures: Mapping[str, str]) -> list[str]:
    if "cross_ride" not in figures:
        return []
    return ["## Cross-ride prediction", "", f"![cross-ride prediction]({figures['cross_ride']})", ""]


def _verdict_lines(res: RideResult) -> list[str]:
    """What was fitted on what, and the balance fit's verdict with its held-out errors."""
    an, v = res.balance, res.verdict
    cr, unit = an.cross, an.error_unit
    test = Path(an.compare).name if an.compare else "the second half of the same ride"
    md = [f"Fitted on **{Path(an.recording).name}**"
          f"{' (first half)' if not an.compare else ''}, tested on **{test}**. "
          f"Model: the wheel's longitudinal balance in the {an.domain} domain "
          f"({error_measure(an)}).", ""]
    md += ["## Verdict", "", f"- **{v.text[0].upper() + v.text[1:]}.**"]
    if v.candidates and v.battery_power:
        md.append("- Candidates accepted by the held-out balance but outside their plausible "
                  "ranges (see 'Estimates'): " + ", ".join(f"`{c}`" for c in v.candidates) + ".")
    if v.battery_power:
        md.append(f"- Held-out error: inertia-only {cr.heldout_nominal:.1f} {unit}, "
                  f"augmented {cr.heldout_augmented:.1f} {unit}; ratio **{cr.ratio:.2f}** "
                  f"({'better' if cr.ratio < 1 else 'NOT better'} out of sample).")
    else:
        md.append(f"- Why: {v.why}. The held-out figures below compare V·I with the model "
                  f"and say nothing about battery power.")
    return md + [""]


def markdown_sections(res: RideResult, figures: Mapping[str, str],
                      shown=frozenset()) -> list[tuple[str, list[str]]]:
    """:func:`write_page`'s sections grouped as the HTML page's folded parts: (title, Markdown lines).

    ``shown``: quantities the first screen already gives, not repeated.
    """
    return [("The balance model and the diagnosis", _verdict_lines(res) + _cross_ride_md(figures)
             + _estimates_md(res) + _aliases_md(res) + _localisation_md(res, figures)),
            ("Mass, drivetrain and battery, term by term", page_section(res, figures, shown)),
            ("The firmware's balance law", law_md(res.law)),
            ("The simulation, step by step", _simulation_md(res, figures)),
            ("Assumptions and notes", _assumptions_md(res, shown))]


def law_md(c) -> list[str]:
    """The page's section on the wheel's balance law (a
    :class:`~euc_sim.rides.law.controller_report.ControllerFit`), Markdown lines."""
    md = ["## The wheel's balance law", ""]
    law = c.law
    if law is None:
        return md + [f"Not read from this log: {c.why}.", ""]
    md += [f"{describe(law)}. Logged pitch sign {law.sign:+d} (forward lean "
           f"{'raises' if law.sign > 0 else 'lowers'} the logged tilt).", "",
           "| term | estimate | 95 % | unit |", "|---|---|---|---|"]
    md += [f"| {k} | {v:.4g} | " + (f"{ci[0]:.4g} – {ci[1]:.4g}" if ci else "–") + f" | {u} |"
           for k, (v, ci, u) in law.terms.items()]
    return md + ["", f"Held-out R² of the {law.channel} predicted from the pitch: **{c.heldout_r2:.3f}** "
                     f"({c.heldout_ride}); within the fitted ride {law.heldout_r2:.3f} (PD alone "
                     f"{law.nominal_r2:.3f}, speed and acceleration without the pitch {law.blind_r2:.3f}).", ""]


def _estimates_md(res: RideResult) -> list[str]:
    """The balance fit's parameters (one row each), each effect's evidence, and how the fit
    with every candidate scores held out."""
    md = ["## Estimates", "",
          "| parameter | estimate | unit | 95 % interval | plausible range | accepted | note |",
          "| --- | --- | --- | --- | --- | --- | --- |"]
    for p in res.parameters:
        if p.source == "balance":
            md.append(f"| {p.name} | {_fmt(p.estimate)} | {unit_label(p.unit)} | "
                      f"{_interval(p.ci95)} | {_interval(p.plausible_range)} | "
                      f"{'yes' if p.accepted else 'no'} | {p.why or '–'} |")
    md.append("")
    for e in res.effects:
        md += [f"- **{e.name}**: {e.evidence}."]
        if "drag_area_m2" in e.extra:
            md[-1] += (f" As a drag area C_dA = {_fmt(e.extra['drag_area_m2'])} m² "
                       f"(95 % {_interval(e.extra['drag_area_m2_ci95'])}); a standing rider is 0.3–1 m².")
    full = res.balance.cross.heldout_full
    if full is not None:
        md += ["", f"The fit with every candidate (bounded alike) predicts {res.balance.compare or 'the held-out half'} "
                   f"to {_fmt(full, 4)} {res.balance.error_unit} RMS (its estimates are in the JSON's "
                   f"`all_estimates`, not repeated here)."]
    return md


def _aliases_md(res: RideResult) -> list[str]:
    """What the ride cannot tell apart: exact aliases, confounded pairs, caveats."""
    cr = res.balance.cross
    md = ["", "## What this ride cannot tell apart", ""]
    seen: set = set()
    for name, al in cr.fit_design.aliases.items():
        pairs = [a for a in al if frozenset((name, a)) not in seen]
        seen.update(frozenset((name, a)) for a in al)
        if pairs:
            md.append(f"- `{name}` and {', '.join(f'`{a}`' for a in pairs)}: identical columns "
                      f"(the speed never changes sign), only their sum is estimated (reported "
                      f"as `{name}`).")
    for name in cr.full.names:
        al = cr.full.confounded(name)
        pairs = [a for a in al if frozenset((name, a)) not in seen]
        seen.update(frozenset((name, a)) for a in al)
        if pairs:
            md.append(f"- `{name}` trades off against {', '.join(f'`{a}`' for a in pairs)} "
                      f"(bootstrap correlation beyond ±0.8 in the fit with every candidate).")
    md += [f"- {_mass_note(n)}." for n in res.notes if _limit_note(n)]
    return md


def _limit_note(note: str) -> bool:
    """A note on what the ride cannot tell apart (said there, not again under the assumptions)."""
    return note.startswith("masses of the balance fit") or "GPS" in note


_FOUND = re.compile(r"m_eq = [\d.]+ kg, total [\d.]+ kg \((found from this log[^()]*(?:\([^()]*\))?)\)")


def _mass_note(note: str) -> str:
    """The balance fit's masses, when found from the log, named, not repeated (the mass section gives them)."""
    return _FOUND.sub(r"the masses are those \1 ('What the wheel weighs')", note)


def torque_words(method: str, efficiency: float) -> str:
    """How the log's torque was inferred (``torque_method``), in words: from battery power it
    takes the ``--efficiency`` assumption, which the energy balance itself does not use."""
    if method == "power_efficiency":
        return (f"battery power at an assumed drivetrain efficiency of {efficiency:g} "
                f"(--efficiency; only for this torque, the energy balance has no efficiency)")
    if method == "phase_current":
        return "phase current × the torque constant"
    return str(method)


def _localisation_md(res: RideResult, figures: Mapping[str, str]) -> list[str]:
    """Where the inertia-only residual concentrates, with its figure."""
    loc = res.traces[0].localisation
    md = ["", "## Where the mismatch concentrates", ""]
    if loc["windows"]:
        clock = res.rider.clock
        md.append("Windows where the inertia-only residual of "
                  f"{Path(res.balance.recording).name} concentrates "
                  f"({100 * (loc['share'] or 0):.0f} % of its energy), {spans_legend(clock)}: "
                  + ", ".join(span_at(clock, a, b) for a, b in loc["windows"]) + ".")
    else:
        md.append("No window stands out: the residual is spread over the ride.")
    if loc["correlations"]:
        md.append("Correlation of that residual with: " + ", ".join(
            f"{k} {v:+.2f}" for k, v in loc["correlations"].items()) + ".")
    for tr in res.traces:        # the held-out ride's RMS: the verdict's errors
        said = ("RMS as in the verdict's held-out errors, augmented" if not tr.in_sample else
               f"RMS of the fit itself, not held out: inertia-only "
               f"{tr.rms_nominal:.0f} {tr.unit}, augmented {tr.rms_augmented:.0f}")
        md.append(f"- {tr.label} ({'in sample' if tr.in_sample else 'held out'}): {said}, of which the "
                  f"{SLOW_S:.0f} s moving mean (slow: hills, wind) {tr.rms_slow:.0f} {tr.unit}.")
    if "residuals" in figures:
        md += ["", f"![residual over time]({figures['residuals']})", ""]
    return md


def falls_sentence(falls: list, scored_rows: int, clock=None) -> str | None:
    """One sentence on the simulated rider's falls (the simulation's ``falls``), each time (clock
    time in the ride's zone, from its ``clock``, and time into the ride) and cause said once with the
    runs it ended; None without a fall."""
    if not falls:
        return None
    groups: dict[tuple, list[str]] = {}
    for f in falls:
        groups.setdefault((round(float(f["t"]), 1), f["cause"]), []).append(f.get("run", "run"))
    said = "; ".join(f"at {when(clock, t, ' and '.join(runs) + ': ' + cause)}"
                     for (t, cause), runs in groups.items())
    tail = ("no scored row was ridden before it, so there is no error to report" if scored_rows == 0
            else f"errors are over the {scored_rows} scored rows ridden before it")
    return f"the simulated rider fell {said}; the profile was not ridden again, and {tail}"


def bands_cell(bands: Mapping[str, BandRatio] | None) -> str:
    """A step's ``heldout_bands`` in a cell: battery power's band RMS ratio in dB with its fastest
    and slowest band, then phase current's and pitch's where scored; '–' without any."""
    if not bands:
        return "–"
    out = []
    for key, label in (("P_W", "P"), ("I_phase_A", "I"), ("pitch_rad", "pitch")):
        b = bands.get(key)
        if b is not None:
            out.append(f"{label} {b.rms_dB:.1f} dB" + (f" ({b.ratio_dB[0]:+.0f} … {b.ratio_dB[-1]:+.0f})"
                                                     if key == "P_W" else ""))
    return "; ".join(out) or "–"


#: dB: a fastest band this far from the log's is said on the page (twice or half the swing).
SWAY_DB = 6.0


def sway_sentence(ran: Sequence[StepScore]) -> str | None:
    """What the last step's fastest battery-power band says of the rider's sway, or None.

    ``ran``: the steps that ran.  Said when that band (~2 Hz) is more than :data:`SWAY_DB` from
    the log's: the simulated rider sways less (or more) than the logged one, which an RMS error
    does not show.
    """
    b = (ran[-1].heldout_bands or {}).get("P_W") if ran else None
    if b is None or abs(b.ratio_dB[0]) <= SWAY_DB:
        return None
    r, name = b.ratio_dB[0], ran[-1].step.name
    times = 10 ** (abs(r) / 20)
    if r < 0:
        return (f"In the last step ({name}) the battery power's fastest band (~2 Hz) swings "
                f"{times:.1f}× less than the log's ({r:+.0f} dB): the logged rider's own sway is "
                f"missing from the simulated one (`--calibrate-rider` fits his delay, bandwidth and "
                f"motor noise); the RMS error favours leaving it out, since a sway drawn "
                f"independently of the logged one adds to it.")
    return (f"In the last step ({name}) the battery power's fastest band (~2 Hz) swings "
            f"{times:.1f}× more than the log's ({r:+.0f} dB): the simulated rider sways more than "
            f"the logged one.")


def _step_row(st: StepScore, clock=None) -> str:
    """One row of the steps' table: what the step adds, its held-out errors and its fall (when:
    the simulated ride's ``clock``)."""
    step, h, ratio = st.step, st.heldout_rmse, st.ratio_to_balance
    if step.why is not None:
        return f"| {step.name} | not run: {step.why} |" + " – |" * 9

    def cell(key, fmt, unit, scale=1.0):
        return f"{h[key] * scale:{fmt}} {unit}" if key in h else "–"

    rc = "–" if ratio is None else (f"**{ratio:.2f}**" if ratio <= TARGET_RATIO else f"{ratio:.2f}")
    fell = "–" if not st.fell else when(clock, st.fell["t"])
    bands = bands_cell(st.heldout_bands)
    return (f"| {step.name} | {step.what} | {cell('P_W', '.0f', 'W')} | {rc} | {bands} | "
            f"{cell('I_phase_A', '.1f', 'A')} | {cell('pitch_rad', '.2f', '°', float(np.degrees(1.0)))} | "
            f"{cell('pwm_pct', '.1f', '%')} | {cell('M_Nm', '.1f', 'N·m')} | {cell('v_mps', '.2f', 'm/s')} "
            f"| {fell} |")


def _simulation_md(res: RideResult, figures: Mapping[str, str]) -> list[str]:
    """The closed-loop simulation along the ride against its log, one row per modelled step."""
    sim, an = res.simulation, res.balance
    md = ["## Simulation against the ride", ""]
    if sim is not None:
        balance = an.cross.heldout_augmented if an.error_unit == "W" else None
        md += [f"The simulator's rider rode the logged speed profile of **{sim.label}** "
               f"(MuJoCo, 1 kHz) once per modelled step, each step adding one piece to the one "
               f"before; its motor torque gave the battery power through the fitted drivetrain, "
               f"phase current (torque / K_t), pitch (in the log's convention, scored on the riding rows) and PWM duty (the "
               f"drivetrain's duty model). Each simulated channel is read at the log's own time "
               f"stamps (the mean over the 0.2 s before each) and put on the grid as the log is. "
               f"Errors on {sim.scored_rows} rows of the 10 Hz grid, both sides smoothed alike. "
               f"The bands compare battery power's level and spectrum with the log's, unsmoothed "
               f"(and phase current's and pitch's, where logged): "
               f"the RMS over eight bands (~2 Hz to ~0.1 Hz) of 20·log10(simulated / logged band RMS), "
               f"and the fastest and slowest band's ratio (0 dB: the log's level and spectrum, "
               f"+6 dB twice its swing); unlike the RMS error it does not count a noise drawn "
               f"independently of the log's as an error"
               + (f"; a step meets the target when its error is within {TARGET_RATIO:g}× the balance fit's "
                  f"held-out battery-power error (the verdict's augmented one; bold)" if balance else "")
               + ":", "",
               "| step | what it adds | battery power RMS | × balance fit | bands, dB (P: fast … slow) "
               "| phase current RMS | pitch RMS | PWM RMS | torque RMS | speed RMS | fell |",
               "| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |"]
        clock = clock_of(res, sim.label)
        md += [_step_row(st, clock) for st in sim.steps]
        inj = (", ".join(sim.effects) + " at their estimates above") if sim.effects else "none"
        md += ["", f"Last / first step battery-power error: **{sim.ratio_P:.2f}** "
               f"(effects injected as physics in the last step: {inj}). The torque column scores "
               f"against a logged torque from {torque_words(sim.torque_method, an.assumptions.efficiency)}.", ""]
        sway = sway_sentence([st for st in sim.steps if st.step.why is None])
        if sway:
            md += [sway, ""]
        windows = sim.localisation.get("windows", [])
        if windows:
            md.append(f"Windows where the last step's ({sim.steps[-1].step.name if sim.steps else 'augmented'}) "
                      f"power error concentrates, {spans_legend(clock)}: "
                      + ", ".join(span_at(clock, a, b) for a, b in windows) + ".")
        fell = falls_sentence(sim.falls, sim.scored_rows, clock)
        if fell:
            md += [fell[0].upper() + fell[1:] + ".", ""]
        def at(_, t) -> str:        # a moment of the simulated ride, in its clock
            return when(clock, float(t))

        for n in summarise_notes([said_once(n) for n in sim.notes], at=at):
            md.append("- " + re.sub(r"\bup to t = ([\d.]+) s\b", lambda m: "up to " + at("", m[1]), n))
        if "simulation" in figures:
            md += ["", f"![simulation against the log, step by step]({figures['simulation']})", ""]
    else:
        why = res.simulation_why or "not run"
        md += [why[0].upper() + why[1:] + ".", ""]
    return md


def _assumptions_md(res: RideResult, shown=frozenset()) -> list[str]:
    """Which values came from the spec, the log or the command line, which are defaults; every note."""
    md = ["## Assumptions and notes", ""]
    an = res.balance
    a = an.assumptions
    msrc = a.source_of("total_mass")
    masses = (f"masses as 'What the wheel weighs' gives them ({msrc})" if str(msrc).startswith("found from this log")
              else f"masses given: {a.total_mass:.4g} kg total, {a.m_eq:.4g} kg equivalent ({msrc})")
    md.append(f"- Balance fit ('Cross-ride prediction', 'Estimates'): wheel radius R = {a.R:g} m "
              f"({a.source_of('R')}); {masses}; power from {an.sig_fit.power_source}"
              + (f"; torque from {torque_words(an.sig_fit.torque_method, a.efficiency)}" if an.domain == "torque"
                 else "") + ".")
    w = res.mass.fit.spec
    given = (("wheel radius", w.radius, "m"), ("net weight", w.wheel_mass, "kg"),
             ("battery voltage", w.battery_voltage, "V"))
    have = [f"{name} {x:.4g} {u}" for name, x, u in given if x is not None]
    miss = [name for name, x, _ in given if x is None]
    src = " + ".join(Path(x.strip()).name if x.strip().endswith(".csv") else x.strip()
                     for x in str(w.source or "none").split("+"))
    md.append(f"- From the wheel's specification ({src}): "
              f"{', '.join(have) or 'nothing'}"
              + (f"; not given: {', '.join(miss)} (" + missing_spec_effect(miss) + ")" if miss else "")
              + ".")
    notes = [n for n in res.notes if not _limit_note(n)]
    if "gaps" in shown:         # the ride's own gap count is the Data quality tile's
        hz = number(res.rider.summary.sampling_hz)
        notes = [n if re.match(r"\S+\.csv: ", n) else as_the_tile(n, hz) for n in notes]
    def at(who: str, t: float) -> str:      # a moment of the ride the note names ("2.csv: "), in its clock
        return when(clock_of(res, who.rstrip(": ")), t)

    md += [f"- {n}" for n in summarise_notes(notes, at=at)]
    md.append("")
    return md


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

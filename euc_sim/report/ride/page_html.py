"""The ride's page as a rider opens it: ``DIR/index.html`` (:mod:`euc_sim.report.html`).

First screen: the ride's numbers (distance, time, speeds, energy, Wh/km, battery,
PWM, alarms, data quality, mass, battery health) read from the ride's
:class:`~euc_sim.rides.result.RiderNumbers` and total mass (never computed here); a tile whose
number is unknown says "not available"; with ``--compare``, right under them, what
differs in the compared ride (:mod:`euc_sim.report.ride.differences_page`).  Then the ride over time on one shared
axis, the track, the wheel's limits with the speed at which its motor would run out of voltage
against the battery's charge (its :class:`~euc_sim.rides.drive.cutout.Cutout`), the battery's sag and the PWM
envelope with the ride's own points.  Then, folded, the physics the plain-text page (``index.md``) carries.
People's units on the page (km/h, %, Wh, mΩ, °C); the JSON keeps SI.
"""

from __future__ import annotations

import re
from pathlib import Path
from typing import Mapping

import numpy as np

from euc_sim.report import html as H
from euc_sim.report.figures import Line, Panel, thin, time_panels, track_map, track_plain, xy_figure
from euc_sim.report.ride.limits_page import pwm_check
from euc_sim.report.ride.differences_page import TITLE, difference_lines
from euc_sim.report.ride.limits_page import (LIMITS_TITLE, cutout_figure, envelope_figure, limit_sentences,
                                              limits_paragraph)
from euc_sim.report.ride.page import markdown_sections
from euc_sim.report.ride.series import MOST_POINTS, RideSeries, max_pwm_mark, number
from euc_sim.report.ride.ride_time import TimeAxis, hm as _hm, pause_words, span_words, when
from euc_sim.rides.result import RideResult, RiderNumbers
from euc_sim.rides.source.gaps import GAP_POLICY

__all__ = ["ride_html", "write_ride_html", "key_figures", "first_screen", "figure_specs",
           "data_quality", "PWM_WARN", "PWM_BAD", "BATTERY_TONE"]

#: Max PWM, %, from which the tile warns (amber) and alarms (red): near 100 % the motor has
#: no voltage left to push the rider back up.
PWM_WARN, PWM_BAD = 80.0, 90.0
NA = "not available"


#: What the energy tiles say where the log's V·I is not the battery's power.
NOT_POWER = "the log's V·I is not the battery's power: the app computes its current"


def _ride_tiles(r: RiderNumbers, not_power: bool = False) -> list:
    """Distance, time, speeds, energy, consumption and battery: from the summary; the energy
    and consumption not given where the log's V·I is not battery power (``not_power``)."""
    K, s = H.KeyFigure, r.summary
    dist, mov, dur = number(s.distance_m), number(s.moving_s), number(s.duration_s)
    top, mean = number(s.speed_max_mps), number(s.speed_mean_moving_mps)
    drawn, regen, whkm = number(s.energy_drawn_Wh), number(s.energy_regen_Wh), number(s.Wh_per_km)
    used, rng, start = number(s.battery_used_pct), number(s.range_m_at_this_rate), number(s.battery_start_pct)
    if not_power:
        drawn = regen = whkm = None
    return [
        K("Distance", f"{dist / 1000:.1f} km" if dist is not None else NA,
          _distance_note(s) if dist is not None else ""),
        K("Riding time", _hm(mov) if mov is not None else NA,
          "; ".join(x for x in ((f"of {_hm(dur)}" + (f"; {s.duration_follows}" if s.duration_follows
                                                      else " logged")) if dur is not None else "",
                                span_words(r.clock, s)) if x)),
        K("Top speed", f"{top * 3.6:.0f} km/h" if top is not None else NA,
          "; ".join(x for x in (f"average {mean * 3.6:.0f} km/h while moving" if mean is not None else "",
                                _spin_note(r.clock, s.free_spin)) if x)),
        K("Energy drawn", f"{drawn:.0f} Wh" if drawn is not None else NA,
          NOT_POWER if not_power else
          f"{regen:.0f} Wh regenerated" if regen is not None else "regeneration not logged"),
        K("Consumption", f"{whkm:.1f} Wh/km" if whkm is not None else NA,
          NOT_POWER if not_power else
          "drawn minus regenerated" if regen is not None else "drawn (no regeneration logged)"),
        K("Battery used", f"{used:.0f} %" if used is not None else NA,
          f"range at this rate: {rng / 1000:.0f} km" if rng is not None else
          f"the wheel's gauge read {start:.0f} % throughout"
          if used == 0 and drawn and start is not None else ""),
    ]


def _distance_note(s) -> str:
    """The counter the distance follows; where it is the GPS, the wheel's own count beside it
    when they differ by over 2 %."""
    note = s.distance_follows or f"from {s.distance_source}"
    dist, wheel = number(s.distance_m), number(s.distance_wheel_m)
    if s.distance_source == "gps" and dist and wheel and abs(wheel / dist - 1) > 0.02:
        note += f"; the wheel's own count {wheel / 1000:.1f} km ({100 * (wheel / dist - 1):+.0f} %)"
    return note


def _spin_note(clock, spin) -> str:
    """The summary's ``free_spin`` (:class:`~euc_sim.rides.grids.spin.FreeSpins`: the wheel spinning
    off the ground) in a few words, or ''."""
    v, n = number(getattr(spin, "speed_max_mps", None)), getattr(spin, "count", 0)
    if v is None or not n:
        return ""
    at = number(spin.at_s)
    return (f"the wheel spun free (off the ground) at {v * 3.6:.0f} km/h"
            + (f" at {when(clock, at)}" if n == 1 and at is not None else f" and {n - 1} more time(s)" if n > 1 else "")
            + ": left out")


def _pwm_tile(r: RiderNumbers, where: str) -> object:
    p = number(r.summary.pwm_max_pct)
    if p is None:
        return H.KeyFigure("Max PWM", NA, "no PWM or safety margin logged")
    at = number(r.summary.pwm_max_at_s)
    tone = "bad" if p >= PWM_BAD else "warn" if p >= PWM_WARN else "good"
    note = f"least margin {100 - p:.0f} %" + (f" at {when(r.clock, at, where)}" if at is not None else "")
    return H.KeyFigure("Max PWM", f"{p:.0f} %", note, tone)


def data_quality(s) -> tuple[str, str]:
    """The :class:`~euc_sim.rides.summary.summary.RideSummary`'s one line on the log's gaps and
    sampling (its verdict, ``quality``: good, fair, poor, worded), and its tile tone."""
    return s.quality_sentence or NA, {"good": "good", "fair": "warn", "poor": "bad"}.get(s.quality, "")


def short(text: str, most: int = 70) -> str:
    """A reason in a tile: its first clause (to the first colon or semicolon), cut at a word
    with "…" if still longer than ``most`` characters."""
    first = re.split(r"[:;]\s", text.strip(), maxsplit=1)[0].rstrip(". ")
    if len(first) <= most:
        return first
    return first[:most].rsplit(" ", 1)[0].rstrip(",") + " …"


def _mass_tile(m, check) -> object:
    """The total mass found from the log (a :class:`~euc_sim.rides.drive.mass.MassFit`), and the
    :class:`~euc_sim.rides.summary.summary.MassCheck` of the declared weight."""
    est = number(m.estimate)
    if est is None:
        return H.KeyFigure("Total mass", NA, short(m.why or ""))
    note = f"95 % {m.ci95[0]:.0f}–{m.ci95[1]:.0f} kg" if m.ci95 else ""
    decl = number(check.declared_rider_kg)
    verdict = str(check.verdict or "")
    if decl is not None:
        note = f"declared rider {decl:.0f} kg: {verdict}"
    return H.KeyFigure("Total mass", f"{est:.0f} kg", note,
                       "warn" if decl is not None and verdict in ("heavier", "lighter") else "")


#: The battery entry's verdict (its first word) -> tile tone.
BATTERY_TONE = {"as new": "good", "worn:": "bad"}


def _battery_tile(b) -> object:
    """Internal resistance, mΩ, with the :class:`~euc_sim.rides.drive.battery.BatteryHealth`'s verdict."""
    est, ci, verdict = number(b.resistance_ohm), b.resistance_ci95, str(b.verdict or "")
    r25 = number(b.resistance_25C_ohm)
    if est is None or est <= 0:
        return H.KeyFigure("Battery resistance", NA, short(b.sentence or "") or
                           "the log shows no voltage sag under load", "warn" if est is not None else "")
    exp, why = b.expected_ohm, b.verdict_why
    note = verdict + (f" (new: {1000 * exp[0]:.0f}–{1000 * exp[1]:.0f} mΩ)" if exp else f" ({why})" if why else "") + (
        f"; {1000 * r25:.0f} mΩ at 25 °C" if r25 is not None else
        f"; 95 % {1000 * ci[0]:.0f}–{1000 * ci[1]:.0f} mΩ" if ci else "")
    tone = next((t for k, t in BATTERY_TONE.items() if verdict.startswith(k)), "")
    return H.KeyFigure("Battery resistance", f"{1000 * est:.0f} mΩ", note, tone)


def key_figures(r: RiderNumbers, mass, unidentified: Mapping | None = None, marked: bool = True) -> list:
    """The first screen's tiles of one ride, every number from its result: its
    :class:`~euc_sim.rides.result.RiderNumbers`, its total mass (a
    :class:`~euc_sim.rides.drive.mass.MassFit`) and what its log cannot identify (``unidentified``:
    where the log's V·I is not battery power, no energy or resistance is the battery's).
    ``marked``: the page draws this ride, so its max PWM is marked on it."""
    s = r.summary
    quality, tone = data_quality(s)
    not_power = bool((unidentified or {}).get("battery_power"))
    battery = H.KeyFigure("Battery resistance", NA, NOT_POWER) if not_power else _battery_tile(r.battery)
    return (_ride_tiles(r, not_power)
            + [_pwm_tile(r, "" if not marked else "marked on the map" if s.pwm_max_place else "marked over time"),
               H.KeyFigure("Alarms", NA if s.alarms is None else str(s.alarms),
                           "" if not s.alarms or s.alarm_rows is None else
                           f"{s.alarm_rows} rows of the log flagged", "warn" if s.alarms else ""),
               H.KeyFigure("Data quality", str(s.quality or NA),
                           _and_pauses(re.sub(r"^Data quality \w+: ", "", quality), pause_words(r.clock)), tone),
               _mass_tile(mass, r.mass_check), battery])


def ride_figures(res: RideResult) -> list:
    """This ride's tiles (:func:`key_figures`), marked on the page."""
    return key_figures(res.rider, res.mass.mass, res.mass.unidentified)


def compared_figures(res: RideResult) -> list | None:
    """The compared ride's tiles, not marked; None without ``--compare``."""
    c = res.compared
    return None if c is None else key_figures(c.rider, c.mass, c.drivetrain.drivetrain.unidentified, False)


def _and_pauses(sentence: str, pauses: str) -> str:
    """The data-quality sentence with the pauses' clock times added before its full stop."""
    if not pauses:
        return sentence
    return (f"{sentence.rstrip('.')}; {pauses}." if sentence and sentence != NA else pauses)


def key_figure_lines(res: RideResult) -> list[str]:
    """The first screen's tiles as plain lines, ``"Label: value (note)"``: what the terminal
    and the plain-text page say first, the same strings as the HTML tiles."""
    def lines(tiles):
        return [f"{k.label}: {k.value}" + (f" ({k.note})" if k.note else "") for k in tiles]

    other = compared_figures(res)
    return lines(ride_figures(res)) + ([f"Compared ride, {Path(res.compared.recording).name}:"] + lines(other)
                                       if other else [])


def first_screen(res: RideResult) -> frozenset:
    """The fitted quantities the tiles give, and the limits' section's check of the PWM model on
    the compared ride (``pwm_heldout``): the folded parts then say them without numbers."""
    tiles = {k.label: k.value for k in ride_figures(res)}
    gaps = "gap" in data_quality(res.rider.summary)[0]
    check = pwm_check(res)
    return frozenset([name for label, name in (("Total mass", "total_mass"), ("Battery resistance",
                                                                              "internal_resistance"),
                                               ("Top speed", "top_speed"))
                      if tiles.get(label, NA) != NA] + (["gaps"] if gaps else [])
                     + (["pwm_heldout"] if check and check[0] != "halves" else []))


def _lead(res: RideResult, series=None) -> list[str]:
    """The verdict in sentences: the data's quality first when it weakens everything else."""
    out = [f"Warning: {w}." for w in res.mass.input_warnings]    # the log against its spec
    s = res.rider.summary
    _, tone = data_quality(s)
    if tone in ("bad", "warn"):             # poor data weakens every verdict (its numbers: the tile's)
        out.append(f"The log's data quality is {s.quality} (tile above): "
                   + ("treat every verdict below as weak." if tone == "bad" else
                      "the figures below are a little less certain."))
    p = number(s.pwm_max_pct)
    if p is not None and p >= PWM_BAD:
        out.append("At its peak (Max PWM above) the motor had almost no voltage left: close to a cut-out.")
    out += limit_sentences(res, series)
    v = res.verdict
    if not v.battery_power:
        out.append("The log's voltage times current is not the battery's power: the physics below is weak.")
    elif v.named:
        out.append("The ride's energy balance shows what the standard model lacks: "
                   + ", ".join(n.replace("_", " ") for n in v.named) + " (details below).")
        edge = [p.name.replace("_", " ") for p in res.parameters if p.name in v.named and p.on_bound]
        if edge:
            out.append(f"Even at the most that is plausible ({', '.join(edge)} on the edge of "
                       f"{'its' if len(edge) == 1 else 'their'} plausible range), the ride asks for more "
                       f"than that: something the model lacks supplies the rest.")
    else:
        out.append("The ride's energy balance names nothing the standard model lacks with confidence "
                   "(details below).")
    return out


def over_time(res: RideResult, series: RideSeries):
    """Speed, power, PWM, voltage and temperature on one shared time axis (pauses left out)."""
    c = series.channels
    spec = (("speed_kmh", "Speed", "km/h"), ("power_W", "Battery power", "W"), ("pwm_pct", "PWM", "%"),
            ("voltage_V", "Voltage", "V"), ("temperature_C", "Temperature", "°C"))
    keep = thin(series.t.size, MOST_POINTS)
    axis = TimeAxis.of(res.rider.clock, series.t)
    x = axis.x(series.t[keep])
    keep, x = keep[np.isfinite(x)], x[np.isfinite(x)]
    panels = [Panel(name, unit, c[k][keep]) for k, name, unit in spec if k in c]
    m = max_pwm_mark(res.rider.summary, series)
    peak = number(res.rider.summary.pwm_max_pct)
    mark = None if m is None else (float(axis.x([m[0]])[0]), f"max PWM {peak:.0f} %")
    gap = max(series.gap_s, GAP_POLICY.plot_steps * float(np.median(np.diff(series.t[keep])))) if keep.size > 1 else series.gap_s
    fig = time_panels(x, panels, "The ride over time (zoom one panel: all follow)", gap / 60.0, mark)
    axis.decorate(fig, len(panels))
    if mark is not None and "pwm_pct" in c:        # the peak is one logged row: the grid's mean may not reach it
        row = [k for k, _, _ in spec if k in c].index("pwm_pct") + 1
        ax = "" if row == 1 else str(row)
        fig["data"].append({"type": "scatter", "x": [mark[0]], "y": [peak],
                            "mode": "markers", "name": "max PWM, logged row", "showlegend": False,
                            "marker": {"symbol": "star", "size": 11, "color": "#c62828"},
                            "hovertemplate": "%{y:.0f} % (the logged row; the line is the 10 Hz grid's mean)"
                                             "<extra>max PWM</extra>", "xaxis": f"x{ax}", "yaxis": f"y{ax}"})
    return fig


def on_the_map(res: RideResult, series: RideSeries):
    """The track coloured by PWM (or battery power): on tiles, and plain (drawn without network)."""
    c = series.channels
    if "lat" not in c or "lon" not in c:
        return None
    key, label = ("pwm_pct", "PWM, %") if "pwm_pct" in c else ("power_W", "battery power, W")
    keep = thin(series.t.size, MOST_POINTS)
    lat, lon, val = c["lat"][keep], c["lon"][keep], c[key][keep]
    m = max_pwm_mark(res.rider.summary, series)
    mark = None if m is None or m[1] is None else (m[1], m[2], f"max PWM at {when(res.rider.clock, m[0])}")
    title = f"Where you rode, coloured by {label.split(',')[0]}"
    return (track_map(lat, lon, val, label, title + " (OpenStreetMap)", mark),
            track_plain(lat, lon, val, label, title + " (drawn without the map)", mark))


def sag_figure(res: RideResult):
    """Voltage against current, the charge's fall taken out, with the fitted line V = E₀ − R·I."""
    fit = res.mass.fit
    bc, sig = fit.drivetrain.battery_coef, fit.sig
    if not bc or "current" not in sig.extra:
        return None
    V, I = sig.extra["voltage"], sig.extra["current"]
    ok = np.isfinite(V) & np.isfinite(I)
    y = V + bc["k_Q"] * fit.drivetrain.charge          # the voltage at the start's charge
    keep = thin(int(ok.sum()), 4000)
    Ix, Vy = I[ok][keep], y[ok][keep]
    R = number(res.rider.battery.resistance_ohm) or bc["R_int"]       # the same fit's value, as reported
    grid = np.linspace(float(np.min(Ix)), float(np.max(Ix)), 50)
    fitted = (f"fitted: {bc['E0']:.1f} V − {1000 * R:.0f} mΩ × current" if R > 0 else
              "fitted: no sag (the resistance found is not positive)")
    return xy_figure([Line("log samples", Ix, Vy), Line(fitted, grid, bc["E0"] - R * grid, "lines")],
                     "Battery sag: voltage against current", "battery current, A",
                     "voltage at the start's charge, V",
                     "each sample's voltage with the fall from the charge drawn so far added back")


def figure_specs(res: RideResult, series: RideSeries | None) -> dict:
    """The page's Plotly figures by element id (None where the log cannot give one)."""
    if series is None:
        return {}
    maps = on_the_map(res, series)
    figs = {"over_time": over_time(res, series),
            "map": maps[0] if maps else None, "track": maps[1] if maps else None,
            "sag": sag_figure(res), "envelope": envelope_figure(res, series),
            "cutout": cutout_figure(res, series)}
    return {k: f for k, f in figs.items() if f is not None}


def _figure_sections(res: RideResult, figs: dict) -> list[str]:
    out = []
    if "over_time" in figs:
        n = len(figs["over_time"]["data"])
        out.append(H.section("The ride over time", H.figure(figs["over_time"], "over_time", 140 * n + 110)))
    if "map" in figs:
        out.append(H.section("On the map", H.columns(H.figure(figs["map"], "map", 460),
                                                     H.figure(figs["track"], "track", 460))))
    else:
        out.append(H.section("On the map", H.paragraph("No GPS position in this log: no map.")))
    why_cut = res.cutout.why or "needs the logged PWM and its fitted model"
    out.append(H.section(LIMITS_TITLE, (
        H.figure(figs["cutout"], "cutout", 460) if "cutout" in figs else
        H.paragraph(f"Cut-out speeds: not available ({why_cut}).")) + H.paragraph(limits_paragraph(res))))
    why_env = res.mass.envelope.why or "needs the logged PWM and its fitted model"
    out.append(H.section("The battery and the limit", H.columns(
        H.figure(figs["sag"], "sag", 420) if "sag" in figs else
        H.paragraph("Battery sag: not available (no battery current logged)."),
        H.figure(figs["envelope"], "envelope", 420) if "envelope" in figs else
        H.paragraph(f"PWM envelope: not available ({why_env})."))))
    return out


def ride_html(res: RideResult, series: RideSeries | None, figures: Mapping[str, str] | None = None,
              plots: Mapping[str, tuple] | None = None) -> str:
    """The whole page (a string).

    Parameters
    ----------
    res : RideResult
    series : RideSeries, optional
        The fit ride's channels over time (None: no figures over time, map or envelope).
    figures : mapping, optional
        The folded parts' figures by key: a PNG's file name (linked), or a key of ``plots``.
    plots : mapping, optional
        ``{id: (Plotly figure, height px)}``: the folded parts' figures drawn on the page.
    """
    name = Path(res.balance.recording).name
    figs = figure_specs(res, series)
    other = compared_figures(res)
    body = [H.key_figures(ride_figures(res)) if other is None else      # --compare: both rides side by side
            H.columns(H.section(f"This ride: {name}", H.key_figures(ride_figures(res))),
                      H.section(f"Compared ride: {Path(res.compared.recording).name}", H.key_figures(other)))]
    diff = difference_lines(res.differences, res.balance.compare, res.mass.fit.path)
    if diff:                    # --compare: what differs leads, right under the ride's numbers
        body.append(H.box(TITLE, H.markdown(diff)))
    body.append(H.lead(_lead(res, series)))
    body += _figure_sections(res, figs)
    replay = f" The simulated replay: {res.simulation_why}." if res.simulation_why else ""
    body.append(H.section("The physics behind it", H.paragraph(
        "For those who want the model: each part opens on a click." + replay), folded=False))
    for title, md in markdown_sections(res, figures or {}, first_screen(res)):
        body.append(H.section(title, f"<div>{H.markdown(md, plots)}</div>", folded=True))
    body.append(H.paragraph("A plain-text version of this page is index.md in the same folder; "
                            "every number in SI is in the ride's JSON."))
    return H.page(f"Your ride: {name}", _subtitle(res.mass.fit.spec), body)


def _subtitle(spec) -> str:
    src = str(spec.source or "").strip()
    file = src.split("+")[0].strip()
    name = spec.name or (Path(file).stem if file.endswith(".csv") else "")
    return f"Wheel: {name or 'not specified'} · euc-sim ride report"


def write_ride_html(res: RideResult, out_dir, series: RideSeries | None, figures: Mapping[str, str] | None = None,
                    plots: Mapping[str, tuple] | None = None) -> Path:
    """Write ``out_dir/index.html`` (atomically); returns its path."""
    return H.write_page(out_dir, ride_html(res, series, figures, plots))

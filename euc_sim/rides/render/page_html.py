"""The ride's page as a rider opens it: ``DIR/index.html`` (:mod:`euc_sim.report.html`).

First screen: the ride's numbers (distance, time, speeds, energy, Wh/km, battery,
PWM, alarms, data quality, mass, battery health) read from the ride JSON's
``summary``, ``battery`` and ``total_mass`` (never computed here); a tile whose
entry is absent says "not available"; with ``--compare``, right under them, what
differs in the compared ride (:mod:`euc_sim.rides.render.differences_page`).  Then the ride over time on one shared
axis, the track, the wheel's limits with the speed at which its motor would run out of voltage
against the battery's charge (the JSON's ``cutout``), the battery's sag and the PWM
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
from euc_sim.rides.drive.drivetrain import charge_drawn
from euc_sim.rides.render.contract import pwm_check
from euc_sim.rides.render.differences_page import TITLE, difference_lines
from euc_sim.rides.render.limits_page import (LIMITS_TITLE, cutout_figure, envelope_figure, limit_sentences,
                                              limits_paragraph)
from euc_sim.rides.render.page import markdown_sections
from euc_sim.rides.render.series import MOST_POINTS, RideSeries, json_number, max_pwm_mark
from euc_sim.rides.render.ride_time import TimeAxis, hm as _hm, pause_words, span_words, when
from euc_sim.rides.source.gaps import GAP_POLICY

__all__ = ["ride_html", "write_ride_html", "key_figures", "first_screen", "figure_specs",
           "data_quality", "PWM_WARN", "PWM_BAD", "BATTERY_TONE"]

#: Max PWM, %, from which the tile warns (amber) and alarms (red): near 100 % the motor has
#: no voltage left to push the rider back up.
PWM_WARN, PWM_BAD = 80.0, 90.0
NA = "not available"


#: What the energy tiles say where the log's V·I is not the battery's power.
NOT_POWER = "the log's V·I is not the battery's power: the app computes its current"


def _ride_tiles(rep: Mapping, not_power: bool = False) -> list:
    """Distance, time, speeds, energy, consumption and battery: from ``summary``; the energy
    and consumption not given where the log's V·I is not battery power (``not_power``)."""
    K, s = H.KeyFigure, rep.get("summary")
    if not s:
        return [K(lbl, NA, "needs the ride's summary") for lbl in
                ("Distance", "Riding time", "Top speed", "Energy drawn", "Consumption", "Battery used")]
    dist, mov, dur = json_number(s, "distance_m"), json_number(s, "moving_s"), json_number(s, "duration_s")
    top, mean = json_number(s, "speed_max_mps"), json_number(s, "speed_mean_moving_mps")
    drawn, regen, whkm = json_number(s, "energy_drawn_Wh"), json_number(s, "energy_regen_Wh"), json_number(s, "Wh_per_km")
    used, rng = json_number(s, "battery_used_pct"), json_number(s, "range_m_at_this_rate")
    if not_power:
        drawn = regen = whkm = None
    return [
        K("Distance", f"{dist / 1000:.1f} km" if dist is not None else NA,
          _distance_note(s) if dist is not None else ""),
        K("Riding time", _hm(mov) if mov is not None else NA,
          "; ".join(x for x in ((f"of {_hm(dur)}" + (f"; {s['duration_follows']}" if s.get("duration_follows")
                                                      else " logged")) if dur is not None else "",
                                span_words(rep)) if x)),
        K("Top speed", f"{top * 3.6:.0f} km/h" if top is not None else NA,
          "; ".join(x for x in (f"average {mean * 3.6:.0f} km/h while moving" if mean is not None else "",
                                _spin_note(rep, s.get("free_spin"))) if x)),
        K("Energy drawn", f"{drawn:.0f} Wh" if drawn is not None else NA,
          NOT_POWER if not_power else
          f"{regen:.0f} Wh regenerated" if regen is not None else "regeneration not logged"),
        K("Consumption", f"{whkm:.1f} Wh/km" if whkm is not None else NA,
          NOT_POWER if not_power else
          "drawn minus regenerated" if regen is not None else "drawn (no regeneration logged)"),
        K("Battery used", f"{used:.0f} %" if used is not None else NA,
          f"range at this rate: {rng / 1000:.0f} km" if rng is not None else
          f"the wheel's gauge read {s['battery_start_pct']:.0f} % throughout"
          if used == 0 and drawn and s.get("battery_start_pct") is not None else ""),
    ]


def _distance_note(s: Mapping) -> str:
    """The counter the distance follows; where it is the GPS, the wheel's own count beside it
    when they differ by over 2 %."""
    note = s.get("distance_follows") or f"from {s.get('distance_source')}"
    dist, wheel = json_number(s, "distance_m"), json_number(s, "distance_wheel_m")
    if s.get("distance_source") == "gps" and dist and wheel and abs(wheel / dist - 1) > 0.02:
        note += f"; the wheel's own count {wheel / 1000:.1f} km ({100 * (wheel / dist - 1):+.0f} %)"
    return note


def _spin_note(rep: Mapping, spin: Mapping | None) -> str:
    """The summary's ``free_spin`` (the wheel spinning off the ground) in a few words, or ''."""
    v, n = json_number(spin, "speed_max_mps"), (spin or {}).get("count")
    if v is None or not n:
        return ""
    at = json_number(spin, "at_s")
    return (f"the wheel spun free (off the ground) at {v * 3.6:.0f} km/h"
            + (f" at {when(rep, at)}" if n == 1 and at is not None else f" and {n - 1} more time(s)" if n > 1 else "")
            + ": left out")


def _pwm_tile(rep: Mapping, where: str) -> object:
    s = rep.get("summary")
    p = json_number(s, "pwm_max_pct")
    if p is None:
        return H.KeyFigure("Max PWM", NA, "no PWM or safety margin logged" if s else "needs the summary")
    at = json_number(s, "pwm_max_at_s")
    tone = "bad" if p >= PWM_BAD else "warn" if p >= PWM_WARN else "good"
    note = f"least margin {100 - p:.0f} %" + (f" at {when(rep, at, where)}" if at is not None else "")
    return H.KeyFigure("Max PWM", f"{p:.0f} %", note, tone)


def data_quality(s: Mapping | None) -> tuple[str, str]:
    """The summary's one line on the log's gaps and sampling, and its tile tone.

    The verdict (``quality``: good, fair, poor) and its sentence are the summary's own;
    without them the gaps are stated with no verdict.
    """
    if not s:
        return NA, ""
    tone = {"good": "good", "fair": "warn", "poor": "bad"}.get(str(s.get("quality", "")), "")
    if s.get("quality_sentence"):
        return str(s["quality_sentence"]), tone
    g, dur = s.get("gaps"), json_number(s, "duration_s")
    if not g or not dur:
        return NA, tone
    rate = json_number(s, "sampling_hz")
    return (f"{g.get('count', 0)} gaps, {g.get('total_s', 0):.0f} s "
            f"({100 * (g.get('total_s') or 0.0) / dur:.0f} % of the ride)"
            + (f", longest {g['longest_s']:.0f} s" if g.get("longest_s") else "")
            + (f"; {rate:.1f} samples/s" if rate else "")), tone


def short(text: str, most: int = 70) -> str:
    """A reason in a tile: its first clause (to the first colon or semicolon), cut at a word
    with "…" if still longer than ``most`` characters."""
    first = re.split(r"[:;]\s", text.strip(), maxsplit=1)[0].rstrip(". ")
    if len(first) <= most:
        return first
    return first[:most].rsplit(" ", 1)[0].rstrip(",") + " …"


def _mass_tile(tm: Mapping | None, check: Mapping | None) -> object:
    """The total mass found from the log, and the ride JSON's ``mass_check`` of the declared weight."""
    est = json_number(tm, "estimate")
    if est is None:
        return H.KeyFigure("Total mass", NA, short((tm or {}).get("why") or ""))
    ci = (tm or {}).get("ci95")
    note = f"95 % {ci[0]:.0f}–{ci[1]:.0f} kg" if ci else ""
    decl = json_number(check, "declared_rider_kg")
    verdict = str((check or {}).get("verdict", ""))
    if decl is not None:
        note = f"declared rider {decl:.0f} kg: {verdict}"
    return H.KeyFigure("Total mass", f"{est:.0f} kg", note,
                       "warn" if decl is not None and verdict in ("heavier", "lighter") else "")


#: The battery entry's verdict (its first word) -> tile tone.
BATTERY_TONE = {"as new": "good", "worn:": "bad"}


def _battery_tile(rep: Mapping) -> object:
    """Internal resistance, mΩ, with the ``battery`` entry's health verdict (the drivetrain's
    resistance, without a verdict, where the ride result has no ``battery``)."""
    b = rep.get("battery")
    if b:
        est, ci, verdict = json_number(b, "resistance_ohm"), b.get("resistance_ci95"), str(b.get("verdict", ""))
        r25 = json_number(b, "resistance_25C_ohm")
    else:
        r = (rep.get("drivetrain") or {}).get("internal_resistance") or {}
        est, ci, verdict, r25 = json_number(r, "estimate"), r.get("ci95"), "no health verdict", None
    if est is None or est <= 0:
        return H.KeyFigure("Battery resistance", NA, short((b or {}).get("sentence", "")) or
                           "the log shows no voltage sag under load", "warn" if est is not None else "")
    exp, why = (b or {}).get("expected_ohm"), (b or {}).get("verdict_why")
    note = verdict + (f" (new: {1000 * exp[0]:.0f}–{1000 * exp[1]:.0f} mΩ)" if exp else f" ({why})" if why else "") + (
        f"; {1000 * r25:.0f} mΩ at 25 °C" if r25 is not None else
        f"; 95 % {1000 * ci[0]:.0f}–{1000 * ci[1]:.0f} mΩ" if ci else "")
    tone = next((t for k, t in BATTERY_TONE.items() if verdict.startswith(k)), "")
    return H.KeyFigure("Battery resistance", f"{1000 * est:.0f} mΩ", note, tone)


def compared_view(rep: Mapping) -> dict | None:
    """The compared ride's numbers (the ride JSON's ``compared``) in the form :func:`key_figures`
    reads; None without ``--compare``."""
    c = rep.get("compared")
    return None if not c else {k: c.get(k) for k in ("recording", "summary", "battery", "total_mass", "mass_check",
                                                        "unidentified", "clock")}


def key_figures(rep: Mapping, marked: bool = True) -> list:
    """The first screen's tiles, every number from the ride result (``summary``, ``battery``,
    ``total_mass``; the drivetrain's resistance where no ``battery`` entry exists).
    ``marked``: the page draws this ride, so its max PWM is marked on it."""
    s = rep.get("summary")
    alarms = s.get("alarms") if s else None
    quality, tone = data_quality(s)
    not_power = bool((rep.get("unidentified") or {}).get("battery_power"))
    battery = H.KeyFigure("Battery resistance", NA, NOT_POWER) if not_power else _battery_tile(rep)
    return (_ride_tiles(rep, not_power)
            + [_pwm_tile(rep, "" if not marked else
                         "marked on the map" if (s or {}).get("pwm_max_place") else "marked over time"),
               H.KeyFigure("Alarms", NA if alarms is None else str(alarms),
                           "" if not alarms or s.get("alarm_rows") is None else
                           f"{s['alarm_rows']} rows of the log flagged", "warn" if alarms else ""),
               H.KeyFigure("Data quality", str((s or {}).get("quality") or NA),
                           _and_pauses(re.sub(r"^Data quality \w+: ", "", quality), pause_words(rep)), tone),
               _mass_tile(rep.get("total_mass"), rep.get("mass_check")), battery])


def _and_pauses(sentence: str, pauses: str) -> str:
    """The data-quality sentence with the pauses' clock times added before its full stop."""
    if not pauses:
        return sentence
    return (f"{sentence.rstrip('.')}; {pauses}." if sentence and sentence != NA else pauses)


def key_figure_lines(rep: Mapping) -> list[str]:
    """The first screen's tiles as plain lines, ``"Label: value (note)"``: what the terminal
    and the plain-text page say first, the same strings as the HTML tiles."""
    def lines(r, marked=True):
        return [f"{k.label}: {k.value}" + (f" ({k.note})" if k.note else "") for k in key_figures(r, marked)]

    other = compared_view(rep)
    return lines(rep) + ([f"Compared ride, {Path(str(other['recording'])).name}:"] + lines(other, False)
                         if other else [])


def first_screen(rep: Mapping) -> frozenset:
    """The fitted quantities the tiles give, and the limits' section's check of the PWM model on
    the compared ride (``pwm_heldout``): the folded parts then say them without numbers."""
    tiles = {k.label: k.value for k in key_figures(rep)}
    gaps = "gap" in data_quality(rep.get("summary"))[0]
    check = pwm_check(rep)
    return frozenset([name for label, name in (("Total mass", "total_mass"), ("Battery resistance",
                                                                              "internal_resistance"),
                                               ("Top speed", "top_speed"))
                      if tiles.get(label, NA) != NA] + (["gaps"] if gaps else [])
                     + (["pwm_heldout"] if check and check[0] != "halves" else []))


def _lead(rep: Mapping, series=None, fit=None) -> list[str]:
    """The verdict in sentences: the data's quality first when it weakens everything else."""
    out = [f"Warning: {w}." for w in rep.get("input_warnings") or []]    # the log against its spec
    _, tone = data_quality(rep.get("summary"))
    if tone in ("bad", "warn"):             # poor data weakens every verdict (its numbers: the tile's)
        out.append(f"The log's data quality is {rep['summary'].get('quality')} (tile above): "
                   + ("treat every verdict below as weak." if tone == "bad" else
                      "the figures below are a little less certain."))
    p = json_number(rep.get("summary"), "pwm_max_pct")
    if p is not None and p >= PWM_BAD:
        out.append("At its peak (Max PWM above) the motor had almost no voltage left: close to a cut-out.")
    out += limit_sentences(rep, series)
    v = rep.get("verdict") or {}
    if v.get("battery_power") is False:
        out.append("The log's voltage times current is not the battery's power: the physics below is weak.")
    elif v.get("named"):
        out.append("The ride's energy balance shows what the standard model lacks: "
                   + ", ".join(n.replace("_", " ") for n in v["named"]) + " (details below).")
        edge = [e["name"].replace("_", " ") for e in rep.get("effects") or []
                if e.get("on_bound") and e["name"] in v["named"]]
        if edge:
            out.append(f"Even at the most that is plausible ({', '.join(edge)} on the edge of "
                       f"{'its' if len(edge) == 1 else 'their'} plausible range), the ride asks for more "
                       f"than that: something the model lacks supplies the rest.")
    elif v:
        out.append("The ride's energy balance names nothing the standard model lacks with confidence "
                   "(details below).")
    return out


def over_time(rep: Mapping, series: RideSeries):
    """Speed, power, PWM, voltage and temperature on one shared time axis (pauses left out)."""
    c = series.channels
    spec = (("speed_kmh", "Speed", "km/h"), ("power_W", "Battery power", "W"), ("pwm_pct", "PWM", "%"),
            ("voltage_V", "Voltage", "V"), ("temperature_C", "Temperature", "°C"))
    keep = thin(series.t.size, MOST_POINTS)
    axis = TimeAxis.of(rep, series.t)
    x = axis.x(series.t[keep])
    keep, x = keep[np.isfinite(x)], x[np.isfinite(x)]
    panels = [Panel(name, unit, c[k][keep]) for k, name, unit in spec if k in c]
    m = max_pwm_mark(rep, series)
    mark = None if m is None else (float(axis.x([m[0]])[0]), f"max PWM {json_number(rep['summary'], 'pwm_max_pct'):.0f} %")
    gap = max(series.gap_s, GAP_POLICY.plot_steps * float(np.median(np.diff(series.t[keep])))) if keep.size > 1 else series.gap_s
    fig = time_panels(x, panels, "The ride over time (zoom one panel: all follow)", gap / 60.0, mark)
    axis.decorate(fig, len(panels))
    if mark is not None and "pwm_pct" in c:        # the peak is one logged row: the grid's mean may not reach it
        row = [k for k, _, _ in spec if k in c].index("pwm_pct") + 1
        ax = "" if row == 1 else str(row)
        fig["data"].append({"type": "scatter", "x": [mark[0]], "y": [json_number(rep["summary"], "pwm_max_pct")],
                            "mode": "markers", "name": "max PWM, logged row", "showlegend": False,
                            "marker": {"symbol": "star", "size": 11, "color": "#c62828"},
                            "hovertemplate": "%{y:.0f} % (the logged row; the line is the 10 Hz grid's mean)"
                                             "<extra>max PWM</extra>", "xaxis": f"x{ax}", "yaxis": f"y{ax}"})
    return fig


def on_the_map(rep: Mapping, series: RideSeries):
    """The track coloured by PWM (or battery power): on tiles, and plain (drawn without network)."""
    c = series.channels
    if "lat" not in c or "lon" not in c:
        return None
    key, label = ("pwm_pct", "PWM, %") if "pwm_pct" in c else ("power_W", "battery power, W")
    keep = thin(series.t.size, MOST_POINTS)
    lat, lon, val = c["lat"][keep], c["lon"][keep], c[key][keep]
    m = max_pwm_mark(rep, series)
    mark = None if m is None or m[1] is None else (m[1], m[2], f"max PWM at {when(rep, m[0])}")
    title = f"Where you rode, coloured by {label.split(',')[0]}"
    return (track_map(lat, lon, val, label, title + " (OpenStreetMap)", mark),
            track_plain(lat, lon, val, label, title + " (drawn without the map)", mark))


def sag_figure(rep: Mapping, fit):
    """Voltage against current, the charge's fall taken out, with the fitted line V = E₀ − R·I."""
    bc = getattr(getattr(fit, "drivetrain", None), "battery_coef", None)
    sig = getattr(fit, "sig", None)
    if not bc or sig is None or "current" not in sig.extra:
        return None
    V, I = sig.extra["voltage"], sig.extra["current"]
    ok = np.isfinite(V) & np.isfinite(I)
    y = V + bc["k_Q"] * charge_drawn(sig.t, I)          # the voltage at the start's charge
    keep = thin(int(ok.sum()), 4000)
    Ix, Vy = I[ok][keep], y[ok][keep]
    R = json_number(rep.get("battery"), "resistance_ohm") or bc["R_int"]       # the same fit's value, as reported
    grid = np.linspace(float(np.min(Ix)), float(np.max(Ix)), 50)
    fitted = (f"fitted: {bc['E0']:.1f} V − {1000 * R:.0f} mΩ × current" if R > 0 else
              "fitted: no sag (the resistance found is not positive)")
    return xy_figure([Line("log samples", Ix, Vy), Line(fitted, grid, bc["E0"] - R * grid, "lines")],
                     "Battery sag: voltage against current", "battery current, A",
                     "voltage at the start's charge, V",
                     "each sample's voltage with the fall from the charge drawn so far added back")


def figure_specs(rep: Mapping, series: RideSeries | None, fit=None) -> dict:
    """The page's Plotly figures by element id (None where the log cannot give one)."""
    if series is None:
        return {}
    maps = on_the_map(rep, series)
    figs = {"over_time": over_time(rep, series),
            "map": maps[0] if maps else None, "track": maps[1] if maps else None,
            "sag": sag_figure(rep, fit), "envelope": envelope_figure(rep, series),
            "cutout": cutout_figure(rep, series)}
    return {k: f for k, f in figs.items() if f is not None}


def _figure_sections(rep: Mapping, figs: dict) -> list[str]:
    out = []
    if "over_time" in figs:
        n = len(figs["over_time"]["data"])
        out.append(H.section("The ride over time", H.figure(figs["over_time"], "over_time", 140 * n + 110)))
    if "map" in figs:
        out.append(H.section("On the map", H.columns(H.figure(figs["map"], "map", 460),
                                                     H.figure(figs["track"], "track", 460))))
    else:
        out.append(H.section("On the map", H.paragraph("No GPS position in this log: no map.")))
    why_cut = (rep.get("cutout") or {}).get("why") or "needs the logged PWM and its fitted model"
    out.append(H.section(LIMITS_TITLE, (
        H.figure(figs["cutout"], "cutout", 460) if "cutout" in figs else
        H.paragraph(f"Cut-out speeds: not available ({why_cut}).")) + H.paragraph(limits_paragraph(rep))))
    why_env = (rep.get("envelope") or {}).get("why", "needs the logged PWM and its fitted model")
    out.append(H.section("The battery and the limit", H.columns(
        H.figure(figs["sag"], "sag", 420) if "sag" in figs else
        H.paragraph("Battery sag: not available (no battery current logged)."),
        H.figure(figs["envelope"], "envelope", 420) if "envelope" in figs else
        H.paragraph(f"PWM envelope: not available ({why_env})."))))
    return out


def ride_html(rep: Mapping, series: RideSeries | None, fit=None,
              figures: Mapping[str, str] | None = None, plots: Mapping[str, tuple] | None = None) -> str:
    """The whole page (a string).

    Parameters
    ----------
    rep : mapping
        The ``euc-sim ride`` JSON object.
    series : RideSeries, optional
        The fit ride's channels over time (None: no figures over time, map or envelope).
    fit : RideDrivetrain, optional
        The fit ride's mass and drivetrain analysis (sag line, PWM model).
    figures : mapping, optional
        The folded parts' figures by key: a PNG's file name (linked), or a key of ``plots``.
    plots : mapping, optional
        ``{id: (Plotly figure, height px)}``: the folded parts' figures drawn on the page.
    """
    name = Path(rep["recording"]).name
    figs = figure_specs(rep, series, fit)

    other = compared_view(rep)
    body = [H.key_figures(key_figures(rep)) if other is None else      # --compare: both rides side by side
            H.columns(H.section(f"This ride: {name}", H.key_figures(key_figures(rep))),
                      H.section(f"Compared ride: {Path(str(other['recording'])).name}",
                                H.key_figures(key_figures(other, marked=False))))]
    diff = difference_lines(rep, getattr(fit, "path", None))
    if diff:                    # --compare: what differs leads, right under the ride's numbers
        body.append(H.box(TITLE, H.markdown(diff)))
    body.append(H.lead(_lead(rep, series, fit)))
    body += _figure_sections(rep, figs)
    replay = f" The simulated replay: {rep['simulation_why']}." if rep.get("simulation_why") else ""
    body.append(H.section("The physics behind it", H.paragraph(
        "For those who want the model: each part opens on a click." + replay), folded=False))
    for title, md in markdown_sections(dict(rep), figures or {}, first_screen(rep)):
        body.append(H.section(title, f"<div>{H.markdown(md, plots)}</div>", folded=True))
    body.append(H.paragraph("A plain-text version of this page is index.md in the same folder; "
                            "every number in SI is in the ride's JSON."))
    return H.page(f"Your ride: {name}", _subtitle(rep), body)


def _subtitle(rep: Mapping) -> str:
    w = rep.get("wheel") or {}
    src = str(w.get("source") or "").strip()
    file = src.split("+")[0].strip()
    name = w.get("name") or (Path(file).stem if file.endswith(".csv") else "")
    return f"Wheel: {name or 'not specified'} · euc-sim ride report"


def write_ride_html(rep: Mapping, out_dir, series: RideSeries | None, fit=None,
                    figures: Mapping[str, str] | None = None, plots: Mapping[str, tuple] | None = None) -> Path:
    """Write ``out_dir/index.html`` (atomically); returns its path."""
    return H.write_page(out_dir, ride_html(rep, series, fit, figures, plots))

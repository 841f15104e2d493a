"""The ``euc-sim rides`` page: one wheel's rides, its battery over time, consumption by speed.

Built on :mod:`euc_sim.report.html`; people's units on the page (km/h, km, Wh,
mΩ, %, °C), SI in the JSON.
"""

from __future__ import annotations

from datetime import datetime, timedelta
from pathlib import Path

from euc_sim.report.html import KeyFigure, figure, key_figures, page, paragraph, section, table
from euc_sim.report.ride.page_html import PWM_BAD, PWM_WARN
from euc_sim.report.ride.series import number
from euc_sim.rides.summary.rider_view import zone_words

__all__ = ["history_page", "table_zone", "start_in", "pwm_cell"]

_LEGEND = {"orientation": "h", "yanchor": "bottom", "y": 1.02, "xanchor": "left", "x": 0}


def table_zone(h) -> tuple[float | None, str]:
    """The one zone the rides' table shows every start in: the zone most of the logs that name
    one give (s east of UTC, and in words: :func:`~euc_sim.rides.logbook.history.shared_offset`,
    the zone the rides are sorted in), logs naming none (WheelLog: the phone's clock) taken
    as already in it; the phone's local time where no log names a zone."""
    off = h.zone
    if off is None:
        return None, zone_words(None)
    bare = any(e.utc_offset_s is None for e in h.rides)
    return off, zone_words(off) + (" (logs naming no zone: the phone's clock, as logged)" if bare else "")


def start_in(e, offset_s: float | None) -> str:
    """A :class:`~euc_sim.rides.logbook.history.RideEntry`'s start, "YYYY-MM-DD HH:MM", in the zone
    ``offset_s`` (:func:`table_zone`)."""
    t = datetime.fromisoformat(e.start)
    if e.utc_offset_s is not None and offset_s is not None:
        t += timedelta(seconds=offset_s)            # the entry's start is UTC
    return f"{t:%Y-%m-%d %H:%M}"


def pwm_cell(pct: float | None, unit: str = "") -> str:
    """A ride's max PWM, %, flagged as the ride page's tile judges it (warn from 80 %, bad from 90 %)."""
    if pct is None:
        return "–"
    flag = (f" BAD (≥ {PWM_BAD:.0f} %: close to a cut-out)" if pct >= PWM_BAD else
            f" high (≥ {PWM_WARN:.0f} %)" if pct >= PWM_WARN else "")
    return f"{pct:.0f}{unit}{flag}"


def _r(e, basis: str) -> tuple:
    b = e.battery
    if basis == "25C":
        return b.resistance_25C_ohm, b.resistance_25C_ci95
    return b.resistance_ohm, b.resistance_ci95


def _resistance_figure(h, x_key: str, title: str, x_title: str) -> dict:
    """Resistance (mΩ) with its 95 % interval against date or temperature."""
    pts = [(r, ci, e) for e in h.rides for r, ci in [_r(e, h.basis)] if r is not None and ci]
    off = table_zone(h)[0]
    xs = [start_in(e, off) if x_key == "date" else e.temperature_C for _, _, e in pts]
    ys = [1e3 * r for r, _, _ in pts]
    up = [1e3 * (ci[1] - r) for r, ci, _ in pts]
    lo = [1e3 * (r - ci[0]) for r, ci, _ in pts]
    label = "at 25 °C" if h.basis == "25C" else "as measured"
    return {"data": [{"type": "scatter", "mode": "markers", "x": xs, "y": ys,
                      "name": f"internal resistance {label}, 95 % interval",
                      "text": [Path(e.path).parent.name + "/" + Path(e.path).name for _, _, e in pts],
                      "error_y": {"type": "data", "array": up, "arrayminus": lo}}],
            "layout": {"title": {"text": title}, "xaxis": {"title": {"text": x_title}},
                       "yaxis": {"title": {"text": "internal resistance (mΩ)"}},
                       "legend": _LEGEND, "showlegend": True, "margin": {"t": 70}}}


def _whkm_figure(h) -> dict:
    rides = [e for e in h.rides if number(e.summary.Wh_per_km) is not None
             and number(e.summary.speed_mean_moving_mps) is not None]
    temps = [e.temperature_C for e in rides]
    marker = {"size": 11}
    if all(t is not None for t in temps) and temps:
        marker.update(color=temps, colorscale="Viridis", showscale=True,
                      colorbar={"title": {"text": "temperature (°C)"}})
    return {"data": [{"type": "scatter", "mode": "markers",
                      "x": [3.6 * number(e.summary.speed_mean_moving_mps) for e in rides],
                      "y": [number(e.summary.Wh_per_km) for e in rides], "marker": marker,
                      "name": "one ride (colour: logged temperature)",
                      "text": [Path(e.path).name for e in rides]}],
            "layout": {"title": {"text": "Consumption against average riding speed"},
                       "xaxis": {"title": {"text": "average speed while moving (km/h)"}},
                       "yaxis": {"title": {"text": "consumption (Wh/km)"}},
                       "legend": _LEGEND, "showlegend": True, "margin": {"t": 70}}}


def _fmt(x, scale=1.0, nd=0, none="–"):
    return none if x is None else round(x * scale, nd) if nd else int(round(x * scale))


def _rows(h) -> list:
    rows = []
    off = table_zone(h)[0]
    for e in h.rides:
        s = e.summary
        r, ci = _r(e, h.basis)
        rows.append([start_in(e, off), Path(e.path).name,
                     _fmt(number(s.distance_m), 1e-3, 1), _fmt(number(s.moving_s), 1 / 60),
                     _fmt(number(s.speed_max_mps), 3.6, 1), _fmt(number(s.energy_drawn_Wh)),
                     _fmt(number(s.Wh_per_km), 1, 1), _fmt(number(s.battery_used_pct)),
                     pwm_cell(number(s.pwm_max_pct)),
                     "–" if r is None else f"{1e3 * r:.0f} [{1e3 * ci[0]:.0f}, {1e3 * ci[1]:.0f}]",
                     _fmt(e.temperature_C), s.quality])
    return rows


def _key_figures(h) -> list:
    rides = h.rides
    dist = sum(number(e.summary.distance_m) or 0 for e in rides)
    energy = sum(number(e.summary.energy_drawn_Wh) or 0 for e in rides)
    off = table_zone(h)[0]
    first, last = start_in(rides[0], off)[:10], start_in(rides[-1], off)[:10]
    out = [KeyFigure("Rides", str(len(rides)), f"{first} to {last}"),
           KeyFigure("Distance", f"{dist / 1000:.1f} km"), KeyFigure("Energy drawn", f"{energy:.0f} Wh")]
    ch = h.change
    if ch:
        tone = "warn" if ch.verdict == "changed" else "good"
        out.append(KeyFigure("Battery resistance, latest ride", f"{1e3 * ch.latest:.0f} mΩ",
                             f"earlier rides {1e3 * ch.earlier_mean:.0f} mΩ", tone))
        out.append(KeyFigure("Battery resistance trend", h.trend or ch.verdict,
                             f"p = {ch.p_value:.2g}; latest − earlier {1e3 * ch.difference:+.0f} mΩ "
                             f"[{1e3 * ch.difference_ci95[0]:+.0f}, {1e3 * ch.difference_ci95[1]:+.0f}]", tone))
    trend = _trend_tile(h)
    return out + ([trend] if trend else [])


def _trend_tile(h):
    """Wh/km per 10 km/h of average speed: the slope where its interval excludes 0, else
    "no trend shown" with the span of speeds the rides cover (the slope is then noise)."""
    if h.whkm_slope is None or not h.whkm_slope_ci95:
        return None
    lo, hi = h.whkm_slope_ci95[0] / 0.36, h.whkm_slope_ci95[1] / 0.36
    label = "Consumption per 10 km/h faster"
    if lo <= 0 <= hi:
        sp = [v for e in h.rides for v in [number(e.summary.speed_mean_moving_mps)] if v is not None]
        return KeyFigure(label, "no trend shown",
                         f"the rides' average speeds span {3.6 * (max(sp) - min(sp)):.1f} km/h; "
                         f"95 % [{lo:+.0f}, {hi:+.0f}] Wh/km")
    return KeyFigure(label, f"{h.whkm_slope / 0.36:+.1f} Wh/km", f"95 % [{lo:+.1f}, {hi:+.1f}]")


def history_page(h, title: str = "Rides of one wheel") -> str:
    """The whole HTML page of a :class:`~euc_sim.rides.logbook.history.RideHistory`."""
    basis = "normalised to 25 °C" if h.basis == "25C" else "as measured (no battery temperature in every log)"
    body = [key_figures(_key_figures(h))]
    ch = h.change
    text = (f"Battery internal resistance {basis}, from the voltage sag against current of each ride. "
            + (f"The latest ride against the earlier {ch.n_earlier}: {ch.verdict} (p = {ch.p_value:.2g}). "
               + (ch.note + "." if ch.note else "") if ch else h.why.get("change", "")))
    body.append(section("Battery over time", paragraph(text)
                        + figure(_resistance_figure(h, "date", "Battery internal resistance per ride",
                                                   f"start ({table_zone(h)[1]})"), "r_date")
                        + figure(_resistance_figure(h, "temp", "Battery internal resistance against temperature",
                                                    "logged temperature (°C)"), "r_temp")))
    body.append(section("Consumption", figure(_whkm_figure(h), "whkm")))
    body.append(section("Every ride", table(
        [f"start ({table_zone(h)[1]})", "log", "distance (km)", "moving (min)", "top (km/h)", "drawn (Wh)", "Wh/km",
         "battery used (%)", "max PWM (%)", "resistance (mΩ) [95 %]", "temperature (°C)", "data"],
        _rows(h))))
    return page(title, f"{len(h.rides)} rides", body)

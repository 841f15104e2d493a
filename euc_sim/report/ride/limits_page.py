"""The wheel's limits on the ride's page: its speed limit, the speed at which the motor runs out of
voltage (100 % PWM, a cut-out) against the battery's charge, and the ride's own points against both.

Read from the ride's summary's :class:`~euc_sim.rides.drive.cutout.Limits` and its
:class:`~euc_sim.rides.drive.cutout.Cutout`;
the lead's sentences (:func:`limit_sentences`), the section's paragraph (:func:`limits_paragraph`),
its chart (:func:`cutout_figure`) and its plain-text version (:func:`limits_md`).
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from euc_sim.report.figures import YL_OR_RD, Line, plain_values, thin, xy_figure
from euc_sim.rides.drive.cutout import CONDITIONS, headroom_words
from euc_sim.report.ride.series import MOST_POINTS, RideSeries, max_pwm_mark, number

__all__ = ["limit_sentences", "limits_paragraph", "cutout_figure", "limits_md", "LIMITS_TITLE", "CUTOUT_LABELS",
           "envelope_figure", "pwm_check"]


def pwm_check(res) -> tuple[str, str, float] | None:
    """The one check of the duty model a ride's pages state: (kind, on what, RMS error in points).

    On the compared ride where there is one (the figure the terminal gives too), else on the
    ride's second half fitted on its first (the cut-out's); None without, and None where the logged
    duty is the app's computation (the model fits its formula).
    """
    if res.mass.fit.pwm_note:
        return None
    other = res.mass.pwm_heldout
    if other is not None and math.isfinite(other):
        return "compared", f"the compared ride ({Path(str(res.balance.compare or '')).name}), fitted on this one", other
    rmse = res.cutout.heldout_pwm_rmse_pct
    return None if rmse is None or not math.isfinite(rmse) else ("halves", "the ride's second half, fitted on its first", rmse)


def _peak(res, series: RideSeries | None) -> tuple[float, float, float | None] | None:
    """At the summary's max-PWM moment: (speed, km/h; PWM, %; battery reading, % or None)."""
    m = max_pwm_mark(res.rider.summary, series) if series is not None else None
    v = None if m is None else series.at("speed_kmh", m[0])
    if v is None:
        return None
    return v, number(res.rider.summary.pwm_max_pct), series.at("charge_pct", m[0])


def _cut_at(cut, charge: float | None, condition: str = "level") -> float | None:
    """The :class:`~euc_sim.rides.drive.cutout.Cutout`'s curve's speed at ``charge`` (%), km/h; None
    where it cannot say."""
    c = next((c for c in cut.curves if c.condition.name == condition), None)
    if c is None or charge is None:
        return None
    v = float(np.interp(charge, c.charge_pct, np.asarray(c.speed_mps, float)))
    return v * 3.6 if np.isfinite(v) else None


def limit_sentences(res, series: RideSeries | None) -> list[str]:
    """The wheel's limit, where the cut-out comes before it (the cut-out's ``danger``), and how close
    the ride's highest PWM came; no speed above the wheel's limit is said to be available."""
    lim, cut = res.rider.summary.limits, res.cutout
    out = [f"Your wheel's limit: {lim.words()}."]
    if cut.danger:
        out.append(cut.danger)
    elif cut.curves and lim.speed_limit_mps is not None:
        said = {c.condition.name for c in cut.curves}
        words = [c.words for c in CONDITIONS if c.name in said]
        out.append("At every charge, " + " and ".join([", ".join(words[:-1]), words[-1]] if len(words) > 1
                                                      else words)
                   + ", the motor keeps voltage up to that limit (chart below).")
    elif cut.why:
        out.append(f"Where the motor would run out of voltage cannot be said: {cut.why}.")
    p = _peak(res, series)
    if p is not None and p[1] is not None:
        out.append(f"At your highest PWM ({p[1]:.0f} %), riding {p[0]:.0f} km/h: "
                   f"{headroom_words(p[0], lim, _cut_at(cut, p[2]))}.")
    return out


#: The cut-out chart's line for each condition.
CUTOUT_LABELS = {"level": "on the level", "accelerating_1mps2": "accelerating at 1 m/s²",
                 "climbing_10pct": "climbing 10 %"}
#: Their colours, then the limit's (apart from the ride's points, yellow to red by PWM).
CUTOUT_COLOURS = ("#1a237e", "#6a1b9a", "#00838f", "#212121")


def cutout_figure(res, series: RideSeries | None):
    """Cut-out speed against battery charge for each condition, the wheel's limit, and the
    ride's own speeds at their charge coloured by the logged PWM; None without curves."""
    cut = res.cutout
    if not cut.curves:
        return None
    lim = res.rider.summary.limits
    lines = [Line(f"cut-out {CUTOUT_LABELS.get(c.condition.name, c.condition.name)}",
                  np.asarray(c.charge_pct, float), 3.6 * np.asarray(c.speed_mps, float), "lines")
             for c in cut.curves]
    top = [np.nanmax(ln.y) if np.isfinite(ln.y).any() else 0.0 for ln in lines]
    if lim.speed_limit_mps is not None:
        L = 3.6 * lim.speed_limit_mps
        src = "tilt-back, from the log" if lim.source == "log" else "the maker's top speed"
        lines.append(Line(f"your limit: {L:.0f} km/h ({src})", np.array([0.0, 100.0]), np.array([L, L]),
                          "lines", "dot"))
        top.append(L)
    check = pwm_check(res)
    note = ("PWM model checked on " + (f"{check[1]}: {check[2]:.1f} points RMS" if check else
                                       "the ride's second half: not enough PWM rows")
            + "; grey: charges this ride did not reach")
    fig = xy_figure(lines, "How fast before the motor runs out of voltage (100 % PWM, a cut-out)",
                    "battery charge, %", "speed, km/h", note)
    for tr, colour in zip(fig["data"], CUTOUT_COLOURS):
        tr["line"]["color"] = colour
    c = (series.channels if series is not None else {})
    if "charge_pct" in c and "speed_kmh" in c:
        ok = np.flatnonzero(np.isfinite(c["charge_pct"]) & (c["speed_kmh"] > 2.0))
        ok = ok[thin(ok.size, MOST_POINTS)]
        pwm = c.get("pwm_pct")
        marker = ({"size": 4, "color": plain_values(pwm[ok]), "colorscale": YL_OR_RD, "cmin": 0, "cmax": 100, "showscale": True,
                   "colorbar": {"title": {"text": "logged PWM, %", "side": "right"}, "thickness": 12}}
                  if pwm is not None else {"size": 4, "color": "#607d8b"})
        fig["data"].append({"type": "scatter", "x": plain_values(c["charge_pct"][ok]),
                            "y": plain_values(c["speed_kmh"][ok]), "mode": "markers", "marker": marker,
                            "name": "this ride" + (" (colour: logged PWM)" if pwm is not None else "")})
        top.append(float(np.max(c["speed_kmh"][ok])) if ok.size else 0.0)
    span = cut.charge_range
    if span:
        for x0, x1 in ((0.0, span[0]), (span[1], 100.0)):
            if x1 > x0:
                fig["layout"].setdefault("shapes", []).append(
                    {"type": "rect", "xref": "x", "yref": "y domain", "x0": x0, "x1": x1, "y0": 0, "y1": 1,
                     "fillcolor": "#9e9e9e", "opacity": 0.15, "line": {"width": 0}, "layer": "below"})
    fig["layout"]["xaxis"]["range"] = [0, 100]
    fig["layout"]["yaxis"]["range"] = [0, 1.3 * max(top)]
    return fig


def limits_paragraph(res, limit: bool = True) -> str:
    """The limits and the model behind the chart, in words (the summary's limits, the cut-out,
    :func:`pwm_check`); ``limit`` False: the speed limit left to the sentences before it."""
    lim, cut = res.rider.summary.limits, res.cutout
    check = pwm_check(res)
    return ((f"Speed limit: {lim.words()}. " if limit else "") + "PWM alarm: not in the log."
            + (f" The PWM model predicts the logged PWM of {check[1]}, to {check[2]:.1f} points RMS."
               if check else "")
            + (f" Charge to volts: {cut.ocv_source}." if cut.ocv_source else "")
            + (" The cut-out speeds are the model's: the controller's own current limit, not in the log, "
               "can come first." if cut.curves else ""))


#: The limits' section's title, on the page and in index.md.
LIMITS_TITLE = "Your wheel's limit and the cut-out"


def limits_md(res, series: RideSeries | None) -> list[str]:
    """index.md's limits section: the page's sentences on the wheel's limit and the cut-out
    (:func:`limit_sentences`, the lead's) and :func:`limits_paragraph` (the section's)."""
    return [f"## {LIMITS_TITLE}", "", " ".join(limit_sentences(res, series) + [limits_paragraph(res, False)]), ""]


def envelope_figure(res, series: RideSeries):
    """The PWM a steady speed takes on the level at full and empty charge (the envelope: the cut-out
    chart's model), with the ride's own points."""
    env = res.mass.envelope
    c = series.channels
    if env.speed is None or "pwm_pct" not in c:
        return None
    v = np.asarray(env.speed, float)
    keep = thin(series.t.size, MOST_POINTS)
    lines = [Line("this ride", c["speed_kmh"][keep], c["pwm_pct"][keep])]
    for name, dash in (("full", "solid"), ("low", "dash")):
        side = getattr(env, name)
        lines.append(Line(f"steady speed, the pack at {side.voltage:.0f} V", v * 3.6,
                          np.asarray(side.pwm_pct, float), "lines", dash))
    lines.append(Line("100 %: no voltage left", np.array([0.0, v[-1] * 3.6]), np.array([100.0, 100.0]),
                      "lines", "dot"))
    left = _peak(res, series)
    note = "above this ride's top speed the curves are extrapolated"
    if left is not None and left[1] is not None:

        sp, p = left[0], left[1]
        lines.append(Line(f"your max PWM: {p:.0f} % at {sp:.0f} km/h", np.array([sp]), np.array([p])))
        note = f"at your max PWM: {headroom_words(sp, res.rider.summary.limits, _cut_at(res.cutout, left[2]))}<br>" + note
    fig = xy_figure(lines, "How close to the limit: PWM against speed", "speed, km/h", "PWM, %", note)
    if left is not None and left[1] is not None:
        fig["data"][-1]["marker"] = {"size": 14, "color": "#c62828", "symbol": "star", "opacity": 1}
    fig["layout"]["yaxis"]["range"] = [0, 110]
    return fig

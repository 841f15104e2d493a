"""The fits' figures on the ride page: the held-out balance, its residual over time, the PWM model;
and the held-out balance's table (:func:`write_balance`, ``ride_balance.csv``).

Each builder returns a Plotly figure (drawn by the page, :func:`euc_sim.report.html.figure`)
readable alone: a title, axis titles with units, legends under the axes.  Long rides are
thinned to at most :data:`MOST_POINTS` points per curve; a gap in the log breaks its lines.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from euc_sim.io import write_text
from euc_sim.report.figures import Line, plain_values, thin, with_breaks, xy_figure
from euc_sim.rides.balance.design import CANDIDATES
from euc_sim.rides.balance.residual import SLOW_S

__all__ = ["balance_figure", "residuals_figure", "residuals_height", "pwm_figure", "write_balance", "MOST_POINTS",
           "BALANCE_HEIGHT", "PWM_HEIGHT"]

#: Points per curve at most (a 90-minute ride at 10 Hz has 54,000).
MOST_POINTS = 4000
#: Legends under the axes, never on the data.
_LEGEND = {"orientation": "h", "yref": "container", "yanchor": "bottom", "y": 0.0, "xanchor": "left", "x": 0.0}
_SHADE = "rgba(255,152,0,0.2)"
#: One colour per model on every panel: the log, the inertia-only and the augmented balance.
_LOG, _NOMINAL, _AUGMENTED = "#222222", "#d95f02", "#1b6fb3"
_SPEED = ("#666666", "#7b3294")
#: Pixels of :func:`balance_figure`; of :func:`pwm_figure`.
BALANCE_HEIGHT, PWM_HEIGHT = 980, 520


def _stack(titles, height: int) -> dict:
    """A figure of panels stacked on rows (a plain Plotly spec: no per-shape validation)."""
    n, gap = len(titles), 0.13
    h = (1.0 - gap * (n - 1)) / n
    layout = {"height": height, "legend": _LEGEND, "margin": {"l": 70, "r": 20, "t": 80, "b": 130},
              "hovermode": "x", "shapes": [], "annotations": []}
    for i, title in enumerate(titles):
        top = 1.0 - i * (h + gap)
        ax = "" if i == 0 else str(i + 1)
        layout[f"xaxis{ax}"] = {"anchor": f"y{ax}", "domain": [0.0, 1.0]}
        layout[f"yaxis{ax}"] = {"anchor": f"x{ax}", "domain": [top - h, top]}
        layout["annotations"].append({"text": title, "xref": "paper", "yref": "paper", "x": 0.5, "y": top,
                                      "xanchor": "center", "yanchor": "bottom", "showarrow": False,
                                      "font": {"size": 13}})
    layout[f"xaxis{'' if n == 1 else n}"]["title"] = {"text": "time from the start of the log, min"}
    return {"data": [], "layout": layout}


def _axis(row: int) -> str:
    return "" if row == 1 else str(row)


def _lines(fig: dict, row: int, t: np.ndarray, curves, gap: float) -> None:
    """``curves``: (name, y, line style) over ``t`` (s; drawn in min, as the page's other times), thinned,
    broken at gaps, on ``row``."""
    keep = thin(t.size, MOST_POINTS)
    cols = with_breaks(t[keep], gap, *(np.asarray(y, float)[keep] for _, y, _ in curves))
    x = plain_values(cols[0] / 60.0)
    for (name, _, style), y in zip(curves, cols[1:]):
        fig["data"].append({"type": "scatter", "mode": "lines", "x": x, "y": plain_values(y), "name": name,
                            "line": style, "xaxis": f"x{_axis(row)}", "yaxis": f"y{_axis(row)}",
                            "hovertemplate": "%{y:.0f}<extra>" + name.split(":")[0] + "</extra>"})


def _shade(fig: dict, row: int, a: float, b: float, label: str | None = None) -> None:
    """A span of time, ``a`` to ``b`` s (drawn in min), shaded on ``row``'s panel, ``label`` at its top left."""
    ax, a, b = _axis(row), a / 60.0, b / 60.0
    fig["layout"]["shapes"].append({"type": "rect", "xref": f"x{ax}", "yref": f"y{ax} domain", "x0": a, "x1": b,
                                    "y0": 0.0, "y1": 1.0, "fillcolor": _SHADE, "line": {"width": 0},
                                    "layer": "below"})
    if label:
        fig["layout"]["annotations"].append({"text": label, "xref": f"x{ax}", "yref": f"y{ax} domain", "x": a,
                                             "y": 1.0, "xanchor": "left", "yanchor": "top", "showarrow": False,
                                             "font": {"size": 11}})


def _ytitle(fig: dict, row: int, text: str) -> None:
    fig["layout"][f"yaxis{_axis(row)}"]["title"] = {"text": text}


def _gap(t: np.ndarray) -> float:
    """A jump in time, s, that breaks a line: 1.5 times the thinned curve's step."""
    keep = thin(t.size, MOST_POINTS)
    return 1.5 * float(np.median(np.diff(t[keep]))) if keep.size > 1 else np.inf


def balance_figure(cr, sig_fit=None, sig_test=None):
    """The test ride's battery power against the inertia-only and augmented predictions.

    Panels: (1) the logged wheel speed of both rides, km/h (one ride split in halves: the
    held-out second half shaded); (2) on the test ride, the measured battery power and
    both models' predictions from the fit ride's parameters, W; (3) their residuals with
    RMS values and the error ratio.

    Parameters
    ----------
    cr : CrossRide
    sig_fit, sig_test : RideSignals, optional
        The rides' signals (their speed, panel 1).

    Returns
    -------
    dict
        A Plotly figure spec (``data``, ``layout``).
    """
    td = cr.test_design
    pn, pa = td.predict(cr.nominal.estimate), td.predict(cr.augmented.estimate)
    aug = cr.augmented.estimate
    sym = {c: "+".join([CANDIDATES[c][0]] + [CANDIDATES[a][0] for a in cr.fit_design.aliases.get(c, ())
                                             if a in CANDIDATES]) for c in cr.accepted}
    lab = ", ".join(f"{sym[c]} = {aug[c]:.3g}" for c in cr.accepted) or "nothing accepted"
    what = "measured − predicted" if td.domain == "power" else "(measured − predicted)·R/v"
    fig = _stack(["Logged wheel speed (10 Hz grid, Savitzky–Golay 1.5 s)",
                  f"{cr.test_label}: predicted from its speed with parameters fitted on {cr.fit_label}",
                  f"Held-out residual; error ratio augmented / inertia-only = {cr.ratio:.2f}"], BALANCE_HEIGHT)
    if sig_fit is not None and sig_test is None:          # one ride, split in halves
        t = sig_fit.frame["t"].to_numpy(float)
        _lines(fig, 1, t, [(f"{Path(str(sig_fit.path)).name}, the whole ride",
                            sig_fit.frame["v"].to_numpy(float) * 3.6, {"width": 1, "color": _SPEED[0]})], _gap(t))
        _shade(fig, 1, float(td.t.min()), float(t.max()), "second half: held out (test); the first half is the fit")
    else:
        for sig, label, colour in ((sig_fit, f"{cr.fit_label} (fit)", _SPEED[0]),
                                   (sig_test, f"{cr.test_label} (test)", _SPEED[1])):
            if sig is not None:
                t = sig.frame["t"].to_numpy(float)
                _lines(fig, 1, t, [(label, sig.frame["v"].to_numpy(float) * 3.6, {"width": 1, "color": colour})],
                       _gap(t))
    gap = _gap(td.t)
    _lines(fig, 2, td.t, [("measured battery power V·I", td.P, {"width": 1, "color": _LOG}),
                          ("inertia only (no resistance, no loss)", pn, {"width": 1, "color": _NOMINAL}),
                          (f"augmented ({lab})", pa, {"width": 1, "color": _AUGMENTED})], gap)
    _lines(fig, 3, td.t, [(f"inertia only: RMS {cr.heldout_nominal:.0f} {td.unit}", td.weight * (td.P - pn),
                           {"width": 0.8, "color": _NOMINAL}),
                          (f"augmented: RMS {cr.heldout_augmented:.0f} {td.unit}", td.weight * (td.P - pa),
                           {"width": 0.8, "color": _AUGMENTED})], gap)
    for row, y in ((1, "wheel speed, km/h"), (2, "battery power, W"), (3, f"{what}, {td.unit}")):
        _ytitle(fig, row, y)
    fig["layout"]["title"] = {"text": f"Battery-power balance fitted on {cr.fit_label}, tested on {cr.test_label}"}
    return fig


def residuals_figure(traces):
    """The balance residuals over time (trace's unit), one panel per ride, the windows where they
    concentrate shaded: inertia-only, augmented and the augmented one's moving mean.

    Parameters
    ----------
    traces : sequence of ResidualTrace
    """
    traces = list(traces)
    titles = [f"{tr.label}: balance residual, "
              + ("in sample (fitted here)" if tr.in_sample else "held out (fitted on the other ride)")
              for tr in traces]
    fig = _stack(titles, residuals_height(len(traces)))
    for row, tr in enumerate(traces, start=1):
        _lines(fig, row, np.asarray(tr.t, float), [
            (f"inertia only: RMS {tr.rms_nominal:.0f} {tr.unit}", tr.nominal, {"width": 0.7, "color": _NOMINAL}),
            (f"augmented: RMS {tr.rms_augmented:.0f} {tr.unit}", tr.augmented,
             {"width": 0.7, "color": _AUGMENTED}),
            (f"augmented, {SLOW_S:.0f} s moving mean: RMS {tr.rms_slow:.0f} {tr.unit}", tr.slow,
             {"width": 1.6, "color": _LOG})], _gap(np.asarray(tr.t, float)))
        for i, (a, b) in enumerate(tr.localisation["windows"]):
            _shade(fig, row, a, b, (f"shaded: where the inertia-only residual concentrates "
                                    f"({100 * tr.localisation['share']:.0f} % of its energy)") if i == 0 else None)
        _ytitle(fig, row, f"measured − predicted, {tr.unit}")
    fig["layout"]["title"] = {"text": "Battery-power balance residual over time"}
    return fig


def residuals_height(n: int) -> int:
    """Pixels of :func:`residuals_figure` with ``n`` panels."""
    return 360 * n + 160


def pwm_figure(check, title: str):
    """PWM predicted by the drivetrain model against the logged one, %, with the line of equality.

    Parameters
    ----------
    check : DutyCheck
        The prediction (:func:`~euc_sim.rides.drive.drivetrain_report.duty_check`).
    title : str
    """
    pred, obs = check.predicted, check.logged
    keep = thin(obs.size, MOST_POINTS)
    top = max(100.0, float(np.nanmax(obs))) if obs.size else 100.0
    return xy_figure([Line(f"log samples: RMS {check.rmse:.1f} points", obs[keep], pred[keep]),
                      Line("equal", np.array([0.0, top]), np.array([0.0, top]), mode="lines")],
                     title, "logged PWM, %", "predicted PWM, %")


def write_balance(an, report_dir) -> Path:
    """Write ``ride_balance.csv`` (the test ride: t, v, measured and predicted battery power) atomically.

    Parameters
    ----------
    an : euc_sim.rides.balance.analysis.RideAnalysis
    report_dir : path

    Returns
    -------
    pathlib.Path
        The table.
    """
    cr, d_test, report_dir = an.cross, an.cross.test_design, Path(report_dir)
    cols = {"t": d_test.t, "v": d_test.v, "P_measured": d_test.P,
            "P_nominal": d_test.predict(cr.nominal.estimate), "P_augmented": d_test.predict(cr.augmented.estimate)}
    # 7 significant digits (0.01 s, 1 mW), the whole table one %-format of Python floats
    table = np.column_stack(list(cols.values()))
    rows = (",".join(["%.7g"] * len(cols)) + "\n") * len(table) % tuple(table.ravel().tolist())
    return write_text(report_dir / "ride_balance.csv", ",".join(cols) + "\n" + rows)

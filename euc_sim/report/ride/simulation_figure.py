"""The figure of a simulated ride (``ride_simulation.png``): where the modelled steps part.

The whole ride's speed once, then a zoomed window where the first and last steps differ most
(:func:`zoom_window`), and each step's battery-power error as a moving RMS.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from euc_sim.rides.grids.signals import break_at_gaps

__all__ = ["ride_simulation_figure", "zoom_window", "moving_rms", "ZOOM_S", "RMS_S", "PANELS"]

#: s: length of the zoomed window.
ZOOM_S = 60.0
#: s: span of the moving RMS of the error.
RMS_S = 30.0


def _rows(t: np.ndarray, span: float) -> int:
    dt = float(np.median(np.diff(t))) if t.size > 1 else 1.0
    return max(1, min(t.size, int(round(span / dt))))


def moving_rms(t: np.ndarray, e: np.ndarray) -> np.ndarray:
    """Centred moving RMS of ``e`` over :data:`RMS_S` seconds of rows; NaN rows are left out.

    Parameters
    ----------
    t : array, s
        Grid times (rows missing at gaps).
    e : array
        The error, any unit.

    Returns
    -------
    array
        Same length and unit as ``e``; NaN where the span holds no finite value.
    """
    e = np.asarray(e, float)
    ok = np.isfinite(e)
    w = np.ones(_rows(np.asarray(t, float), RMS_S))
    num = np.convolve(np.where(ok, e * e, 0.0), w, mode="same")
    den = np.convolve(ok.astype(float), w, mode="same")
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(den > 0, np.sqrt(num / np.maximum(den, 1.0)), np.nan)


def zoom_window(t: np.ndarray, a: np.ndarray, b: np.ndarray, scored: np.ndarray | None = None) -> tuple[float, float]:
    """The :data:`ZOOM_S`-second window where ``a`` and ``b`` differ most (largest mean square).

    Parameters
    ----------
    t : array, s
    a, b : array
        Two series on ``t`` (e.g. the nominal and the augmented battery power).
    scored : array of bool, optional
        Rows that may be chosen (default: all).

    Returns
    -------
    (start, end) : float, s
        The whole of ``t`` when it is shorter than :data:`ZOOM_S`.
    """
    t = np.asarray(t, float)
    if t[-1] - t[0] <= ZOOM_S:
        return float(t[0]), float(t[-1])
    d = np.asarray(a, float) - np.asarray(b, float)
    ok = np.isfinite(d) & (np.ones(t.size, bool) if scored is None else np.asarray(scored, bool))
    score = np.convolve(np.where(ok, d * d, 0.0), np.ones(_rows(t, ZOOM_S)), mode="same")
    centre = float(t[int(np.argmax(score))])
    start = min(max(centre - ZOOM_S / 2, t[0]), t[-1] - ZOOM_S)
    return float(start), float(start + ZOOM_S)


#: Line style of each source: the log, then the steps in order.
LOG_STYLE = dict(color="k", lw=1.0)
STEP_STYLES = (dict(color="tab:red", lw=0.9), dict(color="tab:orange", lw=0.9, ls="--"),
               dict(color="tab:green", lw=0.9, ls="-."), dict(color="tab:blue", lw=0.9, ls=":"),
               dict(color="tab:purple", lw=0.9, ls="--"))

#: Zoomed panels: table stem -> (y label, what, error key, unit, scale for display).
PANELS = {"P": ("battery power [W]", "battery power (log: V·I)", "P_W", "W", 1.0),
          "I": ("phase current [A]", "phase current", "I_phase_A", "A", 1.0),
          "pitch": ("body pitch [deg]", "body pitch (log's convention)", "pitch_rad", "deg",
                    180.0 / np.pi),
          "pwm": ("PWM duty [%]", "PWM duty", "pwm_pct", "%", 1.0)}


def ride_simulation_figure(sim):
    """Figure: the simulated rider on the logged profile against the log, one line per step.

    Panels: (a) speed over the whole ride, m/s, the zoomed window shaded; then, in
    that window, battery power W, and phase current A, body pitch deg and PWM
    duty % where the log has them (logged, and simulated by each step that ran); last,
    the battery-power error log − simulation of each step as a :data:`RMS_S` moving
    RMS over the whole ride, W, with the windows where the last step's error
    concentrates shaded.

    Parameters
    ----------
    sim : euc_sim.rides.sim.simulate.RideSimulation

    Returns
    -------
    matplotlib.figure.Figure
    """
    from matplotlib.figure import Figure

    tb, e = sim.table, sim.errors
    names = [n for n in sim.ran if f"P_{n}" in tb] or ["nominal", "augmented"]
    t = tb["t"].to_numpy()
    lo, hi = zoom_window(t, tb[f"P_{names[0]}"].to_numpy(), tb[f"P_{names[-1]}"].to_numpy(),
                         tb["scored"].to_numpy() if "scored" in tb else None)
    panels = [c for c in PANELS if f"{c}_log" in tb and any(f"{c}_{n}" in tb for n in names)]
    n = len(panels) + 2
    fig = Figure(figsize=(13, 2.9 * n), layout="constrained")
    ax = fig.subplots(n, 1, gridspec_kw={"height_ratios": [1.0] * (n - 1) + [1.2]})
    styles = [("log", LOG_STYLE)] + [(nm, STEP_STYLES[i % len(STEP_STYLES)]) for i, nm in enumerate(names)]
    _speed_overview(ax[0], t, tb, styles, (lo, hi))
    window = (t >= lo) & (t <= hi)
    for k, col in enumerate(panels, start=1):
        ylab, what, key, unit, scale = PANELS[col]
        have = [(nm, st) for nm, st in styles if f"{col}_{nm}" in tb]
        cols = break_at_gaps(t[window], *(scale * tb[f"{col}_{nm}"].to_numpy()[window] for nm, _ in have))
        for (name, st), y in zip(have, cols[1:]):
            rms = "" if name == "log" or key not in e.get(name, {}) else \
                f" (RMS {scale * e[name][key]:.3g} {unit})"
            ax[k].plot(cols[0], y, label=("log" if name == "log" else f"step {name}") + rms, **st)
        ax[k].set(ylabel=ylab, xlabel="time from start of log [s]", xlim=(lo, hi),
                  title=f"({'abcdefg'[k]}) zoom on {lo:.0f}–{hi:.0f} s, where the first and last "
                        f"steps differ most: {what}")
        _legend_right(ax[k])
    _error_panel(ax[-1], t, tb, sim, e, names, styles[1:], "abcdefg"[n - 1])
    fig.suptitle(f"Simulated rider along {Path(sim.label).name}, step by step ({' → '.join(names)}):\n"
                 f"the whole ride, a zoom where the steps differ, and the error over time", fontsize=11)
    return fig


def _legend_right(ax) -> None:
    ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=8, borderaxespad=0.0)


def _speed_overview(ax, t, tb, styles, zoom) -> None:
    cols = break_at_gaps(t, *(tb[f"v_{n}"].to_numpy() for n, _ in styles))
    for (name, st), y in zip(styles, cols[1:]):
        ax.plot(cols[0], y, label="log" if name == "log" else f"step {name}", **st)
    ax.axvspan(*zoom, color="gold", alpha=0.3, lw=0, label="zoomed below")
    ax.set(ylabel="speed [m/s]", xlabel="time from start of log [s]",
           title="(a) wheel speed over the whole ride: logged, and followed by the simulated rider")
    _legend_right(ax)


def _error_panel(ax, t, tb, sim, e, names, styles, letter) -> None:
    for name, st in styles:
        r = moving_rms(t, tb["P_log"].to_numpy() - tb[f"P_{name}"].to_numpy())
        ax.plot(*break_at_gaps(t, r), color=st["color"], ls=st.get("ls", "-"), lw=1.2,
                label=f"step {name}: RMS on\nthe scored rows {e[name]['P_W']:.0f} W")
    for i, (a, b) in enumerate(sim.localisation.get("windows", [])):
        ax.axvspan(a, b, color="tab:gray", alpha=0.2, lw=0,
                   label=f"windows where the\n{names[-1]} error concentrates" if i == 0 else None)
    ax.set_ylim(bottom=0.0)
    ax.set(ylabel=f"{RMS_S:.0f} s moving RMS of\nlog − simulation [W]", xlabel="time from start of log [s]",
           title=f"({letter}) battery-power error of each step over time; last / first step = "
                 f"{sim.ratio_P:.2f}")
    _legend_right(ax)

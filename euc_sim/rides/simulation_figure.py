"""The figure of a simulated ride (``ride_simulation.png``): where nominal and augmented part.

A ride is minutes long and the two simulations overlap nearly everywhere, so the
figure shows the whole ride once (speed), then a zoomed window where the two
simulations differ most (speed, motor torque, battery power), and the battery-power
error over time as a moving RMS.  :func:`ride_simulation_figure` builds it from a
:class:`euc_sim.rides.simulate.RideSimulation`; :func:`zoom_window` picks the window.
"""

from __future__ import annotations

import numpy as np

from euc_sim.rides.signals import break_at_gaps

__all__ = ["ride_simulation_figure", "zoom_window", "moving_rms", "ZOOM_S", "RMS_S"]

#: s: length of the zoomed window.
ZOOM_S = 60.0
#: s: span of the moving RMS of the error.
RMS_S = 30.0


def _rows(t: np.ndarray, span: float) -> int:
    dt = float(np.median(np.diff(t))) if t.size > 1 else 1.0
    return max(1, min(t.size, int(round(span / dt))))


def moving_rms(t: np.ndarray, e: np.ndarray, span: float = RMS_S) -> np.ndarray:
    """Centred moving RMS of ``e`` over ``span`` seconds of rows; NaN rows are left out.

    Parameters
    ----------
    t : array, s
        Grid times (rows missing at gaps).
    e : array
        The error, any unit.
    span : float, s

    Returns
    -------
    array
        Same length and unit as ``e``; NaN where the span holds no finite value.
    """
    e = np.asarray(e, float)
    ok = np.isfinite(e)
    w = np.ones(_rows(np.asarray(t, float), span))
    num = np.convolve(np.where(ok, e * e, 0.0), w, mode="same")
    den = np.convolve(ok.astype(float), w, mode="same")
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(den > 0, np.sqrt(num / np.maximum(den, 1.0)), np.nan)


def zoom_window(t: np.ndarray, a: np.ndarray, b: np.ndarray, scored: np.ndarray | None = None,
                span: float = ZOOM_S) -> tuple[float, float]:
    """The ``span``-second window where ``a`` and ``b`` differ most (largest mean square).

    Parameters
    ----------
    t : array, s
    a, b : array
        Two series on ``t`` (e.g. the nominal and the augmented battery power).
    scored : array of bool, optional
        Rows that may be chosen (default: all).
    span : float, s

    Returns
    -------
    (start, end) : float, s
        The whole of ``t`` when it is shorter than ``span``.
    """
    t = np.asarray(t, float)
    if t[-1] - t[0] <= span:
        return float(t[0]), float(t[-1])
    d = np.asarray(a, float) - np.asarray(b, float)
    ok = np.isfinite(d) & (np.ones(t.size, bool) if scored is None else np.asarray(scored, bool))
    score = np.convolve(np.where(ok, d * d, 0.0), np.ones(_rows(t, span)), mode="same")
    centre = float(t[int(np.argmax(score))])
    start = min(max(centre - span / 2, t[0]), t[-1] - span)
    return float(start), float(start + span)


def ride_simulation_figure(sim):
    """Figure: the simulated rider on the logged profile against the log.

    Panels: (a) speed over the whole ride, m/s, the zoomed window shaded; (b-d) in
    that window, speed, motor torque (inferred from the log, simulated), N·m, and
    battery power (logged, predicted), W; (e) the battery-power error log −
    simulation as a :data:`RMS_S` moving RMS over the whole ride, W, with the
    windows where the augmented error concentrates shaded.

    Parameters
    ----------
    sim : euc_sim.rides.simulate.RideSimulation

    Returns
    -------
    matplotlib.figure.Figure
    """
    from matplotlib.figure import Figure

    tb, e = sim.table, sim.errors
    t = tb["t"].to_numpy()
    lo, hi = zoom_window(t, tb["P_nominal"].to_numpy(), tb["P_augmented"].to_numpy(),
                         tb["scored"].to_numpy() if "scored" in tb else None)
    fig = Figure(figsize=(13, 14), layout="constrained")
    ax = fig.subplots(5, 1, gridspec_kw={"height_ratios": [1.0, 1.0, 1.0, 1.0, 1.2]})
    styles = (("log", dict(color="k", lw=1.0)), ("nominal", dict(color="tab:red", lw=0.9)),
              ("augmented", dict(color="tab:blue", lw=0.9, ls="--")))
    _speed_overview(ax[0], t, tb, styles, (lo, hi))
    window = (t >= lo) & (t <= hi)
    for k, (col, ylab, what, key, unit) in enumerate(
            [("v", "speed [m/s]", "wheel speed", "v_mps", "m/s"),
             ("M", "motor torque M_d [N·m]", f"motor torque (log: {e['M_log_method']})", "M_Nm", "N·m"),
             ("P", "battery power [W]", "battery power (log: V·I)", "P_W", "W")], start=1):
        cols = break_at_gaps(t[window], *(tb[f"{col}_{n}"].to_numpy()[window] for n, _ in styles))
        for (name, st), y in zip(styles, cols[1:]):
            rms = "" if name == "log" else f"\n(RMS diff on the scored rows {e[name][key]:.3g} {unit})"
            ax[k].plot(cols[0], y, label=("log" if name == "log" else f"{name} simulation") + rms, **st)
        ax[k].set(ylabel=ylab, xlabel="time from start of log [s]", xlim=(lo, hi),
                  title=f"({'abcde'[k]}) zoom on {lo:.0f}–{hi:.0f} s, where the two simulations "
                        f"differ most: {what}")
        _legend_right(ax[k])
    _error_panel(ax[4], t, tb, sim, e)
    fig.suptitle(f"Simulated rider along {sim.label}: the whole ride, a zoom where nominal and "
                 f"augmented differ, and the error over time", fontsize=11)
    return fig


def _legend_right(ax) -> None:
    ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=8, borderaxespad=0.0)


def _speed_overview(ax, t, tb, styles, zoom) -> None:
    cols = break_at_gaps(t, *(tb[f"v_{n}"].to_numpy() for n, _ in styles))
    for (name, st), y in zip(styles, cols[1:]):
        ax.plot(cols[0], y, label="log" if name == "log" else f"{name} simulation", **st)
    ax.axvspan(*zoom, color="gold", alpha=0.3, lw=0, label="zoomed below")
    ax.set(ylabel="speed [m/s]", xlabel="time from start of log [s]",
           title="(a) wheel speed over the whole ride: logged, and followed by the simulated rider")
    _legend_right(ax)


def _error_panel(ax, t, tb, sim, e) -> None:
    eff = ", ".join(f"{k}={v:.3g}" for k, v in sim.effects.items()) or "none"
    for name, color, ls in (("nominal", "tab:red", "-"), ("augmented", "tab:blue", "--")):
        r = moving_rms(t, tb["P_log"].to_numpy() - tb[f"P_{name}"].to_numpy())
        what = "nominal" if name == "nominal" else f"augmented\n({eff})"
        ax.plot(*break_at_gaps(t, r), color=color, ls=ls, lw=1.2,
                label=f"{what}: RMS on\nthe scored rows {e[name]['P_W']:.0f} W")
    for i, (a, b) in enumerate(sim.localisation.get("windows", [])):
        ax.axvspan(a, b, color="tab:orange", alpha=0.2, lw=0,
                   label="windows where the\naugmented error concentrates" if i == 0 else None)
    ax.set_ylim(bottom=0.0)
    ax.set(ylabel=f"{RMS_S:.0f} s moving RMS of\nlog − simulation [W]", xlabel="time from start of log [s]",
           title=f"(e) battery-power error of the simulation over time; ratio augmented / nominal = "
                 f"{e['ratio_P']:.2f}")
    _legend_right(ax)

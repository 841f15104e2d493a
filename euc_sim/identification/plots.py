"""Figures of the identification, like the paper's Figs. 6-8 (matplotlib, Agg).

Angles are shown in degrees, torques in N·m, heights in m; everything inside is SI.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
from matplotlib.lines import Line2D
from matplotlib.patches import Patch
from matplotlib.ticker import FixedLocator, FormatStrFormatter, LogLocator, NullFormatter, NullLocator

from euc_sim.identification.h_fit import MIN_RISE
from euc_sim.identification.processing import term_filter
from euc_sim.io import save_figure

__all__ = ["recording_figure", "rmse_curves_figure",
           "plot_maneuver_curves", "maneuver_curves_figure", "verdict_label", "rollout_figure", "plain_log_ticks"]


def recording_figure(rec, torques_df, fit):
    """The paper's Fig. 6/7 for one recording: (ψ), (ϑ) where recorded, γ, φ, and M_d,1 against M_d,2 (3-DoF,
    identified h).

    ``rec``: :class:`~euc_sim.identification.h_fit.Recording`; ``torques_df``:
    :func:`euc_sim.identification.torques.torques` at the identified h; ``fit``: its 3-DoF HFit.
    """
    from matplotlib.figure import Figure

    kin = rec.kin
    panels = [(k, lab) for k, lab in (("psi", "yaw ψ"), ("theta", "tilt ϑ")) if k in kin.extra]
    panels += [("gamma", "EUC pitch γ"), ("phi", "rider pitch φ"), ("torque", "")]
    fig = Figure(figsize=(10, 1.9 * len(panels) + 0.8), layout="constrained")
    axes = fig.subplots(len(panels), 1, sharex=True)
    t = kin.t
    for ax, (key, label), letter in zip(axes, panels, "abcdefg"):
        if key == "torque":
            sl = kin.interior            # edges lack filter support: not drawn, shaded
            ti = t[sl]
            if "M_d" in rec.df.columns:      # through the same term filter as the estimates

                M_d = term_filter(rec.df["M_d"].to_numpy(dtype=float),
                                  kin.smoothing.sigma_samples(kin.dt))
                ax.plot(ti, M_d[sl], color="0.5", lw=2.5, alpha=0.6,
                        label="$M_d$ recorded (same filter)")
            ax.plot(ti, torques_df["M_d1"].to_numpy()[sl], color="tab:blue", lw=1.2,
                    label="$M_{d,1}$ (eq. 9)")
            ax.plot(ti, torques_df["M_d2"].to_numpy()[sl], color="tab:red", lw=1.2, ls="--",
                    label="$M_{d,2}$ (eq. 10)")
            ax.axvspan(t[0], ti[0], color="0.9")
            ax.axvspan(ti[-1], t[-1], color="0.9")
            ax.set_ylabel("torque [N·m]")
            ax.set_title(f"({letter}) driving torque, 3-DoF model, h = {fit.h:.3f} m: "
                         f"RMSE($M_{{d,1}} - M_{{d,2}}$) = {fit.rmse:.3f} N·m", fontsize=9)
            ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=8)
        else:
            y = kin.extra[key] if key in kin.extra else kin.q[:, 1 if key == "gamma" else 2]
            ax.plot(t, np.degrees(y), color="k", lw=1.0)
            ax.set_ylabel(f"{label.split()[-1]} [°]")
            ax.set_title(f"({letter}) {label}", fontsize=9)
        ax.grid(alpha=0.3)
    axes[-1].set_xlabel("time t [s]")
    fig.suptitle(f"{Path(rec.name).name}: processed data (cf. the paper's Figs. 6-7); "
                 f"smoothing {kin.smoothing.method}", fontsize=10)
    return fig


def rmse_curves_figure(names, per_recording, pooled):
    """The paper's Fig. 8: RMSE(M_d,1 − M_d,2) against h, 3-DoF and 2-DoF, per recording and pooled.

    Each curve over its own minimum on one shared log scale, so the rise within ±0.1 m
    (:attr:`HFit.flatness`) reads the same against :data:`MIN_RISE` in every panel.
    ``per_recording``: list of dict model → HFit; ``pooled``: dict model → HFit.
    """
    from matplotlib.figure import Figure

    items = list(zip([Path(n).name for n in names], per_recording))
    if len(items) > 1:
        items.append(("pooled", pooled))
    n = len(items)
    cols = min(n, 4)
    rows = int(math.ceil(n / cols))
    fig = Figure(figsize=(max(4.4 * cols, 8.8), 3.3 * rows + 1.6), layout="constrained")
    axes = fig.subplots(rows, cols, squeeze=False, sharey=True)
    top = min(20.0, max(float(np.nanmax(f.rmse_grid / f.rmse)) for _, fits in items
                        for f in fits.values() if f.rmse > 0))
    for ax, (title, fits), letter in zip(axes.flat, items, "abcdefghijklmnopqrstuvwxyz" * 3):
        lines = [f"({letter}) {title}"]
        for model, fit in fits.items():
            color, label = _STYLE[model]
            ax.plot(fit.h_grid, fit.rmse_grid / fit.rmse, color=color)
            ax.plot([fit.h], [1.0], "o", color=color, ms=5)
            sides = [fit.h + d for d in (-0.1, 0.1) if fit.h_grid[0] <= fit.h + d <= fit.h_grid[-1]]
            ax.plot(sides, np.interp(sides, fit.h_grid, fit.rmse_grid) / fit.rmse, "^", color=color,
                    mec="k", ms=5)
            if np.all(np.isfinite(fit.h_ci95)):
                ax.axvspan(*fit.h_ci95, color=color, alpha=0.15, lw=0)
            lines.append(f"{label}: h {fit.h:.3f} m, {fit.rmse:.3g} N·m, " + verdict_label(fit))
        ax.axhline(1.0 + MIN_RISE, color="k", ls=":", lw=1.0)
        ax.set_title("\n".join(lines), fontsize=8, loc="left")
        ax.set_xlabel("h [m]")
        ax.set_ylabel("RMSE / its minimum")
        ax.grid(alpha=0.3)
    axes[0, 0].set_yscale("log")              # a ratio axis from 0.9 with plain tick labels
    axes[0, 0].set_ylim(0.9, max(top, 2.0) * 1.1)
    plain_log_ticks(axes[0, 0].yaxis, [1, 1.5, 2, 3, 5, 10, 20])
    for ax in list(axes.flat)[n:]:
        ax.set_visible(False)
    handles = [Line2D([], [], color=c, label=lab) for c, lab in _STYLE.values()]
    handles += [Line2D([], [], ls="", marker="o", color="0.4", label="minimum: the identified h"),
                Line2D([], [], ls="", marker="^", color="0.4", mec="k",
                       label="RMSE at h ± 0.1 m: the rise is the lower one"),
                Line2D([], [], color="k", ls=":", label=f"identifiable from a rise of {100 * MIN_RISE:.0f}%"),
                Patch(color="0.4", alpha=0.3, label="95% bootstrap interval of h")]
    fig.legend(handles=handles, loc="outside lower center", ncol=3, fontsize=8)
    fig.suptitle("RMSE between $M_{d,1}$ and $M_{d,2}$ against h (cf. the paper's Fig. 8), each curve "
                 "divided by its minimum,\non one scale: the rise within ±0.1 m of the minimum decides "
                 "whether h is identifiable", fontsize=10)
    return fig


def verdict_label(fit) -> str:
    """The identifiability verdict in a few words naming its rule: ``"rise 300%: identifiable"``, ``"rise 25% <
    75%: shallow"``."""
    rise = f"rise {100 * fit.flatness:.0f}%"
    if fit.identifiable:
        return f"{rise}: identifiable"
    if "at_bound" in fit.at_bound() or "search bound" in fit.reason:
        return "on the search bound"
    if fit.flatness < MIN_RISE:
        return f"{rise} < {100 * MIN_RISE:.0f}%: shallow"
    return "interval too wide" if "wide" in fit.reason else "no interval"


def plot_maneuver_curves(groups, path, true_h: float | None = None) -> list[Path]:
    """Write :func:`maneuver_curves_figure` to ``path`` and, as vector graphics, beside it
    as ``.svg`` (atomically); returns both paths."""
    fig = maneuver_curves_figure(groups, true_h)
    path = Path(path)
    return [save_figure(fig, path), save_figure(fig, path.with_suffix(".svg"))]


def maneuver_curves_figure(groups, true_h: float | None = None):
    """Fig. 8 per maneuver: pooled RMSE(h) (N·m) of both models, minima, 95 % intervals and the true h (m) where known.

    ``groups``: per maneuver (name, number of recordings, dict model → HFit), at most 4.
    """
    from matplotlib.figure import Figure

    if not 1 <= len(groups) <= 4:
        raise ValueError(f"maneuver_curves_figure draws 1 to 4 maneuvers, got {len(groups)}")
    cols = 1 if len(groups) == 1 else 2
    rows = int(math.ceil(len(groups) / cols))
    fig = Figure(figsize=(6.2 * cols, 4.3 * rows + 1.2), layout="constrained")
    axes = fig.subplots(rows, cols, squeeze=False)
    for ax, (name, count, fits), letter in zip(axes.flat, groups, "abcd"):
        lines = [f"({letter}) {name.replace('_', ' ')}, {count} recording{'s' if count != 1 else ''}"]
        for model, fit in fits.items():
            color, label = _STYLE[model]
            ax.plot(fit.h_grid, fit.rmse_grid, color=color, lw=2)
            ax.plot([fit.h], [fit.rmse], "o", color=color, ms=7, mec="k")
            if np.all(np.isfinite(fit.h_ci95)):
                ax.axvspan(*fit.h_ci95, color=color, alpha=0.25, lw=0)
            lines.append(f"{label}: h = {fit.h:.3f} m, {fit.rmse:.3g} N·m, {verdict_label(fit)}")
        if true_h is not None:
            ax.axvline(true_h, color="k", ls="--", lw=1.2)
        low = min(f.rmse for f in fits.values())
        high = max(float(np.nanmax(f.rmse_grid)) for f in fits.values())
        ax.set_ylim(0.0, min(high, 8.0 * low) * 1.05)
        ax.set_title("\n".join(lines), fontsize=10, loc="left")
        ax.set_xlabel("h [m]", fontsize=11)
        ax.set_ylabel("RMSE($M_{d,1} - M_{d,2}$) [N·m]", fontsize=11)
        ax.tick_params(labelsize=10)
        ax.grid(alpha=0.3)
    for ax in list(axes.flat)[len(groups):]:
        ax.set_visible(False)
    handles = [Line2D([], [], color=c, lw=2, label=lab) for c, lab in _STYLE.values()]
    handles += [Line2D([], [], ls="", marker="o", color="0.5", mec="k", label="minimum: the identified h"),
                Patch(color="0.5", alpha=0.4, label="95% interval of h")]
    if true_h is not None:
        handles.append(Line2D([], [], color="k", ls="--", label=f"true h = {true_h:g} m"))
    fig.legend(handles=handles, loc="outside lower center", ncol=3, fontsize=10)
    fig.suptitle("RMSE between $M_{d,1}$ and $M_{d,2}$ against h, recordings pooled per maneuver "
                 "(cf. the paper's Fig. 8)", fontsize=12)
    return fig


#: Colour and name of each model in the figures.
_STYLE = {"3dof": ("tab:blue", "3 DoF"), "2dof": ("tab:orange", "2 DoF")}


def plain_log_ticks(axis, ticks=None) -> None:
    """Plain-number tick labels (``40``, ``0.5``) on a log axis, at ``ticks`` (default 1, 2, 5 per decade)."""
    axis.set_major_locator(LogLocator(subs=(1.0, 2.0, 5.0)) if ticks is None else FixedLocator(list(ticks)))
    axis.set_major_formatter(FormatStrFormatter("%g"))
    axis.set_minor_formatter(NullFormatter())
    if ticks is not None:
        axis.set_minor_locator(NullLocator())


def rollout_figure(name: str, fit, tool: str = "MuJoCo"):
    """The rollout fit of h (``tool="mujoco.sysid"`` for :mod:`~euc_sim.identification.sysid_fit`): each window's
    rollout over the recorded γ and φ, and the parameter correlations."""
    from matplotlib.figure import Figure

    fig = Figure(figsize=(12, 7.5), layout="constrained")
    gs = fig.add_gridspec(2, 2, width_ratios=[2.2, 1])
    for row, (j, label) in enumerate(((1, "EUC pitch γ [°]"), (2, "rider pitch φ [°]"))):
        ax = fig.add_subplot(gs[row, 0])
        for w in range(fit.windows):
            ax.plot(fit.t[w], np.degrees(fit.q_rec[w, :, j]), ".", ms=1.5, color="0.6",
                    label="recorded" if w == 0 and row == 0 else None)
            ax.plot(fit.t[w], np.degrees(fit.q_fit[w, :, j]), "-", lw=1.2, color=f"C{w % 2}",
                    label="rollout (one window, free initial state)" if w == 0 and row == 0 else None)
        ax.set_ylabel(label)
        ax.grid(alpha=0.3)
        if row == 0:
            ax.set_title(f"{Path(name).name}: {fit.windows} windows, h = {fit.h:.4f} m "
                         f"[{fit.h_ci95[0]:.4f}, {fit.h_ci95[1]:.4f}]"
                         + ("  (ON ITS BOUND)" if fit.at_bound else ""))
        else:
            ax.set_xlabel("t [s]")
    ax = fig.add_subplot(gs[:, 1])
    im = ax.imshow(fit.correlation, vmin=-1, vmax=1, cmap="RdBu_r", interpolation="nearest")
    ax.set_title("parameter correlation\n(h, then x, γ, φ, ẋ, γ̇, φ̇ per window)", fontsize=9)
    ax.set_xlabel("parameter index")
    ax.set_ylabel("parameter index")
    fig.colorbar(im, ax=ax, fraction=0.046, pad=0.04, label="correlation")
    fig.legend(loc="outside lower center", ncol=2, fontsize=8)
    fig.suptitle(f"Rollout fit of h: {tool} over 1 s windows with free initial states")
    return fig

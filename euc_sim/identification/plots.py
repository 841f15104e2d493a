"""Figures of the identification, like the paper's Figs. 6-8 (matplotlib, Agg).

Angles are shown in degrees, torques in N·m, heights in m; everything inside is SI.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from euc_sim.identification.h_fit import MIN_RISE

__all__ = ["plot_recording", "plot_rmse_curves", "plot_rollout", "check_figure_path"]


def _pyplot():
    import matplotlib

    matplotlib.use("Agg", force=True)
    import matplotlib.pyplot as plt

    return plt


def check_figure_path(path) -> Path:
    """Refuse, before any work, a figure name whose extension matplotlib cannot write.

    Raises
    ------
    ValueError
        naming the path, the extension and the supported ones.
    """
    from matplotlib.backend_bases import FigureCanvasBase

    path = Path(path)
    kinds = FigureCanvasBase.get_supported_filetypes()
    suffix = path.suffix.lstrip(".").lower()
    if suffix and suffix not in kinds:
        raise ValueError(f"figure {path}: unknown format {suffix!r}; expected one of "
                         f"{', '.join(sorted(kinds))} (e.g. .png)")
    return path


def _save(fig, path) -> Path:
    from euc_sim.io import atomic_write

    suffix = Path(path).suffix.lstrip(".") or "png"
    out = atomic_write(path, lambda p: fig.savefig(p, dpi=110, format=suffix))
    _pyplot().close(fig)
    return out


def plot_recording(rec, torques_df, fit, path) -> Path:
    """Fig. 6/7 of the paper for one recording.

    Panels (ψ), (ϑ) where recorded, then γ, φ, and M_d,1 against M_d,2 of the
    3-DoF model at the identified h with the RMSE in the title.

    Parameters
    ----------
    rec : euc_sim.identification.h_fit.Recording
    torques_df : DataFrame
        :func:`euc_sim.identification.torques.torques` at the identified h.
    fit : HFit
        The 3-DoF fit of this recording.
    path : path
        Output PNG (written atomically).
    """
    plt = _pyplot()
    kin = rec.kin
    panels = [(k, lab) for k, lab in (("psi", "yaw ψ"), ("theta", "tilt ϑ")) if k in kin.extra]
    panels += [("gamma", "EUC pitch γ"), ("phi", "rider pitch φ"), ("torque", "")]
    fig, axes = plt.subplots(len(panels), 1, figsize=(8, 1.9 * len(panels) + 0.6), sharex=True)
    t = kin.t
    for ax, (key, label), letter in zip(axes, panels, "abcdefg"):
        if key == "torque":
            sl = kin.interior            # edges lack filter support: not drawn, shaded
            ti = t[sl]
            if "M_d" in rec.df.columns:      # through the same term filter as the estimates
                from euc_sim.identification.processing import term_filter

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
            ax.legend(loc="best", fontsize=8)
        else:
            y = kin.extra[key] if key in kin.extra else kin.q[:, 1 if key == "gamma" else 2]
            ax.plot(t, np.degrees(y), color="k", lw=1.0)
            ax.set_ylabel(f"{label.split()[-1]} [°]")
            ax.set_title(f"({letter}) {label}", fontsize=9)
        ax.grid(alpha=0.3)
    axes[-1].set_xlabel("time t [s]")
    fig.suptitle(f"{Path(rec.name).name}: processed data (cf. the paper's Figs. 6-7); "
                 f"smoothing {kin.smoothing.method}", fontsize=10)
    fig.tight_layout()
    return _save(fig, path)


def plot_rmse_curves(names, per_recording, pooled, path) -> Path:
    """Fig. 8 of the paper: RMSE(M_d,1 − M_d,2) against h, 3-DoF and 2-DoF.

    One panel per recording plus a pooled panel (when more than one), each with
    both models' curves, their minima and 95 % intervals.

    Parameters
    ----------
    names : list of str
    per_recording : list of dict of model → HFit
    pooled : dict of model → HFit
    path : path
    """
    plt = _pyplot()
    items = list(zip([Path(n).name for n in names], per_recording))
    if len(items) > 1:
        items.append(("pooled", pooled))
    n = len(items)
    cols = min(n, 4)
    rows = int(math.ceil(n / cols))
    # at least 2 panels wide, so that one recording's title and legend are not clipped
    fig, axes = plt.subplots(rows, cols, figsize=(max(4.2 * cols, 8.4), 3.4 * rows + 0.6),
                             squeeze=False)
    style = {"3dof": ("tab:blue", "3 DoF"), "2dof": ("tab:orange", "2 DoF (reduced)")}
    for ax, (title, fits), letter in zip(axes.flat, items, "abcdefghijklmnopqrstuvwxyz" * 3):
        for model, fit in fits.items():
            color, label = style[model]
            ax.plot(fit.h_grid, fit.rmse_grid, color=color,
                    label=f"{label}: h = {fit.h:.3f} m, {fit.rmse:.3g} N·m, rise "
                    f"{100 * fit.flatness:.0f}%" + ("" if fit.identifiable else " (not identifiable)"))
            ax.plot([fit.h], [fit.rmse], "o", color=color)
            if np.all(np.isfinite(fit.h_ci95)):
                ax.axvspan(*fit.h_ci95, color=color, alpha=0.15)
        ax.set_title(f"({letter}) {title}", fontsize=9)
        ax.set_xlabel("h [m]")
        ax.set_ylabel("RMSE($M_{d,1} - M_{d,2}$) [N·m]")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7, loc="upper center")
    for ax in list(axes.flat)[n:]:
        ax.set_visible(False)
    fig.suptitle("RMSE between $M_{d,1}$ and $M_{d,2}$ against h (cf. the paper's Fig. 8)\n"
                 "shaded: 95% bootstrap interval; rise: RMSE increase within ±0.1 m of the minimum, "
                 f"identifiable from {100 * MIN_RISE:.0f}%", fontsize=10)
    fig.tight_layout()
    return _save(fig, path)


def plot_rollout(name: str, fit, path) -> Path:
    """The rollout fit of h (:mod:`euc_sim.identification.rollout_fit`): each window's
    rollout over the recorded γ and φ, and the parameter correlation matrix."""
    plt = _pyplot()
    fig = plt.figure(figsize=(12, 7.5))
    gs = fig.add_gridspec(2, 2, width_ratios=[2.2, 1])
    for row, (j, label) in enumerate(((1, "EUC pitch γ [°]"), (2, "rider pitch φ [°]"))):
        ax = fig.add_subplot(gs[row, 0])
        for w in range(fit.windows):
            ax.plot(fit.t[w], np.degrees(fit.q_rec[w, :, j]), ".", ms=1.5, color="0.6",
                    label="recorded" if w == 0 else None)
            ax.plot(fit.t[w], np.degrees(fit.q_fit[w, :, j]), "-", lw=1.2, color=f"C{w % 2}",
                    label="rollout (one window, free initial state)" if w == 0 else None)
        ax.set_ylabel(label)
        ax.grid(alpha=0.3)
        if row == 0:
            ax.set_title(f"{Path(name).name}: {fit.windows} windows, h = {fit.h:.4f} m "
                         f"[{fit.h_ci95[0]:.4f}, {fit.h_ci95[1]:.4f}]"
                         + ("  (ON ITS BOUND)" if fit.at_bound else ""))
            ax.legend(loc="upper right", fontsize=8)
        else:
            ax.set_xlabel("t [s]")
    ax = fig.add_subplot(gs[:, 1])
    im = ax.imshow(fit.correlation, vmin=-1, vmax=1, cmap="RdBu_r", interpolation="nearest")
    ax.set_title("parameter correlation\n(h, then x, γ, φ, ẋ, γ̇, φ̇ per window)", fontsize=9)
    ax.set_xlabel("parameter index")
    ax.set_ylabel("parameter index")
    fig.colorbar(im, ax=ax, fraction=0.046, pad=0.04, label="correlation")
    fig.tight_layout()
    return _save(fig, path)

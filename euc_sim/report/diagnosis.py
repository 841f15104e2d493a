"""The diagnosis as a person reads it: a terminal summary and a page with figures.

:func:`summary` gives the terminal lines; :func:`write_report` writes ``DIR/index.html``,
``DIR/index.md`` and the PNG figures of :data:`FIGURES` (each a pure function of the
result returning a matplotlib Figure, None when it does not apply).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from euc_sim.report.diagnosis_html import diagnosis_html
from euc_sim.io import atomic_write, figure_png, write_text
from euc_sim.report.html import write_page
from euc_sim.simulation.effects import CATALOG

__all__ = ["summary", "write_report", "report_paths", "resimulation_change_text", "FIGURES",
           "residual_figure", "terms_figure", "before_after_figure", "resimulation_figure", "drift_figure"]


def _fmt_effect(e: dict) -> str:
    unit = "" if e["unit"] in ("1", "") else f" {e['unit']}"
    lo, hi = e["ci95"]
    txt = f"{e['name']} = {e['estimate']:.4g}{unit} (95% CI {lo:.4g}…{hi:.4g})"
    if e.get("aliases"):
        txt += f"; cannot be told apart here from {', '.join(e['aliases'])}"
    for a, v in e.get("alias_estimates", {}).items():     # the same identified term in the alias's unit
        u = "" if v["unit"] in ("1", "") else f" {v['unit']}"
        txt += f" (as {a}: {v['estimate']:.4g}{u}, 95% CI {v['ci95'][0]:.4g}…{v['ci95'][1]:.4g})"
    return txt


def summary(result: dict) -> str:
    """A few terminal lines (no trailing newline) on a result of :func:`euc_sim.diagnosis.pipeline.diagnose`."""
    r = result
    found = bool(r["effects"])
    lines = [f"{r['recording']}: {r['verdict']}"]
    bound = set(r.get("at_bound", []))
    mark = {k: " (AT THE SEARCH BOUND)" if k in bound else "" for k in ("h_nominal", "h_augmented")}
    rmse = f"  residual {r['residual']}; held-out RMSE {r['nominal_rmse']:.3f} N·m nominal"
    if found:
        rmse += f" -> {r['augmented_rmse']:.3f} N·m with the accepted effects"
        h = (f"  h = {r['h_nominal']:.3f} m nominal{mark['h_nominal']}, {r['h_augmented']:.3f} m "
             f"with the effects{mark['h_augmented']}")
    else:
        h = f"  h = {r['h_nominal']:.3f} m{mark['h_nominal']}"
    lines += [rmse + f" (noise floor {r['noise_floor']:.3f} N·m; held-out RMSE over the noise floor "
              f"{r['heldout_over_floor']:.1f}×)", h]
    for e in r["effects"]:
        at = " (AT ITS SEARCH BOUND)" if f"effects.{e['name']}" in bound else ""
        lines.append("  found: " + _fmt_effect(e) + at)
    if r["unexplained"]:
        lines.append(f"  UNEXPLAINED: structure is left that no catalogued effect explains (a generic periodic term "
                     f"gains {100 * r['generic']['gain']:.0f}% held-out; {_floor_ratio_text(r)})")
    if found or r["unexplained"]:
        lines += _where(r)
    lines += _calibration_lines(r)
    for n, why in r.get("cannot_see", {}).items():
        lines.append(f"  cannot see: {n}: {why}")
    for n in r["notes"]:
        lines.append(f"  note: {n}")
    rs = r.get("resimulation")
    if rs and rs.get("done") and "rmse_phi" in rs.get("nominal", {}):
        txt = f"  re-simulated lean φ vs recording: RMSE {np.degrees(rs['nominal']['rmse_phi']):.2f}° nominal"
        if found and "rmse_phi" in rs.get("augmented", {}):
            txt += f", {np.degrees(rs['augmented']['rmse_phi']):.2f}° augmented"
        lines.append(txt)
    return "\n".join(lines)


def _calibration_lines(r: dict) -> list[str]:
    """The lateral term's calibration on a simulated twin (``lateral_calibration``), in a line or two."""
    lc = r.get("lateral_calibration")
    if not lc:
        return []
    if not lc["done"]:
        return [f"  note: lateral_dynamics not calibrated on a simulated twin: {lc['reason']}"]
    item = next((e for e in r["effects"] + r["tentative"] if e["name"] == "lateral_dynamics"), None)
    plan = lc["plan"]
    where = f"{plan['path']} at {plan['speed']:.2f} m/s" + (f", radius {plan['radius']:.2f} m" if plan["radius"] else "")
    out = [f"  calibrated: lateral_dynamics on a simulated twin of the ride ({where}, from the {plan['from']}): "
           f"the twin reads {lc['twin_estimate']:.4g} rad of its {lc['twin_truth']:.4g} rad"]
    if item and "calibration" in item:
        c = item["calibration"]
        out[0] += (f"; uncalibrated {c['uncalibrated_estimate']:.4g} rad (95% CI {c['uncalibrated_ci95'][0]:.4g}…"
                   f"{c['uncalibrated_ci95'][1]:.4g})")
    noisy = lc.get("rider_noise") or {}
    if noisy.get("floor") is not None:
        out.append(f"  the unexplained test's floor {lc['unexplained_floor']:.3g} N·m holds what the term leaves on "
                   f"{len(noisy['heldout'])} twins whose rider carries the motor noise read from M_h "
                   f"({noisy['level']:.2f} N·m)")
    return out


def _floor_ratio_text(r: dict) -> str:
    """The ``unexplained`` test's held-out RMSE over its noise floor, named (it counts the tentative effects too)."""
    whose = ("with every selected effect, the tentative ones too" if r.get("tentative")
             else "with the accepted effects")
    lc = r.get("lateral_calibration") or {}
    noisy = lc.get("rider_noise") or {}
    floor = ("the noise floor" if not lc.get("done") else
             "the noise floor and the lateral term's remainder on its simulated twin"
             + (f" (its rider's motor noise {noisy['level']:.2f} N·m, read from M_h)" if noisy.get("floor") else ""))
    return f"held-out RMSE over {floor} {r['generic']['floor_ratio']:.1f}× {whose}"


def _where(r: dict) -> list[str]:
    """Where the mismatch is and what it moves with (only said when there is one)."""
    lines = []
    if r["windows"]:
        w = ", ".join(f"{a:.1f}–{b:.1f}" for a, b in r["windows"][:6])
        lines.append(f"  mismatch concentrates in t = {w} s ({r.get('localised_on', 'M_d,1 - M_d,2')})")
    else:
        lines.append("  the mismatch is spread over the whole recording (no window concentrates it)")
    if r.get("correlations"):
        c = max(r["correlations"].items(), key=lambda kv: abs(kv[1]))
        lines.append(f"  nominal residual correlates most with {c[0]} (r = {c[1]:+.2f})")
    return lines


def _figure(figsize):
    """A new Figure (not registered with pyplot) laid out by constrained layout."""
    from matplotlib.figure import Figure

    return Figure(figsize=figsize, layout="constrained")


def _legend_right(ax, **kw) -> None:
    """The panel's legend outside its right edge: it never covers the data."""
    ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=8, borderaxespad=0.0, **kw)


def residual_figure(result: dict):
    """``residual.png``: the residual over time, nominal and with the accepted effects."""
    s = result["_series"]
    has_w = s.get("wheel_nominal") is not None
    fig = _figure((12, 6.5 if has_w else 4))
    axes = fig.subplots(2 if has_w else 1, 1, sharex=True, squeeze=False)
    ax = axes[1, 0] if has_w and "wheel" in result.get("localised_on", "") else axes[0, 0]
    for a, b in result["windows"]:
        ax.axvspan(a, b, color="tab:orange", alpha=0.18, lw=0)
    if result["windows"]:
        ax.plot([], [], color="tab:orange", alpha=0.4, lw=6, label="windows where the\nmismatch concentrates")
    ax = axes[0, 0]
    rows = " (both rows)" if has_w else ""
    ax.plot(s["t"], s["residual_nominal"], color="tab:red", lw=1.2,
            label=f"nominal\n(held-out RMSE{rows} {result['nominal_rmse']:.3f} N·m)")
    names = ", ".join(e["name"] for e in result["effects"]) or "none accepted"
    ax.plot(s["t"], s["residual_augmented"], color="tab:blue", lw=1.2,
            label=f"with {names}\n(held-out RMSE{rows} {result['augmented_rmse']:.3f} N·m)")
    ax.axhline(0.0, color="k", lw=0.6)
    ax.fill_between(s["t"], -result["noise_floor"], result["noise_floor"], color="0.8", alpha=0.5,
                    label=f"± noise floor ({result['noise_floor']:.3f} N·m)")
    ax.set_ylabel("M_d,1 − M_d,2 (N·m)")
    ax.set_title(f"{result['recording']}: kinematic residual (moment balance about the contact point P)")
    _legend_right(ax)
    if has_w:
        ax = axes[1, 0]
        ax.plot(s["t"], s["wheel_nominal"], color="tab:red", lw=1.2, label="nominal")
        ax.plot(s["t"], s["wheel_augmented"], color="tab:blue", lw=1.2, label=f"with {names}")
        ax.axhline(0.0, color="k", lw=0.6)
        ax.set_ylabel("M_d,1 − M_d recorded (N·m)")
        ax.set_title("wheel row (M_d recorded): sees internal torques such as bearing friction")
        _legend_right(ax)
    axes[-1, 0].set_xlabel("time t (s)")
    return fig


def terms_figure(result: dict):
    """``terms.png``: the residual against each candidate term fitted alone (jointly with h, h in each title)."""
    from matplotlib.lines import Line2D

    s = result["_series"]
    fits = s["single_fits"]
    names = list(fits)
    cols = 2
    rows = int(np.ceil(len(names) / cols))
    fig = _figure((11, 2.5 * rows + 1.4))
    axes = fig.subplots(rows, cols, squeeze=False, sharex=True)
    accepted = {e["name"] for e in result["effects"]}
    trials = {d["name"]: d for d in (result["history"][1]["trials"] if len(result["history"]) > 1 else [])}
    wheel = "wheel" in result.get("localised_on", "")
    for i, name in enumerate(names):
        ax = axes[i // cols, i % cols]
        y, term, h, y_w, term_w = fits[name]
        if wheel:
            y, term = y_w, term_w
        ax.plot(s["t"], y, color="0.55", lw=1.0)
        ax.plot(s["t"], term, color="tab:green" if name in accepted else "tab:purple", lw=1.2)
        cv = trials.get(name, {}).get("cv_rmse")
        extra = f"; held-out RMSE {cv:.3f} N·m" if cv is not None else ""
        ax.set_title(f"{name}{' (accepted)' if name in accepted else ''}: h = {h:.2f} m{extra}", fontsize=9)
        ax.set_ylabel("torque (N·m)", fontsize=8)
    for j in range(len(names), rows * cols):
        axes[j // cols, j % cols].axis("off")
    for j, ax in enumerate(axes[-1]):
        if rows * cols - cols + j < len(names):
            ax.set_xlabel("time t (s)")
        elif rows > 1:
            axes[-2, j].set_xlabel("time t (s)")
            axes[-2, j].xaxis.set_tick_params(labelbottom=True)
    row = "wheel row M_d,1 − M_d" if wheel else "residual M_d,1 − M_d,2"
    fig.legend(handles=[Line2D([], [], color="0.55", label="residual at the h fitted with this term (h in the title)"),
                        Line2D([], [], color="tab:purple", label="best fit of this term alone"),
                        Line2D([], [], color="tab:green", label="best fit of this term alone (accepted)")],
               loc="outside lower center", ncol=3, fontsize=8)
    fig.suptitle(f"{row} against each candidate term (nominal held-out RMSE {result['nominal_rmse']:.3f} N·m)\n"
                 f"each term is fitted alone jointly with h, so each panel's residual is at its own h "
                 f"(nominal h = {result['h_nominal']:.2f} m)", fontsize=10)
    return fig


def before_after_figure(result: dict):
    """``before_after.png``: held-out residual RMSE before and after each accepted effect (log axis)."""
    from euc_sim.identification.plots import plain_log_ticks  # deferred: loads matplotlib, pandas (0.6 s)

    floor = result["noise_floor"]
    labels, values = ["nominal"], [result["nominal_rmse"]]
    for e in result["effects"]:
        labels.append("+ " + e["name"])
        values.append(e["rmse_after"])
    fig = _figure((8.5, 4.2))
    ax = fig.add_subplot()
    x = np.arange(len(values))
    ax.bar(x[:1], values[:1], color="tab:red", label="nominal model")
    if len(values) > 1:
        ax.bar(x[1:], values[1:], color="tab:blue", label="with the accepted effects, added in turn")
    for xi, v in zip(x, values):
        ax.annotate(f"{v:.3f} N·m\n({v / floor:.2f}× floor)" if floor > 0 else f"{v:.3f} N·m",
                    (xi, v), xytext=(0, 3), textcoords="offset points", ha="center", va="bottom", fontsize=8)
    ax.axhline(floor, color="k", ls="--", lw=1, label=f"noise floor ({floor:.3f} N·m)")
    ax.set_yscale("log")
    lo = min(min(values), floor) / 2.0
    ax.set_ylim(lo, max(max(values), floor) * 4.0)
    plain_log_ticks(ax.yaxis)
    ax.set_xticks(x, labels, rotation=15, fontsize=8)
    ax.set_xlim(-0.6, len(values) - 0.4)
    ax.set_xlabel("model")
    ax.set_ylabel("held-out RMSE of M_d,1 − M_d,2 (N·m, log)")
    ax.set_title("held-out residual before and after adding the accepted effects" if result["effects"]
                 else "held-out residual of the nominal model (no effect accepted)")
    _legend_right(ax)
    return fig


def resimulation_figure(result: dict):
    """``resimulation.png``: the recording against the nominal and augmented simulation (None without one)."""
    s = (result.get("_series") or {}).get("resimulation")
    if not s or "nominal_phi" not in s:
        return None
    fig = _figure((12, 8.5))
    axes = fig.subplots(3, 1, sharex=True)
    names = ", ".join(e["name"] for e in result["effects"]) or "no effect"
    ax = axes[2]
    for label, color, ls in (("nominal", "tab:red", "-"), ("augmented", "tab:blue", "--")):
        if f"{label}_phi" in s:
            d = np.degrees(s["recording_phi"] - s[f"{label}_phi"])
            ax.plot(s["t"], d, color=color, ls=ls, lw=1.0,
                    label=f"recording − {label}\nsimulation (RMS {np.sqrt(np.mean(d ** 2)):.2f}°)")
    ax.axhline(0.0, color="k", lw=0.6)
    ax.set_ylabel("lean difference (deg)")
    _legend_right(ax)
    for ax, key, unit, conv in ((axes[0], "phi", "rider lean φ (deg)", np.degrees),
                                (axes[1], "speed", "speed ẋ (m/s)", lambda v: v)):
        ax.plot(s["t"], conv(s[f"recording_{key}"]), color="k", lw=1.4, label="recording (filtered)")
        ax.plot(s["t"], conv(s[f"nominal_{key}"]), color="tab:red", lw=1.0, label="nominal simulation")
        if f"augmented_{key}" in s:
            ax.plot(s["t"], conv(s[f"augmented_{key}"]), color="tab:blue", lw=1.0, ls="--",
                    label=f"augmented simulation\n({names})")
        ax.set_ylabel(unit)
        _legend_right(ax)
    fig.suptitle(f"{result['recording']}: recording against the nominal and the augmented closed-loop "
                 "simulation")
    axes[2].set_xlabel("time t (s)")
    return fig


def drift_figure(result: dict):
    """``drift.png``: h(t) of a named cog_height_drift with its 95 % band (None without one)."""
    item = next((e for e in result["effects"] if e["name"] == "cog_height_drift" and "h_of_t" in e), None)
    if item is None:
        return None
    ht = item["h_of_t"]
    t, h, w = (np.asarray(ht[k], float) for k in ("t", "h", "ci95_halfwidth"))
    fig = _figure((11, 3.8))
    ax = fig.add_subplot()
    for a, b in item.get("windows", []):
        ax.axvspan(a, b, color="tab:orange", alpha=0.18, lw=0)
    ax.fill_between(t, h - w, h + w, color="tab:blue", alpha=0.25, label="95 % band")
    ax.plot(t, h, color="tab:blue", lw=1.5,
            label=f"h(t) identified ({item['shape']['kind']};\npeak to peak {item['estimate']:.3f} m)")
    ax.axhline(result["h_nominal"], color="tab:red", ls="--", lw=1,
               label=f"constant h of the nominal\nmodel ({result['h_nominal']:.3f} m)")
    if item.get("windows"):
        ax.plot([], [], color="tab:orange", alpha=0.4, lw=6, label="where h changes")
    ax.set_xlabel("time t (s)")
    ax.set_ylabel("rider's CoG height h (m)")
    ax.set_title(f"{result['recording']}: the rider's centre of gravity over the ride")
    _legend_right(ax)
    return fig


#: The report's figures: file name -> (builder, dpi).
FIGURES = {"residual.png": (residual_figure, 110), "terms.png": (terms_figure, 100),
           "before_after.png": (before_after_figure, 110), "resimulation.png": (resimulation_figure, 110),
           "drift.png": (drift_figure, 110)}


def write_report(result: dict, outdir: str | Path) -> Path:
    """Write ``outdir/index.html``, ``outdir/index.md`` and the figures, each file atomically, the pages last.

    Parameters
    ----------
    result : dict
        From :func:`euc_sim.diagnosis.pipeline.diagnose` (with its ``_series``).
    outdir : path
        Created when missing.

    Returns
    -------
    pathlib.Path
        The Markdown page.

    Raises
    ------
    ValueError
        when ``result`` has no ``_series`` (it was read back from JSON).
    """
    if "_series" not in result:
        raise ValueError("result: expected the dict returned by diagnose() (with '_series'), "
                         "got one without its arrays")
    out = Path(outdir)
    figures = {}
    for name, (build, dpi) in FIGURES.items():
        fig = build(result)
        figures[name] = None if fig is None else figure_png(fig, dpi)
    page = _markdown(result, has_resim=figures["resimulation.png"] is not None)

    html = diagnosis_html(result, page)
    for name, png in figures.items():
        if png is not None:
            atomic_write(out / name, lambda path, data=png: path.write_bytes(data))
    md = write_text(out / "index.md", page)
    write_page(out, html)
    return md


def report_paths(outdir: str | Path) -> list[Path]:
    """The files :func:`write_report` writes into ``outdir`` (to check them before any work)."""
    return [Path(outdir) / n for n in ("index.html", "index.md", *FIGURES)]


def _markdown(result: dict, has_resim: bool) -> str:
    """The report page (Markdown)."""
    r = result
    md = [f"# Diagnosis of `{r['recording']}`", "",
          f"**Verdict: {r['verdict']}.**", ""]
    if r["effects"]:
        md += ["## What was missing", "",
               "| effect | estimate | unit | 95% interval | held-out RMSE after (N·m) | cannot be told apart from |",
               "| --- | --- | --- | --- | --- | --- |"]
        for e in r["effects"]:
            md.append(f"| `{e['name']}` | {e['estimate']:.4g} | {e['unit']} | {e['ci95'][0]:.4g} … "
                      f"{e['ci95'][1]:.4g} | {e['rmse_after']:.3f} | {', '.join(e['aliases']) or '—'} |")
        md.append("")
        md += [f"- {e['evidence']}" for e in r["effects"]]
        md.append("")
        if any(e["name"] == "cog_height_drift" and "h_of_t" in e for e in r["effects"]):
            md += ["The rider's centre of gravity over the ride: h(t) of the shape that fits best "
                   "(ramps and dips of every start and length, the 12 s sine, a slow wander), with its "
                   "95 % band; shaded where h changes.", "", "![h over time](drift.png)", ""]
    if r["unexplained"] or r.get("tentative"):
        g = r["generic"]
        md += ["## What no catalogued effect explains", ""]
        if r["unexplained"]:
            md.append(f"Structure is left after the catalogued effects: a generic periodic term (the best "
                      f"sinusoid between 0.1 and 3 Hz, fitted on the training blocks only) cuts the "
                      f"held-out RMSE by {100 * g['gain']:.0f}% ({g['heldout_without']:.3f} → "
                      f"{g['heldout_with']:.3f} N·m); {_floor_ratio_text(r)}.  No catalogued "
                      "name is given to it: a wrong name is worse than none.")
        if r.get("tentative"):
            md.append("")
            md.append("Accepted by the selection but not named (each explained less than half of the "
                      "mismatch while structure is left, or the recording cannot decide): " +
                      ", ".join(f"`{e['name']}` ({e['estimate']:.3g} {e['unit']})" for e in r["tentative"]) + ".")
        md.append("")
    md += ["## How much better the model became", "",
           f"Held-out residual RMSE (blocked in time, h re-identified in every fold): "
           f"**{r['nominal_rmse']:.3f} N·m** with the nominal model, **{r['augmented_rmse']:.3f} N·m** "
           f"with the accepted effects; the recording's own sensor noise alone gives "
           f"{r['noise_floor']:.3f} N·m. h: {r['h_nominal']:.3f} m nominal, {r['h_augmented']:.3f} m "
           f"re-identified with the effects.", "",
           "![before and after](before_after.png)", "",
           "## Where the mismatch is", "",
           "![residual over time](residual.png)", ""]
    if r["windows"]:
        md.append("Windows (s): " + ", ".join(f"{a:.1f}–{b:.1f}" for a, b in r["windows"]) +
                  f" ({100 * r['window_share']:.0f}% of the energy of {r['localised_on']}).")
        md.append("")
    if r["correlations"]:
        md.append(f"Correlation of the nominal residual ({r['localised_on']}) with: " +
                  ", ".join(f"{k} {v:+.2f}" for k, v in r["correlations"].items()) + ".")
        md.append("")
    md += ["## Residual against each candidate term", "",
           "Each term is the physics of one catalog effect (its generalised force by virtual "
           "power, as moment about the contact point P), or the residual's sensitivity to a "
           "parameter or a time offset.", "", "![terms](terms.png)", ""]
    if has_resim:
        md += _resim_section(r)
    md += _limits_section(r)
    md += ["## Selection history", "",
           "| step | best candidate | accepted | reason |", "| --- | --- | --- | --- |"]
    for st in r["history"]:
        md.append(f"| {st['step']} | {st['chosen'] or '(h only)'} | {'yes' if st['accepted'] else 'no'} | "
                  f"{_cell(st['reason'])} |")
    md.append("")
    return "\n".join(md)


def _cell(text: str) -> str:
    """Text for a Markdown table cell: its pipes escaped (|θ|/se stays |θ|/se)."""
    return str(text).replace("|", "\\|")


def _baseline(name: str) -> str | None:
    """The parameter whose nominal value is ``name``'s "absent" value (its record's ``baseline``)."""
    return CATALOG[name].baseline if name in CATALOG else None


def _range(name: str, lo, hi, unit: str, nominal: dict) -> str:
    u = " (dimensionless)" if unit in ("1", "") else f" {unit}"
    if _baseline(name):
        return f"a change of {lo:g} to {hi:g}{u} from the nominal {nominal.get(_baseline(name)):g}{u}"
    return f"{lo:g} to {hi:g}{u}"


def _limits_section(r: dict) -> list[str]:
    """What the recording can and cannot reveal: visibility, detection limit, plausible range."""
    md = ["## What this recording can and cannot reveal", "",
          "An effect is named when its term stands at least "
          f"{r['thresholds']['min_t']:g} standard errors from zero; *detectable above* is the smallest "
          "value that would, on this recording.", "",
          "| effect | visible | detectable above | plausible range | status |",
          "| --- | --- | --- | --- | --- |"]
    for name, lim in r["limits"].items():
        vis = r["visibility"][name]
        unit = "" if lim["unit"] in ("1", "") else f" {lim['unit']}"
        if lim["detectable_above"] is None:
            da = "—"
        else:
            da = f"{lim['detectable_above']:.3g}{unit}" + (" (change)" if _baseline(name) else "")
        md.append(f"| `{name}` | {'yes via ' + vis['through'] if vis['visible'] else 'no'} | {da} | "
                  f"{_range(name, *lim['plausible'], lim['unit'], r.get('nominal_params', {}))} | {_cell(lim['status'])} |")
    md.append("")
    return md


#: Changes of the re-simulated lean's RMSE, %, worded "hardly any" below and "large" (a fall) above.
RESIM_SMALL_CHANGE, RESIM_LARGE_FALL = 5.0, 25.0


def resimulation_change_text(change: float) -> str:
    """The report's paragraph on how the lean's re-simulated RMSE changed.

    Parameters
    ----------
    change : float
        Relative change of the RMSE of φ, augmented against nominal, % (negative: closer).

    Returns
    -------
    str
    """
    check = ("This is a check that the augmented model, run forward in closed loop, reproduces the "
             "ride at least as well as the nominal one, not the test of the effect (that is the "
             "held-out residual above).")
    why_small = ("the simulated rider and motor controllers compensate a missing force or moment (the "
                 "rider leans a little further to hold his speed), so the effect changes the motion only "
                 "by that compensation; and most of the difference left is the recorded rider's own "
                 "random balance corrections and the sensor noise, which no simulation reproduces sample "
                 "by sample.")
    if change > RESIM_SMALL_CHANGE:
        return (f"The lean's RMSE rises by {change:.0f} % with the effects: the augmented model reproduces "
                f"the ride worse than the nominal one, so the named effect, or its estimate, does not "
                f"describe the ride.  {check}")
    if change >= -RESIM_SMALL_CHANGE:
        return (f"The lean's RMSE hardly changes with the effects ({change:+.0f} %).  {check}  A small "
                f"change is expected: {why_small}")
    if change > -RESIM_LARGE_FALL:
        return (f"The lean's RMSE falls by {-change:.0f} % with the effects.  {check}  The fall is modest, "
                f"as expected: {why_small}")
    return (f"The lean's RMSE falls by {-change:.0f} % with the effects: re-simulated with the named "
            f"effect, the closed-loop ride follows the recording much more closely, so the effect changes "
            f"the motion, not only the torques.  {check}")


def _resim_section(r: dict) -> list[str]:
    """The re-simulation, with what its (often small) gain means."""
    rs = r["resimulation"]
    md = ["## Re-simulation", "",
          f"The maneuver re-simulated ({rs['engine']} engine, default motor PD and rider controllers; plan: "
          f"{rs['maneuver']}), nominal and with the accepted effects injected as physics.", ""]
    for label in ("nominal", "augmented"):
        v = rs.get(label, {})
        if "rmse_phi" in v:
            md.append(f"- {label}: RMSE against the recording: lean φ {np.degrees(v['rmse_phi']):.2f}°, "
                      f"pitch γ {np.degrees(v['rmse_gamma']):.2f}°, speed {v['rmse_speed']:.3f} m/s")
        elif "error" in v:
            md.append(f"- {label}: {v['error']}")
    nom, aug = rs.get("nominal", {}), rs.get("augmented", {})
    if "rmse_phi" in nom and "rmse_phi" in aug and r["effects"]:
        change = 100.0 * (aug["rmse_phi"] / nom["rmse_phi"] - 1.0) if nom["rmse_phi"] > 0 else 0.0
        md += ["", resimulation_change_text(change)]
    md += ["", "![re-simulation](resimulation.png)", ""]
    return md

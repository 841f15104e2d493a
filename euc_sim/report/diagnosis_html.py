"""The diagnosis as a page: ``DIR/index.html`` through the one template (:mod:`euc_sim.report.html`).

The verdict first, in sentences; then the residual over time with the windows where
the mismatch concentrates and the held-out error before and after (interactive);
the effects found in a table; then, folded, everything the plain-text page
(``index.md``, :func:`euc_sim.report.diagnosis.write_report`) says, its PNG figures
linked.
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import plotly.graph_objects as go

from euc_sim.report import html as H

__all__ = ["diagnosis_html", "figure_specs", "verdict_sentences", "key_figures"]

#: Most points per residual trace on the page.
MOST_POINTS = 8000


def _effect_text(e: dict) -> str:
    unit = "" if e["unit"] in ("1", "") else f" {e['unit']}"
    lo, hi = e["ci95"]
    return f"{e['name'].replace('_', ' ')} = {e['estimate']:.3g}{unit} (95 % interval {lo:.3g} to {hi:.3g})"


def verdict_sentences(r: dict) -> list[str]:
    """The verdict in a few sentences, in words (symbols stay in the folded part)."""
    out = [f"Verdict: {r['verdict']}."]
    if r["effects"]:
        out.append("The model was missing: " + "; ".join(_effect_text(e) for e in r["effects"]) + ".")
    else:
        out.append("No catalogued effect improves the model out of sample.")
    out.append(f"Held out, the model's error fell from {r['nominal_rmse']:.3f} to {r['augmented_rmse']:.3f} N·m"
               if r["effects"] else f"Held out, the model's error is {r['nominal_rmse']:.3f} N·m")
    out[-1] += f"; the recording's own sensor noise alone gives {r['noise_floor']:.3f} N·m."
    if r["unexplained"]:
        out.append("Structure is left that no catalogued effect explains: no name is given to it.")
    if r["windows"]:
        out.append("The mismatch concentrates at " + ", ".join(f"{a:.1f}–{b:.1f} s" for a, b in r["windows"][:6])
                   + (" and later" if len(r["windows"]) > 6 else "") + " (shaded below).")
    return out


def key_figures(r: dict) -> list:
    """The first screen's tiles."""
    K = H.KeyFigure
    ratio = r["augmented_rmse"] / r["noise_floor"] if r["noise_floor"] else float("nan")
    return [K("Verdict", "physics found" if r["effects"] else "nothing named",
              r["verdict"][:70], "warn" if r["unexplained"] else "good" if r["effects"] else ""),
            K("Effects found", str(len(r["effects"])),
              ", ".join(e["name"].replace("_", " ") for e in r["effects"])[:70]),
            K("Held-out error", f"{r['augmented_rmse']:.3f} N·m", f"nominal model {r['nominal_rmse']:.3f} N·m"),
            K("Noise floor", f"{r['noise_floor']:.3f} N·m", f"error / floor {ratio:.1f}×"),
            K("Centre of gravity height", f"{100 * r['h_augmented']:.0f} cm",
              f"nominal fit {100 * r['h_nominal']:.0f} cm")]


def _thin(n: int) -> np.ndarray:
    return np.arange(n) if n <= MOST_POINTS else np.unique(np.linspace(0, n - 1, MOST_POINTS).astype(int))


def residual_figure(r: dict):
    """The residual over time, nominal and with the effects, windows shaded, the noise band."""
    from plotly.subplots import make_subplots

    s = r["_series"]
    has_w = s.get("wheel_nominal") is not None
    rows = 2 if has_w else 1
    fig = make_subplots(rows=rows, cols=1, shared_xaxes=True, vertical_spacing=0.08,
                        subplot_titles=["moment balance about the contact point"]
                        + (["wheel row (sees internal torques such as bearing friction)"] if has_w else []))
    t = np.asarray(s["t"], float)
    k = _thin(t.size)
    names = ", ".join(e["name"].replace("_", " ") for e in r["effects"]) or "no effect accepted"
    pairs = [("residual_nominal", "residual_augmented")] + ([("wheel_nominal", "wheel_augmented")] if has_w else [])
    for row, (a, b) in enumerate(pairs, start=1):
        first = row == 1
        fig.add_trace(go.Scatter(x=t[k], y=np.asarray(s[a])[k], name="nominal model", mode="lines",
                                 line={"color": "#c62828", "width": 1.2}, showlegend=first), row=row, col=1)
        if s.get(b) is not None:
            fig.add_trace(go.Scatter(x=t[k], y=np.asarray(s[b])[k], name=f"with {names}", mode="lines",
                                     line={"color": "#1565c0", "width": 1.2}, showlegend=first), row=row, col=1)
        fig.update_yaxes(title_text="mismatch, N·m", row=row, col=1)
    nf = r["noise_floor"]
    fig.add_hrect(y0=-nf, y1=nf, fillcolor="grey", opacity=0.2, line_width=0, row=1, col=1)
    fig.add_trace(go.Scatter(x=[None], y=[None], mode="lines", name=f"± noise floor ({nf:.3f} N·m)",
                             line={"color": "rgba(128,128,128,0.4)", "width": 8}))
    for a, b in r["windows"]:
        fig.add_vrect(x0=a, x1=b, fillcolor="orange", opacity=0.18, line_width=0)
    if r["windows"]:
        fig.add_trace(go.Scatter(x=[None], y=[None], mode="lines", name="where the mismatch concentrates",
                                 line={"color": "rgba(255,165,0,0.5)", "width": 8}))
    fig.update_xaxes(title_text="time, s", row=rows, col=1)
    fig.update_layout(title={"text": f"{r['recording']}: what the model leaves unexplained over time"},
                      legend={"orientation": "h", "yanchor": "top", "y": -0.12, "x": 0.0},
                      margin={"l": 60, "r": 20, "t": 80, "b": 90}, height=300 * rows + 160)
    return fig


def before_after_figure(r: dict):
    """Held-out error of the nominal model and with the effects, against the noise floor."""
    labels = ["nominal model", "with the effects found", "sensor noise alone"]
    vals = [r["nominal_rmse"], r["augmented_rmse"], r["noise_floor"]]
    fig = go.Figure(go.Bar(x=labels, y=vals, marker_color=["#c62828", "#1565c0", "#9e9e9e"],
                           text=[f"{v:.3f}" for v in vals], textposition="outside", showlegend=False))
    fig.update_layout(title={"text": "Held-out error before and after"}, xaxis={"title": {"text": "model"}, "type": "category"},
                      yaxis_title="held-out RMS error, N·m", margin={"l": 60, "r": 20, "t": 70, "b": 60},
                      yaxis={"range": [0, 1.2 * max(vals)]})
    return fig


def figure_specs(r: dict) -> dict:
    """The page's Plotly figures by element id."""
    return {"residual": residual_figure(r), "before_after": before_after_figure(r)}


def _effects_table(r: dict) -> str:
    if not r["effects"]:
        return H.paragraph("No effect was accepted.")
    rows = [(e["name"].replace("_", " "), f"{e['estimate']:.4g}", e["unit"],
             f"{e['ci95'][0]:.4g} to {e['ci95'][1]:.4g}", f"{e['rmse_after']:.3f}",
             ", ".join(e.get("aliases", [])) or "–") for e in r["effects"]]
    return H.table(["effect", "estimate", "unit", "95 % interval", "held-out error after, N·m",
                    "cannot be told apart from"], rows)


def _folded(markdown_text: str) -> list[str]:
    """The plain-text page, one folded section per heading (its title skipped)."""
    parts = []
    for title, *lines in (chunk.split("\n") for chunk in re.split(r"^## ", markdown_text, flags=re.M)[1:]):
        body = H.markdown([line for line in lines if not line.startswith("# ")])
        parts.append(H.section(title.strip(), f"<div>{body}</div>", folded=True))
    return parts


def diagnosis_html(result: dict, markdown_text: str) -> str:
    """The page (a string) of a diagnosis result (with its ``_series``) and its Markdown page."""
    figs = figure_specs(result)
    n = 2 if result["_series"].get("wheel_nominal") is not None else 1
    body = [H.key_figures(key_figures(result)), H.lead(verdict_sentences(result)),
            H.section("Where the mismatch is", H.figure(figs["residual"], "residual", 300 * n + 160)),
            H.section("What was found", H.columns(_effects_table(result),
                                                  H.figure(figs["before_after"], "before_after", 360))),
            H.section("Details", H.paragraph("The diagnosis step by step; each part opens on a click."))]
    body += _folded(markdown_text)
    return H.page(f"Diagnosis: {Path(result['recording']).name}",
                  "euc-sim diagnose report · plain text in index.md, figures as PNG beside it", body)

"""The page template's pure builders: escaping, Markdown, inline figures."""

from __future__ import annotations

import json
import re

import numpy as np

from euc_sim.report import html as H
from euc_sim.report.figures import Panel, thin, time_panels, with_breaks


def test_markdown_keeps_structure_and_escapes():
    out = H.markdown(["## Verdict", "", "a **b** `c_d` <x>", "more", "- one", "- two", "",
                      "| a | b |", "| --- | --- |", "| 1 \\| 2 | 3 |", "", "![fig](f.png)"])
    assert "<h3>Verdict</h3>" in out and "<p>a <b>b</b> <code>c_d</code> &lt;x&gt; more</p>" in out
    assert "<ul><li>one</li><li>two</li></ul>" in out
    assert "<td>1 | 2</td><td>3</td>" in out and "---" not in out
    assert '<a href="f.png">figure: fig</a>' in out and "<img" not in out      # an image is a fetch


def test_a_figure_cannot_end_its_script():
    frag = H.figure({"data": [{"x": [1], "y": [2], "name": "</script><b>"}], "layout": {}}, "f1")
    body = frag.split("<script>", 1)[1]
    assert body.count("</script>") == 1                                         # only its own end
    spec = re.search(r"var f=(.*);Plotly", body).group(1).replace("<\\/", "</")
    assert json.loads(spec)["data"][0]["name"] == "</script><b>"


def test_key_figures_escape_and_tone():
    out = H.key_figures([H.KeyFigure("Max <PWM>", "91 %", "at 2:30", "bad")])
    assert '<div class="bad"><div class="l">Max &lt;PWM&gt;</div>' in out


def test_lines_break_at_gaps_and_thinning_keeps_the_ends():
    t, y = with_breaks(np.array([0.0, 0.1, 0.2, 5.0, 5.1]), 1.0, np.arange(5.0))
    assert np.isnan(t[3]) and np.isnan(y[3]) and t.size == 6
    k = thin(100_001, 6000)
    assert k[0] == 0 and k[-1] == 100_000 and k.size <= 6000


def test_time_panels_share_one_x_axis():
    t = np.linspace(0, 10, 50)
    fig = time_panels(t, [Panel("Speed", "km/h", t), Panel("PWM", "%", t)], "title", 1.0, (5.0, "mark"))
    lay = fig["layout"]
    assert lay["xaxis"].get("matches") == "x2" or lay["xaxis2"].get("matches") == "x"
    assert lay["yaxis"]["title"]["text"] == "Speed, km/h" and lay["xaxis2"]["title"]["text"].endswith(", min")


def test_plotly_only_where_a_figure_draws():
    """A page without a Plotly figure carries no plotly.js (4.8 MB); one with a figure does."""
    plain = H.page("t", "s", [H.paragraph("no figure; Plotly.newPlot is only text here")])
    drawn = H.page("t", "s", [H.figure({"data": [], "layout": {}}, "f1")])
    assert len(plain) < 50_000 and "Plotly.newPlot(\"f1\"" not in plain
    assert len(drawn) > 1_000_000 and H._plotly_js() in drawn

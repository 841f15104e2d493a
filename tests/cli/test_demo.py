"""`euc-sim demo`, the README's main job, end to end on its embedded defaults."""

import json
import re
import sys
from pathlib import Path

from euc_sim.cli import main

sys.path.append(str(Path(__file__).resolve().parents[1]))
import browser  # noqa: E402


def _opens_in_a_browser(page: Path, tmp_path: Path) -> None:
    """No script error and nothing fetched (without Chromium the test skips here, saying why,
    after every other check has passed)."""
    browser.chromium_or_skip()
    seen = browser.render(page, tmp_path / "demo.png")
    assert seen.script_errors() == [] and seen.foreign_requests(page) == []


def test_demo_writes_its_story_and_finds_the_concealed_effect(tmp_path, capsys):
    out = tmp_path / "demo"
    assert main(["demo", "--out-dir", str(out)]) == 0
    captured = capsys.readouterr()
    index = (out / "index.md").read_text()
    # the outcome in sentences: each model's h against the truth, which one is right and why
    assert re.search(r"the 3-DoF model identified h = 0\.\d{3} m .*the 2-DoF model 0\.\d{3} m", index)
    assert "Which model is right, and why" in index and "m0 h0 − m l0" in index
    assert "see the table" not in index
    assert (out / "identification.png").stat().st_size > 10_000
    assert (out / "identification.svg").read_text().lstrip().startswith("<?xml")
    assert len(list((out / "recordings").glob("*.csv"))) == 14
    truth = json.loads((out / "concealed" / "concealed.truth.json").read_text())
    found = json.loads((out / "concealed" / "diagnosis.json").read_text())
    (name, t), = truth["effects"].items()
    assert found["effects"] and found["effects"][0]["name"] == name
    estimate = found["effects"][0]["estimate"]
    assert abs(estimate - t["value"]) < 0.25 * abs(t["value"])
    assert f"`{name}`" in index
    assert (out / "concealed" / "report" / "index.md").exists()
    # the page through the one template: the story, the figures inline, opened in a browser
    page = (out / "index.html").read_text()
    assert "Which model is right, and why" in page and page.count("data:image/png;base64,") >= 1
    assert 'href="concealed/report/index.html"' in page
    _opens_in_a_browser(out / "index.html", tmp_path)
    # progress as plain lines (stderr is not a terminal here): no cursor escapes, no blank lines
    assert "demo: 1/4" in captured.err
    assert "\r" not in captured.err and "\x1b" not in captured.err
    assert all(line.strip() for line in captured.err.splitlines())
    assert (captured.out + captured.err).count("done") == 1


def test_the_seed_draws_the_concealed_effect_too():
    import numpy as np

    from euc_sim.api.demo import CONCEALABLE, draw_concealed_effect
    drawn = {draw_concealed_effect(np.random.default_rng([s, 5]))[0] for s in range(1, 9)}
    assert drawn == set(CONCEALABLE)
    assert draw_concealed_effect(np.random.default_rng([3, 5])) == \
        draw_concealed_effect(np.random.default_rng([3, 5]))


def test_the_story_renders_sections_tables_and_figures():
    from euc_sim.api.demo import Section, Story

    story = Story("t", ("Opening one.", "Opening two."),
                  (Section("A", ("It went.",), (("x", "y"), ("1", "2")), (("f.png", "a figure"),)),))
    md = story.to_markdown()
    assert md.startswith("# t\n\nOpening one. Opening two.")
    assert "| x | y |\n| --- | --- |\n| 1 | 2 |" in md and "![a figure](f.png)" in md


def test_the_story_as_a_page_inlines_its_figures(tmp_path):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from euc_sim.api.demo import Section, Story

    fig, ax = plt.subplots()
    ax.plot([0, 1], [0, 1])
    fig.savefig(tmp_path / "f.png")
    plt.close(fig)
    story = Story("t", ("Opening one.",),
                  (Section("A", ("See [the report](r/index.html).",), (("x", "y"), ("1", "2")),
                           (("f.png", "a figure"),)),))
    page = story.to_html(tmp_path)
    assert '<a href="r/index.html">the report</a>' in page and "<td>1</td>" in page
    assert "data:image/png;base64," in page and 'src="f.png"' not in page


def test_the_seed_reaches_the_concealed_rides_diagnosis(tmp_path, monkeypatch):
    """``--seed`` holds for every draw of the demo, the diagnosis's noise floor included."""
    import euc_sim.api.demo as demo

    seen = []

    class Stop(Exception):
        pass

    def spy(conc, **kw):
        seen.append(kw.get("seed"))
        raise Stop

    monkeypatch.setattr(demo, "diagnose", spy)
    try:
        demo._conceal_and_diagnose(tmp_path, 5, lambda s: None)
    except Stop:
        pass
    assert seen == [5]

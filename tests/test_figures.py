"""Every PNG the demo and ``euc-sim ride`` write, looked at: legends, labels, titles (issue 19).

The commands run as a user runs them (shorter: 8 s demo recordings, a 2-minute cut
of a real ride), with :meth:`matplotlib.figure.Figure.savefig` watched: every figure
that reaches a file is checked by :func:`figcheck.figure_problems` with matplotlib's
own extents, and the number of checked figures equals the number of PNGs written.
The real rides come from ``../shared/data`` (skipped when it is absent).
"""

from __future__ import annotations

import math
import warnings
from pathlib import Path

import numpy as np
import pytest
from matplotlib.figure import Figure

from euc_sim.cli import main
from figcheck import assert_readable, figure_problems, line_labels

SHARED = Path(__file__).resolve().parents[2] / "shared" / "data"
needs_shared = pytest.mark.skipif(not SHARED.is_dir(), reason=f"{SHARED} absent (user's clone)")


def _watch_savefig(monkeypatch) -> list[Figure]:
    """Every Figure saved from now on (to a file or to bytes), in order."""
    saved: list[Figure] = []
    original = Figure.savefig

    def savefig(self, fname, *args, **kwargs):
        saved.append(self)
        return original(self, fname, *args, **kwargs)

    monkeypatch.setattr(Figure, "savefig", savefig)
    return saved


def _titles(fig) -> str:
    sup = fig._suptitle.get_text() if fig._suptitle is not None else ""
    return " | ".join([sup] + [ax.get_title() or ax.get_title("left") for ax in fig.axes])


# --- the checker itself: it must fail on the defects the issue lists ---------------------
def test_the_checker_sees_a_legend_wider_than_its_panel_and_a_missing_label():
    fig = Figure(figsize=(3, 2))
    ax = fig.add_subplot()
    ax.plot(np.arange(10), np.arange(10), label="a label far wider than this small panel can hold")
    ax.legend(loc="upper center")
    problems = figure_problems(fig)
    assert any("legend" in p for p in problems)
    assert any("no x label" in p for p in problems) and any("no title" in p for p in problems)


def test_the_checker_sees_a_legend_on_the_data_and_scientific_tick_labels():
    fig = Figure(figsize=(6, 4), layout="constrained")
    ax = fig.add_subplot()
    x = np.linspace(1, 100, 400)
    ax.plot(x, x, label="y = x")
    ax.set(xscale="log", yscale="log", xlabel="x [1]", ylabel="y [1]", title="t")
    ax.legend(loc="center")
    problems = figure_problems(fig)
    assert any("covers" in p and "data point" in p for p in problems)
    assert any("not a plain number" in p for p in problems)


def test_the_checker_sees_a_title_wider_than_the_figure():
    fig = Figure(figsize=(3, 2), layout="constrained")
    ax = fig.add_subplot()
    ax.plot([0, 1], [0, 1])
    ax.set(xlabel="x [m]", ylabel="y [m]", title="a title that is far too long for so small a figure")
    assert any("title runs off" in p for p in figure_problems(fig))


def test_the_checker_passes_a_readable_figure():
    fig = Figure(figsize=(7, 3), layout="constrained")
    ax = fig.add_subplot()
    ax.plot([0, 1, 2], [0, 1, 4], label="y = x²")
    ax.set(xlabel="x [m]", ylabel="y [m²]", title="a readable figure")
    ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0))
    assert figure_problems(fig) == []


# --- the demo ---------------------------------------------------------------------------
@pytest.fixture(scope="module")
def demo(tmp_path_factory):
    """``euc-sim demo`` with 8 s recordings: (output folder, the figures it saved)."""
    from euc_sim.simulation import dataset

    mp = pytest.MonkeyPatch()
    try:
        saved = _watch_savefig(mp)
        plan = dataset.dataset_plan
        mp.setattr(dataset, "dataset_plan", lambda seed, duration: plan(seed=seed, duration=8.0))
        out = tmp_path_factory.mktemp("demo")
        assert main(["demo", "--out-dir", str(out)]) == 0
    finally:
        mp.undo()
    return out, saved


def test_every_demo_png_is_readable(demo):
    out, saved = demo
    pngs = sorted(out.rglob("*.png"))
    figures = list({id(f): f for f in saved}.values())      # the identification figure is saved as PNG and SVG
    assert len(figures) == len(pngs) >= 5          # identification + the concealed report's four
    assert (out / "identification.svg").is_file()
    for fig in figures:
        assert_readable(fig)


def test_identification_is_the_papers_fig8_readable_at_full_size(demo):
    """One panel per maneuver (at most 4), both models in each, text of 10 pt or more, and
    each curve's verdict in words: a curve with an interior minimum is never called
    unidentifiable without the rule that decided it."""
    fig = demo[1][0]
    assert "Fig. 8" in _titles(fig)
    panels = [ax for ax in fig.axes if ax.get_visible()]
    assert len(panels) in range(1, 5)
    assert all(ax.get_legend() is None for ax in panels) and len(fig.legends) == 1
    for ax in panels:
        curves = [ln for ln in ax.get_lines() if len(ln.get_ydata()) > 5]
        assert len(curves) == 2
        assert "not ident." not in ax.get_title(loc="left")
        assert ax.get_title(loc="left").count("identifiable") + ax.get_title(loc="left").count("shallow") == 2
    texts = [t for t in fig.findobj(lambda o: hasattr(o, "get_fontsize") and hasattr(o, "get_text"))
             if t.get_text() and t.get_visible()]
    assert texts and min(t.get_fontsize() for t in texts) >= 10


def test_before_after_labels_every_bar_against_the_floor(demo):
    """Item 8: a legend entry per bar colour, a value on every bar, the floor inside the frame."""
    fig = next(f for f in demo[1] if "before and after" in _titles(f))
    ax = fig.axes[0]
    bars = [p for p in ax.patches if p.get_height() > 0]
    values = [t.get_text() for t in ax.texts if "N·m" in t.get_text()]
    assert len(values) == len(bars) >= 2
    labels = line_labels(fig)
    assert any("nominal" in s for s in labels) and any("accepted effects" in s for s in labels)
    assert ax.get_yscale() == "log"
    floor = next(ln.get_ydata()[0] for ln in ax.get_lines() if ln.get_linestyle() == "--")
    assert math.log(ax.get_ylim()[1] / floor) > 0.5          # not on the top frame


def test_before_after_null_case_keeps_the_floor_off_the_frame(demo):
    from euc_sim.diagnosis.pipeline import diagnose
    from euc_sim.report.diagnosis import before_after_figure

    rec = sorted((demo[0] / "recordings").glob("stop_and_go*.csv"))[0]
    with warnings.catch_warnings():           # a short recording's notes are not under test
        warnings.simplefilter("ignore")
        result = diagnose(rec, resimulate=False)
    fig = before_after_figure(result)
    assert_readable(fig)
    ax = fig.axes[0]
    floor = next(ln.get_ydata()[0] for ln in ax.get_lines() if ln.get_linestyle() == "--")
    lo, hi = ax.get_ylim()
    assert math.log(hi / floor) > 0.5 and math.log(floor / lo) > 0.3


def test_drift_figure_is_readable():
    """``drift.png`` (only with cog_height_drift named): h(t), its band, the windows."""
    from euc_sim.report.diagnosis import drift_figure

    t = np.linspace(0.0, 20.0, 400)
    h = 0.6 + 0.05 * np.clip((t - 8.0) / 4.0, 0.0, 1.0)
    item = {"name": "cog_height_drift", "estimate": 0.05, "shape": {"kind": "ramp"}, "windows": [[8.0, 12.0]],
            "h_of_t": {"t": t.tolist(), "h": h.tolist(), "ci95_halfwidth": np.full(t.size, 0.01).tolist()}}
    fig = drift_figure({"effects": [item], "h_nominal": 0.62, "recording": "drift.csv"})
    assert_readable(fig)
    assert drift_figure({"effects": [], "h_nominal": 0.6, "recording": "x.csv"}) is None


def test_terms_says_each_panels_h(demo):
    """Item 9: each panel's residual is at its own h, and its title says which."""
    fig = next(f for f in demo[1] if "candidate term" in _titles(f))
    titled = [ax.get_title() for ax in fig.axes if ax.axison]
    assert titled and all(" h = " in t for t in titled)
    assert "its own h" in fig._suptitle.get_text()


def test_identify_plot_figures_are_readable(demo, tmp_path, monkeypatch):
    """``identify --report DIR``: Fig. 8 and the recording's Figs. 6-7 (``identify-torques.png``)."""
    saved = _watch_savefig(monkeypatch)
    rec = sorted((demo[0] / "recordings").glob("deceleration*.csv"))[0]
    assert main(["identify", str(rec), "--n-boot", "50", "--report", str(tmp_path)]) == 0
    assert len(saved) == len(list(tmp_path.glob("*.png"))) == 2
    for fig in saved:
        assert_readable(fig)


# --- euc-sim design --report ------------------------------------------------------------
def test_design_figures_are_readable(tmp_path, monkeypatch):
    """Item 10: one figure legend (none over the Monte Carlo points), plain tick labels;
    and the effects figure beside it."""
    saved = _watch_savefig(monkeypatch)
    assert main(["design", "--maneuvers", "constant_speed,deceleration", "--rides", "3",
                 "--duration", "8", "--report", str(tmp_path),
                 "--effect", "aerodynamic_drag", "--effect", "wheel_bearing_friction", "--effect-rides", "3",
                 "--quiet"]) == 0
    assert len(saved) == len(list(tmp_path.glob("*.png"))) == 2
    for fig in saved:
        assert_readable(fig)
    design = next(f for f in saved if "Experiment design" in _titles(f))
    assert all(ax.get_legend() is None for ax in design.axes) and len(design.legends) == 1


# --- euc-sim ride on real logs ----------------------------------------------------------
def _ride(argv, monkeypatch) -> tuple[list[Figure], int]:
    saved = _watch_savefig(monkeypatch)
    out = Path(argv[argv.index("--report") + 1])
    assert main([str(a) for a in argv] + ["--quiet"]) == 0
    return saved, len(list(out.glob("*.png")))


def _cut(src: Path, rows: slice, out: Path) -> Path:
    """Rows of a real log (header kept) in a temporary file: a shorter ride, same columns."""
    lines = src.read_text().splitlines()
    out.write_text("\n".join(lines[:1] + lines[rows]) + "\n")
    return out


@needs_shared
def test_ride_figures_on_two_real_rides_with_the_simulation(tmp_path, monkeypatch):
    """The README's ``ride LOG --compare OTHER --simulate`` on 2-minute cuts of two real WheelLog
    rides: the simulation (item 12: a zoom and the error over time; the fits' figures are the
    page's Plotly figures, tests/report/test_pages.py)."""
    from euc_sim.report.ride.simulation_figure import ZOOM_S

    wl = SHARED / "wheellog"
    fit = _cut(wl / "2020_05_16_08_02_06.csv", slice(1, 600), tmp_path / "a.csv")
    test = _cut(wl / "2020_05_28_07_52_00.csv", slice(170, 770), tmp_path / "b.csv")
    saved, written = _ride(["ride", fit, "--compare", test, "--report", tmp_path / "rep", "--n-boot", "20",
                            "--simulate"], monkeypatch)
    assert len(saved) == written == 1
    for fig in saved:
        assert_readable(fig)
    sim, = [f for f in saved if "Simulated rider" in _titles(f)]
    spans = [ax.get_xlim()[1] - ax.get_xlim()[0] for ax in sim.axes]
    assert min(spans) == pytest.approx(ZOOM_S) and max(spans) > 1.5 * ZOOM_S   # a zoom, the whole ride
    assert any("moving RMS" in ax.get_ylabel() for ax in sim.axes)


@needs_shared
def test_ride_figures_with_the_drivetrain(tmp_path, monkeypatch):
    """A real ride with PWM and GPS altitude, split in halves: envelope (item 11), grade; the
    balance's Plotly figure labels the whole ride as such (item 13)."""
    from euc_sim.rides.grids.power import G
    from euc_sim.report.ride.drivetrain_page import TYRE_MU

    core = SHARED / "euc_core"
    saved, written = _ride(["ride", core / "trips/inmotion/v9/2/2.csv", "--wheel", core / "specs/v9.csv",
                            "--report", tmp_path / "rep", "--no-simulate", "--n-boot", "10"], monkeypatch)
    assert len(saved) == written == 2
    for fig in saved:
        assert_readable(fig)
    env, = [f for f in saved if "envelope" in _titles(f).lower()]
    ax = env.axes[0]
    drawn = np.concatenate([np.asarray(ln.get_ydata(), float) for ln in ax.get_lines()])
    assert np.nanmax(drawn) <= TYRE_MU * G + 1e-9
    assert ax.get_ylim()[1] < 1.2 * TYRE_MU * G
    assert "current limit" in _titles(env)
    page = (tmp_path / "rep" / "index.html").read_text()
    assert "first half) (fit)" not in page and "the whole ride" in page and "second half: held out" in page

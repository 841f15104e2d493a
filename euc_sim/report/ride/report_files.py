"""The report folder of a ride: figures, tables, ``index.md`` and ``index.html``.

:func:`write_report` renders a :class:`~euc_sim.rides.result.RideResult` into a folder and
returns the files' names (:class:`~euc_sim.report.ride.contract.ReportFiles`), which the
JSON then names.
"""

from __future__ import annotations

import os
import shutil
import tempfile
from pathlib import Path

from euc_sim.io import atomic_write, save_figure
from euc_sim.report.ride import fit_figures as F
from euc_sim.report.ride.contract import ReportFiles
from euc_sim.report.ride.drivetrain_page import envelope_figure, grade_figure
from euc_sim.report.ride.fit_figures import write_balance
from euc_sim.report.ride.page import write_page
from euc_sim.report.ride.limits_page import limits_md
from euc_sim.report.ride.page_html import first_screen, key_figure_lines, write_ride_html
from euc_sim.report.ride.series import RideSeries
from euc_sim.report.ride.simulation_figure import ride_simulation_figure
from euc_sim.rides.result import RideResult

__all__ = ["write_report"]


def write_report(res: RideResult, out: Path) -> ReportFiles:
    """Figures, tables, ``index.html`` and ``index.md`` into ``out``; returns their names.

    Everything is first written into a hidden folder inside ``out`` and moved into
    place (``index.md`` last) only once all of it exists: a failure or an
    interruption half-way leaves ``out`` as it was.
    """
    out.mkdir(parents=True, exist_ok=True)
    stage = Path(tempfile.mkdtemp(prefix=".ride-report-", dir=out))
    try:
        files = _write_report_files(res, stage)
        names = sorted((p.name for p in stage.iterdir()), key=lambda n: n in ("index.md", "index.html"))
        for name in names:
            os.replace(stage / name, out / name)
    finally:
        shutil.rmtree(stage, ignore_errors=True)
    return files


def _write_report_files(res: RideResult, out: Path) -> ReportFiles:
    an, sim = res.balance, res.simulation
    table = write_balance(an, out).name
    figures = _drivetrain_figures(res, out)        # PNG files
    sim_files = {}
    if sim is not None:
        figures["simulation"] = save_figure(ride_simulation_figure(sim), out / "ride_simulation.png", dpi=100).name
        atomic_write(out / "ride_simulation.csv",
                     lambda p: sim.table.to_csv(p, index=False, float_format="%.6g"))
        sim_files = {"table": "ride_simulation.csv", "figure": figures["simulation"]}
    # the page's curves come from the log as the balance fit parsed it (the fit ride's grid)
    series = RideSeries.from_frame(an.sig_fit.raw, an.sig_fit.rate)
    md = write_page(res, out, figures, key_figure_lines(res), first_screen(res), limits_md(res, series)).name
    plots = _fit_plots(res)
    html = write_ride_html(res, out, series, {**figures, **{k: k for k in plots}}, plots).name
    return ReportFiles(table, figures, md, html, sim_files.get("table"), sim_files.get("figure"))


def _fit_plots(res: RideResult) -> dict:
    """The fits' figures the page draws (Plotly), by key (the markdown's figure key, the element id)."""
    an, fit = res.balance, res.mass.fit
    plots = {"cross_ride": (F.balance_figure(an.cross, an.sig_fit, an.sig_test), F.BALANCE_HEIGHT),
             "residuals": (F.residuals_figure(list(res.traces)), F.residuals_height(len(res.traces)))}
    if res.mass.duty_shown is not None:
        shown = res.mass.duty_shown
        plots["pwm"] = (F.pwm_figure(shown, f"PWM of {Path(shown.path).name}, "
                                     f"model fitted on {Path(fit.path).name}"), F.PWM_HEIGHT)
    return plots


def _drivetrain_figures(res: RideResult, out: Path) -> dict:
    """The envelope and grade figures of the ride page (PNG), by key -> file name."""
    fit, env = res.mass.fit, res.mass.envelope
    figs = {}
    if fit.grade is not None:
        title = f"{Path(fit.path).name}: the altitude the battery-power balance implies, against GPS altitude"
        figs["grade"] = save_figure(grade_figure(fit.grade, title), out / "ride_grade.png").name
    if env.why is None:
        figs["envelope"] = save_figure(envelope_figure(env), out / "ride_envelope.png").name
    return figs

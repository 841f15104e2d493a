"""The ride JSON of CONTRACT.md, rendered from a :class:`~euc_sim.rides.result.RideResult`.

:func:`ride_json` is the one place the ``euc-sim ride`` object's keys are put together, in
the order the command has always written them; the analyses behind it hand over their own
typed objects.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from euc_sim.rides.result import RideResult, RiderNumbers

__all__ = ["ReportFiles", "ride_json", "verdict_json", "rider_json"]


@dataclass(frozen=True)
class ReportFiles:
    """The files a report folder holds, by name (no folder: no machine path in the JSON).

    Attributes
    ----------
    table : str
        The balance fit's table (``ride_balance.csv``).
    figures : dict of str -> str
        Figure key -> file name (PNG).
    markdown, html : str
        ``index.md`` and ``index.html``.
    simulation_table, simulation_figure : str or None
        The simulated rider's table and figure (None without a simulation).
    """

    table: str
    figures: dict = field(default_factory=dict)
    markdown: str | None = None
    html: str | None = None
    simulation_table: str | None = None
    simulation_figure: str | None = None


def verdict_json(v) -> dict:
    """CONTRACT's ``verdict``: ``battery_power``, ``named``, ``candidates``, ``text`` (and ``why``)."""
    out = {"battery_power": v.battery_power, "named": list(v.named), "candidates": list(v.candidates),
           "text": v.text}
    return out if v.why is None else {**out, "why": v.why}


def rider_json(r: RiderNumbers) -> dict:
    """CONTRACT's ``summary`` (with its ``battery`` verdict), ``mass_check``, ``battery`` and ``clock``."""
    bh = r.battery.to_json()
    out = r.summary.to_json()
    # CONTRACT's summary.battery: the verdict and what it is judged against (the whole entry: battery)
    out["battery"] = {k: bh[k] for k in ("verdict", "expected_ohm", "expected_source")}
    return {"summary": out, "mass_check": r.mass_check.to_json(), "battery": bh, "clock": r.clock}


def _simulation(res: RideResult, files: ReportFiles | None) -> dict:
    """``simulation`` and ``simulation_why``, the one that is set first (as the command wrote them)."""
    if res.simulation is None:
        return {"simulation_why": res.simulation_why, "simulation": None}
    sim = res.simulation.as_json()
    if files is not None and files.simulation_table:
        sim["table"], sim["figure"] = files.simulation_table, files.simulation_figure
    return {"simulation": sim, "simulation_why": res.simulation_why}


def ride_json(res: RideResult, files: ReportFiles | None = None, report_dir: str | None = None) -> dict:
    """CONTRACT's ``euc-sim ride`` object.

    Parameters
    ----------
    res : RideResult
    files : ReportFiles, optional
        The report folder's files (:func:`euc_sim.rides.render.report_files.write_report`).
    report_dir : str, optional
        Where the report folder is, from the JSON's folder (``report_dir``).

    Returns
    -------
    dict
    """
    rep = dict(res.balance.report)
    rep["notes"] = list(res.notes)
    rep["table"] = files.table if files else None
    rep.update(res.mass.view)
    rep["controller"] = res.law
    rep["parameters"] = list(res.parameters)
    rep["drivetrain"] = res.drivetrain
    if res.differences is not None:
        rep.update(res.differences.to_json())
    loc = res.traces[0].localisation
    rep["windows"] = loc["windows"]
    rep["localisation"] = {"residual": f"inertia-only balance residual of {res.traces[0].label}, "
                                       f"{rep['error_unit']}",
                           "share": loc["share"], "correlations": loc["correlations"]}
    rep["residual_traces"] = [tr.as_json() for tr in res.traces]
    rep.update(_simulation(res, files))
    rep["verdict"] = verdict_json(res.verdict)
    rep.update(rider_json(res.rider))
    if res.compared is not None:        # the compared ride's own numbers, beside LOG's on the page
        c = res.compared
        rep["compared"] = {"recording": c.recording, "total_mass": c.view["total_mass"],
                           "unidentified": c.view["unidentified"], **rider_json(c.rider)}
    rep["cutout"] = res.cutout.as_json()
    rep["report"] = files.html if files else None
    if files is not None:
        rep["figures"] = dict(files.figures)
        rep["report_markdown"] = files.markdown
    if report_dir is not None:
        rep["report_dir"] = report_dir
    return rep

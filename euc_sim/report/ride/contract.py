"""The ride JSON of CONTRACT.md, rendered from a :class:`~euc_sim.rides.result.RideResult`.

:func:`ride_json` is the one place the ``euc-sim ride`` object's keys are put together, in
the order the command has always written them; the analyses behind it hand over their own
typed objects.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field, fields

import numpy as np

from euc_sim.io import to_jsonable

from euc_sim.rides.balance.design import NOMINAL
from euc_sim.rides.balance.fit import plausibility
from euc_sim.rides.law.controller_report import describe
from euc_sim.rides.result import RideResult, RiderNumbers
from euc_sim.rides.sim.sim_steps import TARGET_RATIO, VOLTAGE_EXTRAS

__all__ = ["ReportFiles", "ride_json", "balance_json", "effect_json", "assumptions_json",
           "verdict_json", "rider_json", "physics_json", "total_mass_json", "term_json", "parameter_json",
           "spec_json", "grade_json", "cutout_json", "envelope_json", "simulation_json", "trace_json",
           "resolution_json", "difference_json", "differences_json", "clock_json", "mass_difference_json", "mass_check_json",
           "error_measure", "limits_json", "summary_json", "battery_json", "history_json",
           "controller_json", "rider_fit_json", "sim_step_json", "step_score_json", "simulation_errors_json",
           "simulation_drivetrain_json"]


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


def spec_json(spec) -> dict:
    """CONTRACT's ``wheel``: a :class:`~euc_sim.rides.source.spec.WheelSpec` in SI units."""
    return {"radius_m": spec.radius, "wheel_mass_kg": spec.wheel_mass,
            "battery_voltage_V": spec.battery_voltage, "name": spec.name,
            "source": spec.source, "missing": list(spec.missing),
            "top_speed_mps": spec.top_speed, "motor_power_W": spec.motor_power,
            "energy_Wh": spec.energy_Wh,
            "pack_layout": f"{spec.series}s{spec.parallel}p" if spec.series and spec.parallel else None,
            "cell": spec.cell or None, "tyre": spec.tyre or None}


def grade_json(g) -> dict:
    """CONTRACT's ``grade``: a :class:`~euc_sim.rides.drive.grade.GradeProfile`'s numbers (no arrays), m;
    ``{"why"}`` without one."""
    if g is None:
        return {"why": "no GPS altitude, or no mass identified: no implied grade"}
    return {"rms_implied_vs_gps_m": g.rms_m, "ascent_gps_m": g.climb_gps_m,
            "ascent_implied_m": g.climb_implied_m, "unit": "m",
            "distance_km": float(g.distance[-1]) if g.distance.size else 0.0}


def cutout_json(c) -> dict:
    """CONTRACT's ``cutout`` of a :class:`~euc_sim.rides.drive.cutout.Cutout` (speeds in m/s, NaN as null)."""
    if c.why is not None and not c.curves:
        return {"curves": None, "heldout_pwm_rmse_pct": c.heldout_pwm_rmse_pct, "danger": None, "why": c.why}
    return {"curves": [{"condition": cv.condition.name, "charge_pct": [float(x) for x in cv.charge_pct],
                        "speed_mps": [None if not np.isfinite(x) else float(x) for x in cv.speed_mps]}
                       for cv in c.curves],
            "heldout_pwm_rmse_pct": c.heldout_pwm_rmse_pct, "danger": c.danger,
            "ocv_source": c.ocv_source,
            "ride_charge_pct": list(c.charge_range) if c.charge_range else None}


def envelope_json(e) -> dict:
    """The ride JSON's ``envelope`` of a :class:`~euc_sim.rides.drive.cutout.Envelope` (SI, NaN as null):
    ``speed`` and, for ``full`` and ``low`` charge, ``voltage``, ``accel``, ``lean``, ``v_limit`` and
    ``pwm_pct``; ``voltage_source``, ``ride_top_speed``; ``{"why"}`` without one."""
    if e.why is not None:
        return {"why": e.why}
    side = lambda c: {"voltage": c.voltage, "accel": c.accel, "lean": c.lean, "v_limit": c.v_limit,   # noqa: E731
                      "pwm_pct": c.pwm_pct}
    return to_jsonable({"speed": e.speed, "full": side(e.full), "low": side(e.low),
                        "voltage_source": e.voltage_source, "ride_top_speed": e.ride_top_speed})


def simulation_json(sim) -> dict:
    """CONTRACT's ``simulation`` of a :class:`~euc_sim.rides.sim.simulate.RideSimulation` (its
    table goes to CSV)."""
    loc = sim.localisation
    return {"ride": sim.label, "errors": simulation_errors_json(sim), "effects_injected": sim.effects,
            "drivetrain": simulation_drivetrain_json(sim), "falls": list(sim.falls),
            "steps": [step_score_json(s) for s in sim.steps],
            "windows": loc.get("windows", []), "windows_share": loc.get("share"),
            "correlations": loc.get("correlations", {}), "scored_rows": sim.scored_rows,
            "pitch_scored_rows": sim.pitch_scored_rows, "notes": list(sim.notes)}


def trace_json(tr) -> dict:
    """One of CONTRACT's ``residual_traces``: a :class:`~euc_sim.rides.balance.residual.ResidualTrace`'s
    windows and RMS values (its arrays are drawn, not written)."""
    loc = tr.localisation
    return {"ride": tr.label, "in_sample": tr.in_sample, "unit": tr.unit,
            "windows": loc["windows"], "share": loc["share"], "correlations": loc["correlations"],
            "rms_nominal": tr.rms_nominal, "rms_augmented": tr.rms_augmented,
            "slow_rms_augmented": tr.rms_slow}


def resolution_json(r) -> dict | None:
    """A ``differences`` entry's ``resolution`` detail: the parts of a
    :class:`~euc_sim.rides.compare.resolution.Resolution` (None where not tested)."""
    if r is None:
        return None
    return {"interval_halfwidth": r.interval_halfwidth, "gate": r.gate, "residual_rms": r.residual_rms,
            "signature_rms": r.signature_rms, "floor": r.floor, "gain_se": r.gain_se, "fold_sd": r.fold_sd}


def difference_json(d) -> dict:
    """One of CONTRACT's ``differences``: a :class:`~euc_sim.rides.compare.differences.Difference`
    (``alias_set`` where the pair cannot tell it from others)."""
    g = d.independent
    extra = {"alias_set": list(d.alias_set)} if d.alias_set else {}
    return {"name": d.name, "estimate": d.estimate, "ci95": list(d.ci95) if d.ci95 else None, "unit": d.unit,
            "named": d.named, "why": d.why, "aliases": list(d.aliases), "heldout_gain": d.heldout_gain,
            "independent": None if g is None else {"estimate": g[0], "ci95": list(g[1]) if g[1] else None},
            "resolvable": d.resolvable, "resolution": resolution_json(d.detectable), "p_value": d.p_value,
            "q_value": d.q_value, **extra}


def differences_json(res) -> dict:
    """CONTRACT's ``differences`` list and its companions of a
    :class:`~euc_sim.rides.compare.differences.Differences`."""
    return {"differences": [difference_json(d) for d in res.items],
            "differences_cannot_see": dict(res.cannot_see), "differences_sentence": res.sentence,
            "differences_interval": res.interval_method}


def effect_json(e) -> dict:
    """One of CONTRACT's ``effects``: a Parameter of :func:`~euc_sim.rides.balance.parameters.effect_estimates`."""
    return {"name": e.name, "estimate": e.estimate, "unit": e.unit, "ci95": e.ci95,
            "rmse_after": e.rmse_after, "aliases": list(e.aliases), "evidence": e.evidence,
            "plausible": e.plausible, "plausible_range": e.plausible_range, "on_bound": e.on_bound, **e.extra}


def assumptions_json(a) -> dict:
    """CONTRACT's ``assumptions``: the :class:`~euc_sim.rides.grids.signals.RideAssumptions` the balance
    fit took (SI), each found value's source."""
    return {"R": a.R, "total_mass": a.total_mass, "m_eq": a.m_eq, "g": a.g, "efficiency_for_torque": a.efficiency,
            "torque_constant": a.torque_constant, "v_min": a.v_min,
            "sources": {k: a.source_of(k) for k in ("R", "total_mass")},
            "source": "; ".join(f"{k}: {a.source_of(k)}" for k in ("R", "total_mass"))}


def error_measure(an) -> str:
    """What a :class:`~euc_sim.rides.balance.analysis.RideAnalysis`'s held-out errors measure, in words."""
    cr = an.cross
    return (f"RMS of measured minus predicted battery power{'' if an.domain == 'power' else ' divided by ω = v/R'} "
            f"on {cr.test_label}, parameters fitted on {cr.fit_label}")


def balance_json(an, effects) -> dict:
    """CONTRACT's balance keys of a :class:`~euc_sim.rides.balance.analysis.RideAnalysis`
    and its accepted ``effects`` (``recording`` ... ``notes``, ``table`` None), in the command's order."""
    cr, st = an.cross, an.settings
    d_fit, d_test = cr.fit_design, cr.test_design
    return {
        "recording": an.recording,
        "compare": an.compare,
        "effects": [effect_json(e) for e in effects],
        "heldout_error_nominal": cr.heldout_nominal,
        "heldout_error_augmented": cr.heldout_augmented,
        "error_unit": an.error_unit,
        "error_measure": error_measure(an),
        "ratio": cr.ratio,
        "heldout_error_all_candidates": cr.heldout_full,
        "selection": [dict(h) for h in cr.selection],
        "selected_not_accepted": [c for c in cr.selected if c not in cr.accepted],
        "insample_error_nominal": cr.nominal.rmse,
        "insample_error_augmented": cr.augmented.rmse,
        "nominal_parameters": {k: plausibility(cr.augmented)[k] for k in NOMINAL},
        "inertia_only_parameters": plausibility(cr.nominal),
        "all_estimates": plausibility(cr.full),
        "aliases": {k: list(v) for k, v in d_fit.aliases.items()},
        "confounded": {k: list(cr.full.confounded(k)) for k in cr.full.names
                       if cr.full.confounded(k)},
        "bootstrap_correlation_full_fit": {f"{a}~{b}": r for (a, b), r in cr.full.boot_corr.items()
                                           if a < b},
        "domain": an.domain,
        "torque_method": an.sig_fit.torque_method,
        "power_source": an.sig_fit.power_source,
        "assumptions": assumptions_json(an.assumptions),
        "filter": {"rate_hz": st.rate, "window_s": st.window, "polyorder": st.polyorder,
                   "max_gap_s": st.max_gap},
        "bootstrap": {"n_boot": st.n_boot, "block_s": st.block_s, "seed": st.seed},
        "rows": {"fit": len(d_fit.P), "test": len(d_test.P)},
        "notes": list(an.notes),
        "table": None,
    }


def term_json(t) -> dict:
    """A drivetrain term: ``estimate``, ``ci95``, ``unit`` (a balance fit's also ``accepted`` and
    ``parameter``), and ``why`` where it is not identified or not accepted."""
    out = {"estimate": t.estimate, "ci95": list(t.ci95) if t.ci95 else None, "unit": t.unit}
    if t.parameter is not None:
        out.update(accepted=t.accepted, parameter=t.parameter)
        if not t.accepted:
            out["why"] = t.why
    elif t.why is not None:
        out["why"] = t.why
    return out


def parameter_json(p) -> dict:
    """One entry of CONTRACT's ``parameters`` (a balance term's also ``plausible_range``, ``on_bound``)."""
    out = {"name": p.name, "estimate": p.estimate, "ci95": list(p.ci95) if p.ci95 else None, "unit": p.unit,
           "plausible": p.plausible, "accepted": p.accepted, "why": p.why, "source": p.source}
    if p.source == "balance":
        out.update(plausible_range=p.plausible_range, on_bound=p.on_bound)
    return out


def total_mass_json(m, spec) -> dict:
    """CONTRACT's ``total_mass`` of a reported :class:`~euc_sim.rides.drive.mass.MassFit` (the rider's
    mass where the spec gives the wheel's net weight)."""
    out = {"estimate": m.estimate, "ci95": list(m.ci95) if m.ci95 else None,
           "unit": "kg", "lag_s": m.lag, "speed_scale": m.scale.estimate, "speed_scale_source": m.scale.source,
           "signed_current": m.signed, "terms": m.terms, "balance": m.history,
           "n_samples": m.n_samples,
           "by_window": [{"window_s": w, "estimate": x} for w, x in m.by_window.items()],
           "equivalent_mass": m.equivalent or None,
           "systematic": dict(m.systematic) if m.estimate is not None else None,
           "statistical_ci95": list(m.stat_ci95) if m.stat_ci95 else None,
           "copper_column": m.copper_column}
    if m.estimate is None:
        out["why"] = m.why
    if spec.wheel_mass is not None and m.estimate is not None:
        out["rider_mass"] = {"estimate": m.estimate - spec.wheel_mass,
                             "ci95": [x - spec.wheel_mass for x in m.ci95] if m.ci95 else None,
                             "note": "total minus the spec's net weight (rider with gear)"}
    else:
        out["rider_mass"] = None
        out["rider_mass_why"] = ("no wheel weight (give --wheel SPEC.csv or --wheel-mass)"
                                 if m.estimate is not None else m.why)
    return out


def mass_difference_json(d) -> dict:
    """CONTRACT's ``mass_difference``: a :class:`~euc_sim.rides.source.systematic.MassDifference`."""
    out = {"estimate": d.estimate, "ci95": None if d.ci95 is None else list(d.ci95), "unit": d.unit,
           "verdict": d.verdict}
    if d.why is not None:
        return {**out, "why": d.why}
    return {**out, "cancelled": list(d.cancelled), "note": d.note}


def mass_check_json(m) -> dict:
    """CONTRACT's ``mass_check``: a :class:`~euc_sim.rides.summary.summary.MassCheck` (kg)."""
    return to_jsonable(asdict(m))


def physics_json(md) -> dict:
    """CONTRACT's ``total_mass``, ``drivetrain`` (the energy balance's terms), ``envelope``,
    ``input_warnings``, ``wheel``, ``unidentified``, ``grade`` and, with a compared ride,
    ``mass_difference``, ``power_heldout`` and ``pwm`` of a
    :class:`~euc_sim.rides.drive.drivetrain_report.MassDrivetrain`."""
    fit = md.fit
    rep = {"total_mass": total_mass_json(md.mass, fit.spec),
           "drivetrain": {k: term_json(t) for k, t in md.terms.items()}, "envelope": envelope_json(md.envelope),
           "input_warnings": md.input_warnings, "wheel": spec_json(fit.spec), "unidentified": dict(md.unidentified),
           "grade": grade_json(fit.grade)}
    if md.test is None:
        return rep
    rep["mass_difference"] = mass_difference_json(md.mass_difference)
    rep["power_heldout"] = {"rmse": md.power_heldout[0], "rms_power": md.power_heldout[1], "unit": "W"}
    if md.pwm_why is None:
        rep["pwm"] = {"heldout_rmse": md.pwm_heldout, "unit": "%"}
        if md.pwm_unchecked:
            rep["pwm"]["note"] = md.pwm_unchecked
    else:
        rep["pwm"] = {"heldout_rmse": None, "unit": "%", "why": md.pwm_why}
    return rep


def verdict_json(v) -> dict:
    """CONTRACT's ``verdict``: ``battery_power``, ``named``, ``candidates``, ``text`` (and ``why``)."""
    out = {"battery_power": v.battery_power, "named": list(v.named), "candidates": list(v.candidates),
           "text": v.text}
    return out if v.why is None else {**out, "why": v.why}


def clock_json(c) -> dict:
    """CONTRACT's ``clock``: ``start``, ``utc_offset_s``, ``zone`` and ``pauses`` ([[t0, t1], ...] s)."""
    return {"start": c.start, "utc_offset_s": c.utc_offset_s, "zone": c.zone, "pauses": [list(p) for p in c.pauses]}


def rider_json(r: RiderNumbers) -> dict:
    """CONTRACT's ``summary`` (with its ``battery`` verdict), ``mass_check``, ``battery`` and ``clock``."""
    bh = battery_json(r.battery)
    out = summary_json(r.summary)
    # CONTRACT's summary.battery: the verdict and what it is judged against (the whole entry: battery)
    out["battery"] = {k: bh[k] for k in ("verdict", "expected_ohm", "expected_source")}
    return {"summary": out, "mass_check": mass_check_json(r.mass_check), "battery": bh, "clock": clock_json(r.clock)}


def _simulation(res: RideResult, files: ReportFiles | None) -> dict:
    """``simulation`` and ``simulation_why``, the one that is set first (as the command wrote them)."""
    if res.simulation is None:
        return {"simulation_why": res.simulation_why, "simulation": None}
    sim = simulation_json(res.simulation)
    if files is not None and files.simulation_table:
        sim["table"], sim["figure"] = files.simulation_table, files.simulation_figure
    return {"simulation": sim, "simulation_why": res.simulation_why}


def ride_json(res: RideResult, files: ReportFiles | None = None, report_dir: str | None = None) -> dict:
    """CONTRACT's ``euc-sim ride`` object.

    Parameters
    ----------
    res : RideResult
    files : ReportFiles, optional
        The report folder's files (:func:`euc_sim.report.ride.report_files.write_report`).
    report_dir : str, optional
        Where the report folder is, from the JSON's folder (``report_dir``).

    Returns
    -------
    dict
    """
    rep = balance_json(res.balance, res.effects)
    rep["notes"] = list(res.notes)
    rep["table"] = files.table if files else None
    rep.update(physics_json(res.mass))
    rep["controller"] = controller_json(res.law)
    rep["parameters"] = [parameter_json(p) for p in res.parameters]
    rep["drivetrain"] = {k: term_json(t) for k, t in res.drivetrain.items()}
    if res.differences is not None:
        rep.update(differences_json(res.differences))
    loc = res.traces[0].localisation
    rep["windows"] = loc["windows"]
    rep["localisation"] = {"residual": f"inertia-only balance residual of {res.traces[0].label}, "
                                       f"{rep['error_unit']}",
                           "share": loc["share"], "correlations": loc["correlations"]}
    rep["residual_traces"] = [trace_json(tr) for tr in res.traces]
    rep.update(_simulation(res, files))
    rep["verdict"] = verdict_json(res.verdict)
    rep.update(rider_json(res.rider))
    if res.compared is not None:        # the compared ride's own numbers, beside LOG's on the page
        c = res.compared
        rep["compared"] = {"recording": c.recording, "total_mass": total_mass_json(c.mass, c.drivetrain.spec),
                           "unidentified": dict(c.drivetrain.drivetrain.unidentified), **rider_json(c.rider)}
    rep["cutout"] = cutout_json(res.cutout)
    rep["report"] = files.html if files else None
    if files is not None:
        rep["figures"] = dict(files.figures)
        rep["report_markdown"] = files.markdown
    if report_dir is not None:
        rep["report_dir"] = report_dir
    return rep


def limits_json(lim) -> dict:
    """``summary.limits`` of a :class:`~euc_sim.rides.drive.cutout.Limits`: ``speed_limit_mps``, ``source``,
    ``pwm_alarm_pct`` (and ``why`` when something is missing)."""
    out = {"speed_limit_mps": lim.speed_limit_mps, "source": lim.source, "pwm_alarm_pct": lim.pwm_alarm_pct}
    return out if lim.why is None else {**out, "why": lim.why}


def summary_json(s) -> dict:
    """CONTRACT's ``summary`` of a :class:`~euc_sim.rides.summary.summary.RideSummary` (plain floats,
    None for what is unknown)."""
    out = asdict(s)
    out["limits"] = None if s.limits is None else limits_json(s.limits)
    return to_jsonable(out)


def battery_json(b) -> dict:
    """CONTRACT's ``battery``: a :class:`~euc_sim.rides.drive.battery.BatteryHealth` (Ω, °C)."""
    out = asdict(b)
    for k in ("resistance_ci95", "resistance_25C_ci95", "expected_ohm"):
        out[k] = list(out[k]) if out[k] is not None else None
    return out


def history_json(h) -> dict:
    """The ``euc-sim rides`` object of a :class:`~euc_sim.rides.logbook.history.RideHistory`: each ride's
    entry (its ``summary`` and ``battery`` as in the ride JSON), the change test and the Wh/km slope."""
    rides = [{**{f.name: getattr(e, f.name) for f in fields(e)}, "summary": summary_json(e.summary),
              "battery": battery_json(e.battery), "series": list(e.series), "repairs": list(e.repairs)}
             for e in h.rides]
    change = None if h.change is None else {**asdict(h.change), "difference_ci95": list(h.change.difference_ci95)}
    return {"rides": rides, "basis": h.basis, "change": change,
            "Wh_per_km_vs_speed": {"slope": h.whkm_slope,
                                   "ci95": list(h.whkm_slope_ci95) if h.whkm_slope_ci95 else None,
                                   "unit": "Wh/km per m/s"},
            "trend": h.trend, "why": dict(h.why)}


def controller_json(c) -> dict:
    """CONTRACT's ``controller`` of a :class:`~euc_sim.rides.law.controller_report.ControllerFit`:
    ``law`` (words), ``terms`` [{name, estimate, ci95, unit}] (``torque_limit`` also
    ``largest_measured``), ``sign``, ``heldout``, ``within_ride``, ``selection``; or ``{"law": None, "why"}``.
    ``euc-sim sim --firmware`` reads it back (:func:`euc_sim.controllers.firmware.law_terms`)."""
    law = c.law
    if law is None:
        return {"law": None, "why": c.why}
    terms = [{"name": k, "estimate": v, "ci95": list(ci) if ci else None, "unit": u,
              **({"largest_measured": c.largest_measured} if k == "torque_limit" else {})}
             for k, (v, ci, u) in law.terms.items()]
    heldout = {"r2": c.heldout_r2, "channel": law.channel, "ride": c.heldout_ride}
    if c.compare_why is not None:
        heldout["compare_why"] = c.compare_why
    return {"law": describe(law), "terms": terms, "sign": law.sign, "sign_share": law.sign_share,
            "torque_constant": c.torque_constant, "channel": law.channel,
            "within_ride": {"r2": law.heldout_r2, "nominal_r2": law.nominal_r2,
                            "without_pitch_r2": law.blind_r2, "rmse": law.heldout_rmse, "unit": law.unit},
            "selection": law.history, "heldout": heldout}


def rider_fit_json(fit) -> dict:
    """The studies' JSON of a :class:`~euc_sim.rides.rider.rider_fit.RiderFit` (the rider calibrated on a ride)."""
    return {"params": fit.params, "rider": fit.rider.as_dict(), "objective": fit.objective,
            "objective_nominal": fit.objective_nominal, "features": fit.features,
            "windows": [list(w) for w in fit.windows], "simulations": fit.simulations,
            "falls": [dict(f) for f in fit.falls], "notes": list(fit.notes)}


def sim_step_json(step) -> dict:
    """A :class:`~euc_sim.rides.sim.sim_steps.SimStep` as CONTRACT's ``simulation.steps`` describe it:
    its law (``motor``, read back by :func:`~euc_sim.rides.sim.sim_steps.motor_from_law`), rider,
    effects and power model."""
    m = step.motor
    law = {"K_p": m.Kp, "K_d": m.Kd, "torque_limit": m.torque_limit}
    if math.isfinite(m.tiltback_speed):
        law.update(tiltback_speed=m.tiltback_speed, tiltback_gain=m.tiltback_gain)
    if math.isfinite(m.voltage):
        law.update(voltage=m.voltage, back_emf=m.back_emf, drop=m.drop)
        law.update({k: getattr(m, k) for k in VOLTAGE_EXTRAS
                    if getattr(m, k) != type(m).__dataclass_fields__[k].default})
    rider = None if step.rider is None else {
        "delay": float(getattr(step.rider, "delay", float("nan"))),
        "noise_std": float(getattr(step.rider, "noise_std", float("nan"))),
        "plan_window": step.plan_window,
        **({"bandwidth": float(step.rider_fit["bandwidth"])} if "bandwidth" in step.rider_fit else {})}
    return {"step": step.name, "what": step.what, "ran": step.why is None, "why": step.why,
            "physics": list(step.physics), "motor": law, "rider": rider or "default LQR rider designed for this motor",
            "effects_injected": dict(step.effects), "power_model": dict(step.power), "notes": list(step.notes)}


def step_score_json(s) -> dict:
    """One of CONTRACT's ``simulation.steps``: a :class:`~euc_sim.rides.sim.simulate.StepScore`."""
    bands = None if s.heldout_bands is None else {k: asdict(b) for k, b in s.heldout_bands.items()}
    return {**sim_step_json(s.step), "heldout_rmse": dict(s.heldout_rmse), "heldout_bands": bands,
            "ratio_to_balance": s.ratio_to_balance, "target_ratio": TARGET_RATIO,
            "fell": None if s.fell is None else {"t": s.fell["t"], "cause": s.fell["cause"]}}


def simulation_errors_json(sim) -> dict:
    """CONTRACT's ``simulation.errors``: each step that ran, ``nominal`` and ``augmented`` (the first
    and the last), ``ratio_P`` and ``M_log_method``."""
    e, ran = sim.errors, sim.ran
    return {**e, "nominal": e[ran[0]], "augmented": e[ran[-1]], "ratio_P": sim.ratio_P,
            "M_log_method": sim.torque_method}


def simulation_drivetrain_json(sim) -> dict:
    """CONTRACT's ``simulation.drivetrain``: each step's battery-power model that ran, ``nominal`` and ``augmented``."""
    run = [s.step for s in sim.steps if s.step.why is None]
    return {s.name: dict(s.power) for s in run} | {"nominal": dict(run[0].power), "augmented": dict(run[-1].power)}

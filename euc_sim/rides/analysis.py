"""A ride's balance diagnosis end to end: CONTRACT's ``euc-sim ride`` JSON form.

:func:`ride_analysis` reads the ride(s), builds the balance designs, runs the
cross-ride comparison (:mod:`euc_sim.rides.crossride`) and assembles the report;
:func:`ride_report` returns only the report.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import pandas as pd

from euc_sim.rides.crossride import CrossRide, cross_ride, effect_entries, plot_cross_ride
from euc_sim.rides.design import NOMINAL, Design, balance_design
from euc_sim.rides.fit import plausibility
from euc_sim.rides.signals import RideAssumptions, RideSignals, ride_signals

__all__ = ["RideAnalysis", "ride_report", "ride_analysis"]


@dataclass(frozen=True)
class RideAnalysis:
    """What :func:`ride_analysis` computed: the JSON report and the objects behind it.

    Attributes
    ----------
    report : dict
        CONTRACT's ``euc-sim ride`` form (see :func:`ride_report`).
    cross : CrossRide
    sig_fit, sig_test : RideSignals
        The fit ride and the compare ride (None without ``compare_path``).
    """

    report: dict
    cross: CrossRide
    sig_fit: RideSignals
    sig_test: RideSignals | None


def ride_report(log_path, compare_path=None, **kwargs) -> dict:
    """Diagnose a ride's longitudinal balance; CONTRACT's ``euc-sim ride`` JSON form.

    ``ride_analysis(log_path, compare_path, **kwargs).report``: see :func:`ride_analysis`.
    """
    return ride_analysis(log_path, compare_path, **kwargs).report


def ride_analysis(log_path, compare_path=None, *, report_dir=None,
                  assumptions: RideAssumptions = RideAssumptions(), rate: float = 10.0,
                  max_gap: float = 1.0, window: float = 1.5, polyorder: int = 2,
                  domain: str = "power", n_boot: int = 200, block_s: float = 10.0,
                  seed: int = 0) -> RideAnalysis:
    """Diagnose a ride's longitudinal balance; CONTRACT's ``euc-sim ride`` JSON form.

    Fits the inertia-only balance (η_m, η_r) and the augmented one on
    ``log_path`` and measures both on ``compare_path``; without ``compare_path``
    the first half of the ride is the fit and the second half the test.

    Parameters
    ----------
    log_path : path
        Ride to fit.
    compare_path : path, optional
        Ride to test on.
    report_dir : path, optional
        Where to write ``ride_balance.png`` and ``ride_balance.csv`` (test ride:
        t, measured and predicted battery power), atomically.
    assumptions : RideAssumptions
    rate, max_gap, window, polyorder :
        See :func:`ride_signals`.
    domain : {"power", "torque"}
    n_boot, block_s, seed :
        See :func:`fit_balance`.

    Returns
    -------
    RideAnalysis
        ``.report`` is the dict
        ``{"effects": [...], "heldout_error_nominal", "heldout_error_augmented",
        "error_unit"}`` plus ``ratio``, ``nominal_parameters`` (the efficiencies
        of the augmented fit, with plausibility flags), ``all_estimates`` (every
        candidate of the full fit, flagged), ``aliases``, ``torque_method``,
        ``power_source``, ``assumptions``, ``filter``, ``bootstrap``, ``notes``,
        ``figure``.
    """
    sig_fit = ride_signals(log_path, assumptions, rate, max_gap, window, polyorder)
    sig_test = (None if compare_path is None else
                ride_signals(compare_path, assumptions, rate, max_gap, window, polyorder))
    d_fit, d_test, fit_label, test_label = _fit_and_test(sig_fit, sig_test, log_path, compare_path,
                                                         domain)
    cr = cross_ride(d_fit, d_test, n_boot, block_s, seed, fit_label, test_label)
    aug_phys = plausibility(cr.augmented)
    notes = _notes(sig_fit, sig_test, d_fit, assumptions, test_label)
    report = {
        "recording": str(log_path),
        "compare": None if compare_path is None else str(compare_path),
        "effects": effect_entries(cr),
        "heldout_error_nominal": cr.heldout_nominal,
        "heldout_error_augmented": cr.heldout_augmented,
        "error_unit": "W" if domain == "power" else "N·m",
        "error_measure": (f"RMS of measured minus predicted battery power"
                          f"{'' if domain == 'power' else ' divided by ω = v/R'} on {test_label}, "
                          f"parameters fitted on {fit_label}"),
        "ratio": cr.ratio,
        "heldout_error_all_candidates": cr.heldout_full,
        "insample_error_nominal": cr.nominal.rmse,
        "insample_error_augmented": cr.augmented.rmse,
        "nominal_parameters": {k: aug_phys[k] for k in NOMINAL},
        "inertia_only_parameters": plausibility(cr.nominal),
        "all_estimates": plausibility(cr.full),
        "aliases": {k: list(v) for k, v in d_fit.aliases.items()},
        "confounded": {k: list(cr.full.confounded(k)) for k in cr.full.names
                       if cr.full.confounded(k)},
        "bootstrap_correlation_full_fit": {f"{a}~{b}": r for (a, b), r in cr.full.boot_corr.items()
                                           if a < b},
        "domain": domain,
        "torque_method": sig_fit.torque_method,
        "power_source": sig_fit.power_source,
        "assumptions": assumptions.as_dict(),
        "filter": {"rate_hz": rate, "window_s": window, "polyorder": polyorder,
                   "max_gap_s": max_gap},
        "bootstrap": {"n_boot": n_boot, "block_s": block_s, "seed": seed},
        "rows": {"fit": len(d_fit.P), "test": len(d_test.P)},
        "notes": notes,
        "figure": None,
    }
    if report_dir is not None:
        report["figure"] = str(_write_balance(cr, d_test, sig_fit, sig_test, Path(report_dir)))
    return RideAnalysis(report=report, cross=cr, sig_fit=sig_fit, sig_test=sig_test)


def _fit_and_test(sig_fit: RideSignals, sig_test: RideSignals | None, log_path, compare_path,
                  domain: str) -> tuple[Design, Design, str, str]:
    """The fit and test designs and their labels: two rides, or one ride's halves."""
    d_all = balance_design(sig_fit, domain)
    if sig_test is not None:
        return d_all, balance_design(sig_test, domain), Path(log_path).name, Path(compare_path).name
    t_mid = 0.5 * (d_all.t[0] + d_all.t[-1])
    return (d_all.rows(d_all.t < t_mid), d_all.rows(d_all.t >= t_mid),
            f"{Path(log_path).name} (first half)", f"{Path(log_path).name} (second half)")


def _notes(sig_fit: RideSignals, sig_test: RideSignals | None, d_fit: Design,
           assumptions: RideAssumptions, test_label: str) -> list[str]:
    """The report's notes: reader, resampling and design notes, and the mass caveat."""
    notes = list(sig_fit.notes) + list(d_fit.notes)
    notes.append(f"masses are assumed (m_eq = {assumptions.m_eq:g} kg, total {assumptions.total_mass:g} "
                 f"kg): the power balance fixes only m_eq/η_m, so η_m, η_r, k and P₀ scale with the "
                 f"assumed mass; C_rr (a force per weight) does not")
    if sig_test is not None:
        notes += [f"{test_label}: {n}" for n in sig_test.notes]
    return notes


def _write_balance(cr: CrossRide, d_test: Design, sig_fit: RideSignals,
                   sig_test: RideSignals | None, report_dir: Path) -> Path:
    """Write ``ride_balance.png`` and ``ride_balance.csv`` (the test ride) atomically."""
    from euc_sim.io import atomic_write

    fig = plot_cross_ride(cr, report_dir / "ride_balance.png", sig_fit, sig_test)
    table = pd.DataFrame({"t": d_test.t, "v": d_test.v, "P_measured": d_test.P,
                          "P_nominal": d_test.predict(cr.nominal.estimate),
                          "P_augmented": d_test.predict(cr.augmented.estimate)})
    atomic_write(report_dir / "ride_balance.csv", lambda p: table.to_csv(p, index=False))
    return fig

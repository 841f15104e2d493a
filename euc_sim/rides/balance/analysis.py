"""A ride's balance diagnosis end to end: CONTRACT's ``euc-sim ride`` JSON form.

:func:`ride_analysis` reads the ride(s), builds the balance designs, runs the
cross-ride comparison (:mod:`euc_sim.rides.balance.crossride`) and assembles the report;
:func:`ride_report` returns only the report.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass
from typing import Callable

import numpy as np

from euc_sim.errors import InputError
from euc_sim.rides.balance.crossride import CrossRide, cross_ride, effect_entries
from euc_sim.rides.balance.design import NOMINAL, Design, balance_design
from euc_sim.rides.balance.fit import FEW_BLOCKS, block_rows, plausibility
from euc_sim.rides.grids.signals import RideAssumptions, RideSignals, ride_signals
from euc_sim.rides.source.gaps import GAP_POLICY
from euc_sim.stats import one_blas_thread

__all__ = ["RideAnalysis", "ride_report", "ride_analysis", "check_data", "split_time"]


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
    designs : tuple of Design
        The balance design of the whole fit ride and of the compare ride (None without
        ``compare_path``): built once, read again by the residual's localisation.
    """

    report: dict
    cross: CrossRide
    sig_fit: RideSignals
    sig_test: RideSignals | None
    designs: tuple = (None, None)


def ride_report(log_path, compare_path=None, **kwargs) -> dict:
    """Diagnose a ride's longitudinal balance; CONTRACT's ``euc-sim ride`` JSON form.

    ``ride_analysis(log_path, compare_path, **kwargs).report``: see :func:`ride_analysis`.
    """
    return ride_analysis(log_path, compare_path, **kwargs).report


def ride_analysis(log_path, compare_path=None, *,
                  assumptions: RideAssumptions = RideAssumptions(), rate: float = GAP_POLICY.rate,
                  max_gap: float = GAP_POLICY.bridge, window: float = 1.5, polyorder: int = 2,
                  domain: str = "power", n_boot: int = 200, block_s: float = 10.0,
                  seed: int = 0, progress: Callable[[str], None] | None = None) -> RideAnalysis:
    """Diagnose a ride's longitudinal balance; CONTRACT's ``euc-sim ride`` JSON form.

    Fits the inertia-only balance (η_m, η_r) and the augmented one on
    ``log_path`` and measures both on ``compare_path``; without ``compare_path``
    the first half of the ride is the fit and the second half the test.

    Parameters
    ----------
    log_path : Ride
        Ride to fit (it keeps its grid: built once).
    compare_path : Ride, optional
        Ride to test on.
    assumptions : RideAssumptions
    rate, max_gap, window, polyorder :
        See :func:`ride_signals`.
    domain : {"power", "torque"}
    n_boot, block_s, seed :
        See :func:`fit_balance`.
    progress : callable, optional
        Called with a short line at each step.

    Returns
    -------
    RideAnalysis
        ``.report`` is the dict
        ``{"effects": [...], "heldout_error_nominal", "heldout_error_augmented",
        "error_unit"}`` plus ``ratio``, ``nominal_parameters`` (the inertia-only
        model's terms in the augmented fit: none since the balance fits no efficiency), ``all_estimates`` (every
        candidate of the full fit, flagged), ``aliases``, ``torque_method``,
        ``power_source``, ``assumptions``, ``filter``, ``bootstrap``, ``notes``,
        ``figure`` (None: the page names it); ``recording`` and
        ``compare`` are file names (no folder: no machine path in outputs).
    """
    with one_blas_thread():
        return _ride_analysis(log_path, compare_path, assumptions=assumptions, rate=rate, max_gap=max_gap,
                              window=window, polyorder=polyorder, domain=domain, n_boot=n_boot,
                              block_s=block_s, seed=seed, progress=progress)


def _ride_analysis(log_path, compare_path=None, *,
                   assumptions: RideAssumptions = RideAssumptions(), rate: float = GAP_POLICY.rate,
                   max_gap: float = GAP_POLICY.bridge, window: float = 1.5, polyorder: int = 2,
                   domain: str = "power", n_boot: int = 200, block_s: float = 10.0,
                   seed: int = 0, progress: Callable[[str], None] | None = None) -> RideAnalysis:
    say = progress or (lambda msg: None)
    say(f"reading {log_path.name}" + ("" if compare_path is None else
                                            f" and {compare_path.name}"))
    sig_fit = ride_signals(log_path, assumptions, rate, max_gap, window, polyorder)
    sig_test = (None if compare_path is None else
                ride_signals(compare_path, assumptions, rate, max_gap, window, polyorder))
    d_all, d_fit, d_test, fit_label, test_label = _fit_and_test(sig_fit, sig_test, log_path, compare_path,
                                                                domain)
    cr = cross_ride(d_fit, d_test, n_boot, block_s, seed, fit_label, test_label, progress=say)
    notes = _notes(sig_fit, sig_test, d_fit, assumptions, test_label)
    blocks = len(d_fit.P) / (block_s * rate)
    if n_boot and blocks < FEW_BLOCKS:
        notes.append(_few_blocks(fit_label, blocks, block_s))
        warnings.warn(notes[-1], stacklevel=3)
    report = _report(cr, sig_fit, d_fit, d_test, (fit_label, test_label), notes, domain,
                     assumptions, dict(log_path=log_path, compare_path=compare_path, rate=rate,
                                       window=window, polyorder=polyorder, max_gap=max_gap,
                                       n_boot=n_boot, block_s=block_s, seed=seed))
    an = RideAnalysis(report=report, cross=cr, sig_fit=sig_fit, sig_test=sig_test,
                      designs=(d_all, None if sig_test is None else d_test))
    return an


def _report(cr: CrossRide, sig_fit: RideSignals, d_fit: Design, d_test: Design,
            labels: tuple[str, str], notes: list[str], domain: str,
            assumptions: RideAssumptions, settings: dict) -> dict:
    """CONTRACT's ``euc-sim ride`` dict from the cross-ride fits (``figure`` still None)."""
    fit_label, test_label = labels
    log_path, compare_path = settings["log_path"], settings["compare_path"]
    rate, window, polyorder = settings["rate"], settings["window"], settings["polyorder"]
    max_gap, n_boot = settings["max_gap"], settings["n_boot"]
    block_s, seed = settings["block_s"], settings["seed"]
    aug_phys = plausibility(cr.augmented)
    return {
        "recording": log_path.name,
        "compare": None if compare_path is None else compare_path.name,
        "effects": effect_entries(cr),
        "heldout_error_nominal": cr.heldout_nominal,
        "heldout_error_augmented": cr.heldout_augmented,
        "error_unit": "W" if domain == "power" else "N·m",
        "error_measure": (f"RMS of measured minus predicted battery power"
                          f"{'' if domain == 'power' else ' divided by ω = v/R'} on {test_label}, "
                          f"parameters fitted on {fit_label}"),
        "ratio": cr.ratio,
        "heldout_error_all_candidates": cr.heldout_full,
        "selection": [dict(h) for h in cr.selection],
        "selected_not_accepted": [c for c in cr.selected if c not in cr.accepted],
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
        "table": None,
    }


def check_data(log_path, compare_path=None, *, assumptions: RideAssumptions = RideAssumptions(),
               domain: str = "power", block_s: float = 10.0) -> None:
    """Fail early, naming the file, on a log :func:`ride_analysis` cannot use.

    Builds the rides' balance grids (kept on each ride) and checks the fit part (LOG, or its first half without
    ``compare_path``) holds enough rows for the bootstrap (:func:`block_rows`).

    Raises
    ------
    ValueError, OSError
        naming the file and what is missing.
    """
    sig_fit = ride_signals(log_path, assumptions)
    sig_test = None if compare_path is None else ride_signals(compare_path, assumptions)
    _, d_fit, d_test, _, _ = _fit_and_test(sig_fit, sig_test, log_path, compare_path, domain)
    block_rows(d_fit, block_s)
    if len(d_test.P) == 0:
        raise InputError(f"{d_test.path}: no usable rows to test on")


def _few_blocks(fit_label: str, blocks: float, block_s: float) -> str:
    return (f"{fit_label} gives only {blocks:.1f} bootstrap blocks of {block_s:g} s: the 95 % "
            f"intervals are rough (fewer than {FEW_BLOCKS} blocks); a longer ride gives "
            f"firmer ones")


def split_time(t) -> float:
    """Where a ride is cut into fit and test halves, s: half its usable rows on each side.

    Not the midpoint of the clock: a log left recording through a long pause
    would put all the riding on one side.
    """
    t = np.sort(np.asarray(t, float))
    return float(t[len(t) // 2])


def _fit_and_test(sig_fit: RideSignals, sig_test: RideSignals | None, log_path, compare_path,
                  domain: str) -> tuple[Design, Design, Design, str, str]:
    """The fit ride's whole design, the fit and test designs and their labels: two rides, or one
    ride's halves."""
    d_all = balance_design(sig_fit, domain)
    if sig_test is not None:
        return d_all, d_all, balance_design(sig_test, domain), log_path.name, compare_path.name
    t_mid = split_time(d_all.t)
    return (d_all, d_all.rows(d_all.t < t_mid), d_all.rows(d_all.t >= t_mid),
            f"{log_path.name} (first half)", f"{log_path.name} (second half)")


def _notes(sig_fit: RideSignals, sig_test: RideSignals | None, d_fit: Design,
           assumptions: RideAssumptions, test_label: str) -> list[str]:
    """The report's notes: reader, resampling and design notes, and the mass caveat."""
    notes = list(sig_fit.notes) + list(d_fit.notes)
    notes.append(f"masses of the balance fit: m_eq = {assumptions.m_eq:.4g} kg, total "
                 f"{assumptions.total_mass:.4g} kg ({assumptions.source_of('total_mass')}): the "
                 f"balance takes the inertial power m_eq·a·v as given (no efficiency to scale it), "
                 f"so every estimate depends on this mass through the inertia it leaves in the "
                 f"residual")
    if sig_test is not None:
        notes += [f"{test_label}: {n}" for n in sig_test.notes]
    return notes

"""A ride's balance diagnosis end to end.

:func:`ride_analysis` builds the ride(s)' balance designs and runs the cross-ride
comparison (:mod:`euc_sim.rides.balance.crossride`); the JSON is rendered from its
:class:`RideAnalysis` (:func:`euc_sim.report.ride.contract.balance_json`).
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass, field
from typing import Callable

import numpy as np

from euc_sim.errors import InputError
from euc_sim.rides.balance.crossride import CrossRide, cross_ride
from euc_sim.rides.balance.design import Design, balance_design
from euc_sim.rides.balance.fit import FEW_BLOCKS, block_rows
from euc_sim.rides.grids.signals import RideAssumptions, RideSignals, ride_signals
from euc_sim.rides.source.gaps import GAP_POLICY
from euc_sim.stats import one_blas_thread

__all__ = ["RideAnalysis", "BalanceSettings", "ride_analysis", "check_data", "split_time"]


@dataclass(frozen=True)
class BalanceSettings:
    """How the balance fit read the ride (``rate`` Hz, Savitzky–Golay ``window`` s and
    ``polyorder``, ``max_gap`` s) and drew its bootstrap (``n_boot``, ``block_s`` s, ``seed``).
    """

    rate: float = GAP_POLICY.rate
    window: float = 1.5
    polyorder: int = 2
    max_gap: float = GAP_POLICY.bridge
    n_boot: int = 200
    block_s: float = 10.0
    seed: int = 0


@dataclass(frozen=True)
class RideAnalysis:
    """What :func:`ride_analysis` computed.

    Attributes
    ----------
    cross : CrossRide
    sig_fit, sig_test : RideSignals
        The fit ride and the compare ride (None without one).
    designs : tuple of Design
        The balance designs of the whole fit ride and of the compare ride.
    notes : tuple of str
    domain : {"power", "torque"}
    assumptions : RideAssumptions
    settings : BalanceSettings
    recording, compare : str
        The fit and compare logs' file names (``compare`` None without one).
    """

    cross: CrossRide
    sig_fit: RideSignals
    sig_test: RideSignals | None
    designs: tuple = (None, None)
    notes: tuple = ()
    domain: str = "power"
    assumptions: RideAssumptions = field(default_factory=RideAssumptions)
    settings: BalanceSettings = field(default_factory=BalanceSettings)
    recording: str = ""
    compare: str | None = None

    @property
    def error_unit(self) -> str:
        """The balance's residual unit: W, or N·m in the torque domain."""
        return "W" if self.domain == "power" else "N·m"


def ride_analysis(log_path, compare_path=None, *, assumptions: RideAssumptions = RideAssumptions(),
                  max_gap: float = GAP_POLICY.bridge, domain: str = "power", n_boot: int = 200,
                  seed: int = 0, progress: Callable[[str], None] | None = None) -> RideAnalysis:
    """Diagnose a ride's longitudinal balance.

    Fits the inertia-only and the augmented balance on ``log_path`` and measures both on
    ``compare_path`` (without one: the first half fits, the second tests).  ``max_gap`` as
    :func:`ride_signals`, ``n_boot`` and ``seed`` as :func:`fit_balance`, the rest
    :class:`BalanceSettings`' defaults; ``progress`` is called with a short line at each step.
    """
    settings = BalanceSettings(max_gap=max_gap, n_boot=n_boot, seed=seed)
    rate, window, polyorder, block_s = settings.rate, settings.window, settings.polyorder, settings.block_s
    with one_blas_thread():
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
            notes.append(f"{fit_label} gives only {blocks:.1f} bootstrap blocks of {block_s:g} s: the 95 % "
                         f"intervals are rough (fewer than {FEW_BLOCKS} blocks); a longer ride gives "
                         f"firmer ones")
            warnings.warn(notes[-1], stacklevel=2)
        return RideAnalysis(cross=cr, sig_fit=sig_fit, sig_test=sig_test,
                            designs=(d_all, None if sig_test is None else d_test), notes=tuple(notes),
                            domain=domain, assumptions=assumptions,
                            settings=settings,
                            recording=log_path.name, compare=None if compare_path is None else compare_path.name)


def check_data(log_path, compare_path=None, *, domain: str = "power") -> None:
    """Fail early, naming the file, on a log :func:`ride_analysis` cannot use: the fit part must hold
    enough rows for the bootstrap (:func:`block_rows`); the rows it counts do not depend on mass or radius."""
    sig_fit = ride_signals(log_path)
    sig_test = None if compare_path is None else ride_signals(compare_path)
    _, d_fit, d_test, _, _ = _fit_and_test(sig_fit, sig_test, log_path, compare_path, domain)
    block_rows(d_fit, BalanceSettings.block_s)
    if len(d_test.P) == 0:
        raise InputError(f"{d_test.path}: no usable rows to test on")


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

"""The battery's internal resistance of one ride, normalised to 25 °C, and a health verdict.

The resistance is the drivetrain's ``internal_resistance`` term
(:func:`euc_sim.rides.drive.drivetrain.fit_battery`: V = E₀ − k_Q·Q − R_int·I); this module
adds its Arrhenius normalisation to 25 °C (:func:`to_25C`), a verdict in a rider's words
against a new pack of the spec's layout (:meth:`PackSpec.expected`: cells from
``data/cells.csv`` plus interconnects, BMS and leads) and the trend across rides
(:func:`trend_words`).  EUC World's sag-compensation setting is shown for comparison only.
See docs/summary.md.
"""

from __future__ import annotations

import csv
import math
import re
from dataclasses import dataclass
from functools import lru_cache
from importlib.resources import files

__all__ = ["PackSpec", "BatteryHealth", "CellFigures", "pack_spec", "cell_figures", "to_25C",
           "battery_health", "battery_health_of", "measure_resistance", "health_verdict",
           "trend_words", "EA_J_PER_MOL", "AGED_RATIO", "SOC_SPREAD", "INTERCONNECT_OHM", "FIXED_OHM"]

#: Activation energy of the cell's DC resistance, J/mol (Arrhenius normalisation; docs/summary.md).
EA_J_PER_MOL = 20_000.0
GAS_CONSTANT = 8.314462618       # J/(mol·K)
T25_K = 298.15
#: A ride's interval overlapping the new pack's range but reaching above this × its upper end
#: cannot tell a new pack from one 30 % worn: "cannot tell".
AGED_RATIO = 1.3
#: A cell's DC resistance over a ride's charge range against its mid-charge figure, up to: the
#: 50S's pulse test gives 14.2 mΩ at mid-charge and 20.0 mΩ full (tayvoy.com), ×1.4.
SOC_SPREAD = 1.4
#: Per series step, the welds, nickel strips or busbars between cell groups, Ω (an allowance
#: of 0.2-1.0 mΩ a step: a few 0.1 mΩ of strip and weld per joint; our estimate, not a datasheet).
INTERCONNECT_OHM = (0.2e-3, 1.0e-3)
#: Once per pack: BMS MOSFETs, fuse, connectors and leads, Ω (our estimate, not a datasheet).
FIXED_OHM = (5e-3, 30e-3)


@dataclass(frozen=True)
class CellFigures:
    """One cell's published figures (``data/cells.csv``): name, capacity (mAh), DC (pulse,
    mid-charge) resistance (Ω), and their source.
    """

    cell: str
    capacity_mAh: float | None
    dc_ohm: float | None
    source: str


@lru_cache(maxsize=1)
def _cells() -> tuple[tuple[tuple[str, ...], CellFigures], ...]:
    text = files("euc_sim.rides.drive").joinpath("data", "cells.csv").read_text(encoding="utf-8")
    num = (lambda x, k=1.0: float(x) * k if x else None)
    return tuple((tuple(a.upper() for a in r["aliases"].split(";") if a),
                  CellFigures(r["cell"], num(r["capacity_mAh"]), num(r["dc_mohm"], 1e-3), r["source"]))
                 for r in csv.DictReader(text.splitlines()))


def cell_figures(text: str) -> CellFigures | None:
    """The figures of the cell a spec names (``SAMSUNG 50S (21700) li-ion``), or None."""
    up = str(text).upper()
    for aliases, fig in _cells():
        if any(re.search(rf"(?<![A-Z0-9]){re.escape(a)}(?![A-Z0-9])", up) for a in aliases):
            return fig
    return None


@dataclass(frozen=True)
class PackSpec:
    """The battery pack as its specification gives it: cells in ``series`` and ``parallel``,
    the ``cell`` model, one cell's DC resistance (Ω; the spec's, else :func:`cell_figures`),
    ``energy_Wh`` and the wheel's ``name``.
    """

    series: int | None = None
    parallel: int | None = None
    cell: str = ""
    cell_resistance_ohm: float | None = None
    energy_Wh: float | None = None
    name: str = ""

    def expected(self) -> tuple[tuple[float, float] | None, str]:
        """The resistance of this pack when new, [lo, hi] Ω, and its source (or why none).

        lo = n_s·(R_cell/n_p + 0.2 mΩ) + 5 mΩ and hi = n_s·(1.4·R_cell/n_p + 1.0 mΩ) + 30 mΩ
        (:data:`SOC_SPREAD`, :data:`INTERCONNECT_OHM`, :data:`FIXED_OHM`).
        """
        if not (self.series and self.parallel):
            return None, "the spec gives no pack layout (cells in series and in parallel)"
        layout = f"{self.series}s{self.parallel}p"
        if self.cell_resistance_ohm:
            r, src = self.cell_resistance_ohm, f"{layout} of {self.cell or 'cells'} at the spec's cell resistance"
        else:
            fig = cell_figures(self.cell) if self.cell else None
            if fig is None or fig.dc_ohm is None:
                return None, (f"no resistance figure for the cell {fig.cell if fig else self.cell or '(not named)'}")
            r, src = fig.dc_ohm, f"{layout} of {fig.cell} ({fig.source})"
        n, p = self.series, self.parallel
        lo = n * (r / p + INTERCONNECT_OHM[0]) + FIXED_OHM[0]
        hi = n * (SOC_SPREAD * r / p + INTERCONNECT_OHM[1]) + FIXED_OHM[1]
        return (lo, hi), src + "; plus interconnects, BMS and leads (euc-sim's allowance)"


def pack_spec(spec) -> PackSpec | None:
    """The pack of a :class:`euc_sim.rides.source.spec.WheelSpec`; None without one or without a pack."""
    if spec is None or not (getattr(spec, "series", None) or getattr(spec, "cell", "")):
        return None
    return PackSpec(series=spec.series, parallel=spec.parallel, cell=spec.cell,
                    cell_resistance_ohm=spec.cell_resistance, energy_Wh=spec.energy_Wh, name=spec.name)


def to_25C(r_ohm: float, temp_C: float, ea: float = EA_J_PER_MOL) -> float:
    """A resistance measured at ``temp_C`` expressed at 25 °C, Ω: R₂₅ = R(T)·exp[−(E_a/R_gas)·(1/T − 1/T₂₅)]."""
    T = temp_C + 273.15
    return r_ohm * math.exp(-(ea / GAS_CONSTANT) * (1.0 / T - 1.0 / T25_K))


@dataclass(frozen=True)
class BatteryHealth:
    """The ``battery`` object of the ride JSON (Ω and °C).

    Attributes
    ----------
    resistance_ohm, resistance_ci95 : float, tuple or None
        As measured on the ride.
    temperature_C : float or None
        The battery's median logged temperature.
    resistance_25C_ohm, resistance_25C_ci95 : float, tuple or None
        Normalised to 25 °C; None without a temperature.
    per_cell_ohm : float or None
        One cell's share: resistance × parallel / series.
    expected_ohm, expected_source : tuple, str or None
        A new pack's [lo, hi] Ω and its source.
    app_setting_ohm : float or None
        EUC World's sag-compensation setting (comparison only).
    verdict, sentence, verdict_why : str
        :func:`health_verdict`'s verdict, the page's sentence, and why in one clause.
    """

    resistance_ohm: float | None
    resistance_ci95: tuple | None
    temperature_C: float | None
    resistance_25C_ohm: float | None
    resistance_25C_ci95: tuple | None
    per_cell_ohm: float | None
    expected_ohm: float | None
    expected_source: str | None
    app_setting_ohm: float | None
    verdict: str
    sentence: str
    verdict_why: str = ""


def health_verdict(r: float, ci, expected) -> tuple[str, str]:
    """A pack's resistance ``r`` (Ω, 95 % interval ``ci``) against a new one's [lo, hi], and why.

    ``"worn: +NN % resistance"`` when the interval lies above the range (NN against its upper
    end), ``"cannot tell"`` without a range or with an interval reaching past
    :data:`AGED_RATIO` × its upper end, else ``"as new"``.
    """
    if expected is None:
        return "cannot tell", "no resistance of a new pack to judge it against"
    lo, hi = expected
    a, b = ci if ci else (r, r)
    rng, got = f"the {1e3 * lo:.0f}–{1e3 * hi:.0f} mΩ of a new pack", f"its 95 % interval {1e3 * a:.0f}–{1e3 * b:.0f} mΩ"
    if a > hi:
        return f"worn: +{100 * (r / hi - 1):.0f} % resistance", f"{got} lies above {rng}"
    if b > AGED_RATIO * hi:
        return "cannot tell", f"{got} is too wide to tell {rng} from a worn one"
    return "as new", f"{got} {'lies below' if b < lo else 'overlaps'} {rng}"


def trend_words(values, cis) -> str:
    """The resistance from the first ride to the last, in a rider's words: unchanged where their
    95 % intervals overlap, else rising or falling by NN %.
    """
    n = len(values)
    (a0, b0), (a1, b1) = cis[0], cis[-1]
    if a1 <= b0 and a0 <= b1:
        return f"resistance unchanged across {n} rides"
    pct = 100 * (values[-1] / values[0] - 1)
    return f"{'rising' if pct > 0 else 'falling'}: {pct:+.0f} % from first to last".replace("-", "−")


def battery_health(r_ohm: float | None, ci95, temp_C: float | None = None,
                   pack: PackSpec | None = None, wheel_reported_ohm: float | None = None,
                   why: str | None = None) -> BatteryHealth:
    """The health verdict of one ride's ``internal_resistance`` ``r_ohm`` (Ω, with ``ci95``), at
    ``temp_C`` (°C, normalised to 25 °C where given), against ``pack``; ``why`` says why there
    is no resistance.
    """
    expected, source = pack.expected() if pack else (None, "no wheel specification given")
    if r_ohm is None or not math.isfinite(r_ohm) or r_ohm <= 0:
        return BatteryHealth(None, None, temp_C, None, None, None, expected,
                             source if expected else None, wheel_reported_ohm, "not measured",
                             why or "The ride does not give the battery's internal resistance.",
                             why or "the ride does not give the battery's internal resistance")
    r25 = to_25C(r_ohm, temp_C) if temp_C is not None else None
    ci25 = tuple(to_25C(x, temp_C) for x in ci95) if (temp_C is not None and ci95) else None
    per_cell = r_ohm * pack.parallel / pack.series if pack and pack.series and pack.parallel else None
    ref, ref_ci = (r25, ci25) if r25 is not None else (r_ohm, ci95)
    v, vwhy = health_verdict(ref, ref_ci, expected)
    if expected is None:
        vwhy = source
    s = f"Internal resistance {1e3 * ref:.0f} mΩ: {v} ({vwhy})"
    if r25 is not None:
        s += f" (at 25 °C; {1e3 * r_ohm:.0f} mΩ at the logged {temp_C:.0f} °C)."
    else:
        s += " (battery temperature not logged: not normalised to 25 °C)."
    if wheel_reported_ohm:
        s += f" EUC World's sag compensation is set to {1e3 * wheel_reported_ohm:.0f} mΩ."
    return BatteryHealth(r_ohm, tuple(ci95) if ci95 else None, temp_C, r25, ci25, per_cell,
                         expected, source if expected else None, wheel_reported_ohm, v, s, vwhy)


def measure_resistance(log, n_boot: int = 100, seed: int = 0) -> tuple[float, tuple | None]:
    """The drivetrain's ``internal_resistance`` of one log, Ω, with its 95 % interval (as ``euc-sim ride`` computes it)."""
    from euc_sim.rides.drive.drivetrain import charge_drawn, fit_battery  # deferred: loads scipy (1.1 s)
    from euc_sim.rides.grids.power import MassSettings, power_signals  # deferred: loads scipy (1.1 s)

    sig = power_signals(log, MassSettings(n_boot=n_boot, seed=seed))
    coef, ci = fit_battery(sig, charge_drawn(sig.t, sig.extra["current"]), n_boot, seed)
    return coef["R_int"], ci["R_int"]


def battery_health_of(term, counters=None, pack: PackSpec | None = None) -> BatteryHealth:
    """:func:`battery_health` of the drivetrain's ``internal_resistance`` ``term`` (or None), not
    recomputed, at the log's ``counters``' battery temperature."""
    temp = getattr(counters, "battery_temp_C", None)
    wheel = getattr(counters, "battery_circuit_ohm", None)
    est, ci, why = (None, None, None) if term is None else (term.estimate, term.ci95, term.why)
    return battery_health(est, ci, temp, pack, wheel, why)

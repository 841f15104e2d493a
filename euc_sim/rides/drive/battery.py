"""The battery's internal resistance of one ride, normalised to 25 °C, and a health verdict.

The resistance itself is the drivetrain's ``internal_resistance`` term
(:func:`euc_sim.rides.drive.drivetrain.fit_battery`: V = E₀ − k_Q·Q − R_int·I over the
ride, the voltage sag against current with the open-circuit voltage's fall with
charge taken out, and a moving-block bootstrap interval).  This module computes
no second resistance: it reads that one (from the ride JSON, or by calling the same
function) and adds

- the normalisation to 25 °C where the battery's temperature is logged
  (:func:`to_25C`, an Arrhenius law; docs/summary.md gives the source and the
  sensitivity), and
- a verdict against the pack's specification: the cell's resistance from the spec
  file's ``Cell resistance`` field scaled by its ``Battery architecture`` (NsMp);
  without it, the per-cell figure a rider can compare with the cell's data sheet.
  The resistance EUC World is set to use for its sag compensation
  (``euc.batteryCircuitResistance``, a setting, not a measurement) is shown beside
  it for comparison, never used as the specification.
"""

from __future__ import annotations

import math
import re
from dataclasses import asdict, dataclass

__all__ = ["PackSpec", "BatteryHealth", "pack_spec", "to_25C", "battery_health",
           "battery_health_from_report", "measure_resistance", "EA_J_PER_MOL", "WORN_RATIO", "AGED_RATIO"]

#: Activation energy of the cell's DC resistance, J/mol (Arrhenius normalisation; docs/summary.md).
EA_J_PER_MOL = 20_000.0
GAS_CONSTANT = 8.314462618       # J/(mol·K)
T25_K = 298.15
#: Resistance over the specified one at which the pack is called worn (a common end-of-life mark) ...
WORN_RATIO = 2.0
#: ... and aged.
AGED_RATIO = 1.3


@dataclass(frozen=True)
class PackSpec:
    """The battery pack as its specification gives it.

    Attributes
    ----------
    series, parallel : int or None
        Cells in series and in parallel (``Battery architecture| 20s2p``).
    cell : str
        The cell model as written.
    cell_resistance_ohm : float or None
        One cell's DC resistance (``Cell resistance| 15 mOhm``), Ω.
    energy_Wh : float or None
        The pack's energy (``Battery| 750 Wh``).
    """

    series: int | None = None
    parallel: int | None = None
    cell: str = ""
    cell_resistance_ohm: float | None = None
    energy_Wh: float | None = None

    @property
    def expected_ohm(self) -> float | None:
        """The pack's resistance from its cells, Ω (wiring and BMS not counted)."""
        if self.cell_resistance_ohm and self.series and self.parallel:
            return self.cell_resistance_ohm * self.series / self.parallel
        return None


def pack_spec(path) -> PackSpec | None:
    """Read the pack's fields of an EUC_core ``Field|Data`` spec file; None when unreadable."""
    try:
        rows = [ln.split("|", 1) for ln in open(path, encoding="utf-8").read().splitlines() if "|" in ln]
    except (OSError, UnicodeDecodeError):
        return None
    got = {k.strip().lower(): v.strip() for k, v in rows}
    arch = re.match(r"\s*(\d+)\s*s\s*(\d+)\s*p", got.get("battery architecture", ""), re.I)
    res = re.match(r"\s*([\d.]+)\s*(m?)\s*ohm", got.get("cell resistance", ""), re.I)
    wh = re.match(r"\s*([\d.]+)\s*wh", got.get("battery", ""), re.I)
    return PackSpec(series=int(arch.group(1)) if arch else None,
                    parallel=int(arch.group(2)) if arch else None,
                    cell=got.get("cells", ""),
                    cell_resistance_ohm=(float(res.group(1)) * (1e-3 if res.group(2) else 1.0)) if res else None,
                    energy_Wh=float(wh.group(1)) if wh else None)


def to_25C(r_ohm: float, temp_C: float, ea: float = EA_J_PER_MOL) -> float:
    """A resistance measured at ``temp_C`` expressed at 25 °C (Arrhenius), Ω.

    R(T) = R₂₅·exp[(E_a/R_gas)·(1/T − 1/T₂₅)], so R₂₅ = R(T)·exp[−(E_a/R_gas)·(1/T − 1/T₂₅)].
    """
    T = temp_C + 273.15
    return r_ohm * math.exp(-(ea / GAS_CONSTANT) * (1.0 / T - 1.0 / T25_K))


@dataclass(frozen=True)
class BatteryHealth:
    """The ``battery`` object of the ride JSON (Ω and °C; the page shows mΩ).

    Attributes
    ----------
    resistance_ohm, resistance_ci95 : float, tuple or None
        As measured on the ride (the drivetrain's ``internal_resistance``).
    temperature_C : float or None
        The battery's median logged temperature; None where not logged.
    resistance_25C_ohm, resistance_25C_ci95 : float, tuple or None
        Normalised to 25 °C; None without a battery temperature.
    per_cell_ohm : float or None
        The pack's resistance × parallel / series: one cell's share, Ω.
    expected_ohm : float or None
        The pack's resistance from its specification.
    expected_source : str or None
    app_setting_ohm : float or None
        The resistance EUC World's sag compensation is set to (for comparison only).
    verdict : str
        ``"as specified"``, ``"aged"``, ``"worn"``, ``"no specification"`` or ``"not measured"``.
    sentence : str
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

    def to_json(self) -> dict:
        """A JSON-ready dict."""
        out = asdict(self)
        for k in ("resistance_ci95", "resistance_25C_ci95"):
            out[k] = list(out[k]) if out[k] is not None else None
        return out


def _verdict(r: float, ci, expected: float | None, source: str | None) -> tuple[str, str]:
    if expected is None:
        return "no specification", (f"Internal resistance {1e3 * r:.0f} mΩ; the specification gives "
                                    f"no pack resistance to judge it against")
    lo = ci[0] if ci else r
    ratio = r / expected
    if lo > WORN_RATIO * expected:
        v = "worn"
    elif lo > AGED_RATIO * expected:
        v = "aged"
    else:
        v = "as specified"
    return v, (f"Internal resistance {1e3 * r:.0f} mΩ, {ratio:.1f}× the {1e3 * expected:.0f} mΩ of "
               f"{source}: {v}")


def battery_health(r_ohm: float | None, ci95, temp_C: float | None = None,
                   pack: PackSpec | None = None, wheel_reported_ohm: float | None = None,
                   why: str | None = None) -> BatteryHealth:
    """The health verdict of one ride's measured resistance.

    Parameters
    ----------
    r_ohm, ci95 : float, tuple
        The drivetrain's ``internal_resistance`` and its 95 % interval, Ω.
    temp_C : float, optional
        The battery's temperature during the ride, °C (normalises to 25 °C).
    pack : PackSpec, optional
    wheel_reported_ohm : float, optional
        The resistance EUC World's sag compensation is set to, Ω (shown for comparison).
    why : str, optional
        Why the resistance is not measured (when ``r_ohm`` is None).
    """
    if r_ohm is None or not math.isfinite(r_ohm) or r_ohm <= 0:
        return BatteryHealth(None, None, temp_C, None, None, None, None, None, wheel_reported_ohm,
                             "not measured", why or "The ride does not give the battery's internal resistance.")
    r25 = to_25C(r_ohm, temp_C) if temp_C is not None else None
    ci25 = tuple(to_25C(x, temp_C) for x in ci95) if (temp_C is not None and ci95) else None
    per_cell = r_ohm * pack.parallel / pack.series if pack and pack.series and pack.parallel else None
    expected, source = (pack.expected_ohm, f"{pack.series}s{pack.parallel}p of {pack.cell or 'cells'} "
                                           f"(spec)") if pack and pack.expected_ohm else (None, None)
    ref, ref_ci = (r25, ci25) if r25 is not None else (r_ohm, ci95)
    v, s = _verdict(ref, ref_ci, expected, source)
    if r25 is not None:
        s += f" (at 25 °C; {1e3 * r_ohm:.0f} mΩ at the logged {temp_C:.0f} °C)."
    else:
        s += " (battery temperature not logged: not normalised to 25 °C)."
    if wheel_reported_ohm:
        s += f" EUC World's sag compensation is set to {1e3 * wheel_reported_ohm:.0f} mΩ."
    return BatteryHealth(r_ohm, tuple(ci95) if ci95 else None, temp_C, r25, ci25, per_cell,
                         expected, source, wheel_reported_ohm, v, s)


def measure_resistance(log, n_boot: int = 100, seed: int = 0) -> tuple[float, tuple | None]:
    """The drivetrain's ``internal_resistance`` of one log, Ω, with its 95 % interval.

    The same computation ``euc-sim ride`` reports (:func:`euc_sim.rides.drive.drivetrain.fit_battery`
    on :func:`euc_sim.rides.grids.power.power_signals`), for commands that read many logs.
    """
    from euc_sim.rides.drive.drivetrain import fit_battery
    from euc_sim.rides.grids.power import MassSettings, power_signals

    sig = power_signals(log, MassSettings(n_boot=n_boot, seed=seed))
    coef, ci = fit_battery(sig, n_boot, seed)
    return coef["R_int"], ci["R_int"]


def battery_health_from_report(drivetrain: dict | None, log=None, counters=None,
                               pack: PackSpec | None = None) -> BatteryHealth:
    """:func:`battery_health` of the ride JSON's ``drivetrain.internal_resistance`` (not recomputed)."""
    term = (drivetrain or {}).get("internal_resistance") or {}
    temp = getattr(counters, "battery_temp_C", None)
    wheel = getattr(counters, "battery_circuit_ohm", None)
    return battery_health(term.get("estimate"), term.get("ci95"), temp, pack, wheel, term.get("why"))

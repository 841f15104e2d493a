"""A wheel maker's specification: the few numbers a ride analysis can use.

The format is that of EUC_core's ``specs/MODEL.csv``: a header ``Field|Data`` and
one ``Field| value unit`` row per line, e.g.::

    Field|Data
    Brand| InMotion
    Model| V9
    Wheel diameter| 16 inches
    Net weight| 23.5 kg
    Tension| 84 V

Four fields are read: ``Wheel diameter`` (inches, converted to the
wheel's radius in m), ``Net weight`` (kg, the wheel without rider),
``Tension`` (the battery's full-charge voltage, V) and ``Max speed`` (km/h, the
maker's top speed, converted to m/s; a value that cannot be read is left out, not refused).  Every value can be given or
overridden on its own (:func:`wheel_spec`), so a ride without a spec still runs
and says what it could not pin down (:attr:`WheelSpec.missing`).
"""

from __future__ import annotations

import re
from dataclasses import dataclass, replace
from pathlib import Path

from euc_sim.errors import BadInputFile

__all__ = ["SpecError", "WheelSpec", "read_spec", "wheel_spec", "INCH"]

INCH = 0.0254     # inch -> m

#: Spec field -> (attribute, unit word expected after the number, factor to SI).
_FIELDS = {
    "wheel diameter": ("radius", ("inch", "inches", '"', "in"), INCH / 2.0),
    "net weight": ("wheel_mass", ("kg",), 1.0),
    "tension": ("battery_voltage", ("v",), 1.0),
    "max speed": ("top_speed", ("km/h", "km"), 1.0 / 3.6),
}


class SpecError(BadInputFile):
    """A specification that cannot be used; the message names the file and the field."""


@dataclass(frozen=True)
class WheelSpec:
    """What the analysis takes from a wheel's specification.

    Attributes
    ----------
    radius : float or None
        Wheel (tyre) radius, m: half the nominal wheel diameter.
    wheel_mass : float or None
        The wheel's net weight, kg.
    battery_voltage : float or None
        Full-charge battery voltage, V (the maker's "Tension").
    top_speed : float or None
        The maker's top speed, m/s ("Max speed").
    name : str
        Brand and model, or the file name.
    source : str
        Where the numbers came from.
    """

    radius: float | None = None
    wheel_mass: float | None = None
    battery_voltage: float | None = None
    top_speed: float | None = None
    name: str = ""
    source: str = "none"

    @property
    def missing(self) -> tuple[str, ...]:
        """Fields still unknown, by attribute name."""
        return tuple(k for k in ("radius", "wheel_mass", "battery_voltage")
                     if getattr(self, k) is None)

    def as_json(self) -> dict:
        """Plain dict for the ride JSON (SI units)."""
        return {"radius_m": self.radius, "wheel_mass_kg": self.wheel_mass,
                "battery_voltage_V": self.battery_voltage, "top_speed_mps": self.top_speed, "name": self.name,
                "source": self.source, "missing": list(self.missing)}


_LABEL = {"radius": "Wheel diameter", "wheel_mass": "Net weight", "battery_voltage": "Tension",
          "top_speed": "Max speed"}


def _check_range(where: str, attr: str, value: float) -> None:
    """Refuse a value no wheel has (:data:`euc_sim.rides.source.sanity.SPEC_RANGE`), naming it."""
    from euc_sim.rides.source.sanity import SPEC_RANGE

    lo, hi, unit = SPEC_RANGE[attr]
    if not lo <= value <= hi:
        shown = (f"{2 * value / INCH:.3g} inches (radius {value:.3g} m)" if attr == "radius"
                 else f"{value:g} {unit}")
        raise SpecError(f"{where}: {shown} is no electric unicycle's {attr.replace('_', ' ')} "
                        f"(expected {lo:g}–{hi:g} {unit})")


def _number(path, field: str, text: str, units: tuple[str, ...]) -> float:
    m = re.match(r"\s*([0-9]+(?:[.,][0-9]+)?)\s*([A-Za-z\"]*)", text)
    if not m:
        raise SpecError(f"{path}: field {field!r}: expected a number with unit "
                        f"{units[0]!r}, got {text.strip()!r}")
    value = float(m.group(1).replace(",", "."))
    unit = m.group(2).lower()
    if unit and unit not in units:
        raise SpecError(f"{path}: field {field!r}: expected the unit {units[0]!r}, "
                        f"got {unit!r} in {text.strip()!r}")
    if not value > 0:
        raise SpecError(f"{path}: field {field!r}: expected a positive value, got {value:g}")
    return value


def read_spec(path) -> WheelSpec:
    """Read a ``Field|Data`` specification file.

    Parameters
    ----------
    path : str or path

    Returns
    -------
    WheelSpec
        With ``radius`` (m), ``wheel_mass`` (kg), ``battery_voltage`` (V).

    Raises
    ------
    SpecError
        (a ``ValueError``) naming the file and the field: not a text file, no
        ``Field|Data`` header, a field without a number, or no ``Net weight``
        (the one field the rider's own mass needs).
    FileNotFoundError
        when the file does not exist.
    """
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"{path}: no such file")
    try:
        lines = path.read_text(encoding="utf-8").splitlines()
    except UnicodeDecodeError as exc:
        raise SpecError(f"{path}: not a text specification file ({exc.reason})") from None
    rows = [ln.split("|", 1) for ln in lines if ln.strip()]
    if not rows or [c.strip().lower() for c in rows[0]] != ["field", "data"]:
        raise SpecError(f"{path}: expected the header 'Field|Data' (EUC_core specs format), "
                        f"got {lines[0].strip()[:40]!r}" if lines else f"{path}: empty file")
    got: dict[str, float] = {}
    names = {}
    for row in rows[1:]:
        if len(row) != 2:
            raise SpecError(f"{path}: expected 'Field| value', got {row[0].strip()[:40]!r}")
        key, text = row[0].strip().lower(), row[1]
        if key in ("brand", "model"):
            names[key] = text.strip()
        if key in _FIELDS:
            attr, units, factor = _FIELDS[key]
            try:
                got[attr] = _number(path, row[0].strip(), text, units) * factor
                _check_range(f"{path}: field {_LABEL[attr]!r}", attr, got[attr])
            except SpecError:
                if attr != "top_speed":         # the top speed only bounds what the page says: left out
                    raise
                got.pop(attr, None)
    if "wheel_mass" not in got:
        raise SpecError(f"{path}: field 'Net weight': missing (expected e.g. 'Net weight| 23.5 kg')")
    name = " ".join(names.get(k, "") for k in ("brand", "model")).strip() or path.stem
    return WheelSpec(name=name, source=str(path), **got)


def wheel_spec(path=None, *, radius: float | None = None, wheel_mass: float | None = None,
               battery_voltage: float | None = None) -> WheelSpec:
    """A spec from a file (optional) with single values given or overridden.

    Parameters
    ----------
    path : str or path, optional
        A ``Field|Data`` file (:func:`read_spec`).
    radius, wheel_mass, battery_voltage : float, optional
        m, kg, V; each replaces the file's value.

    Raises
    ------
    SpecError
        for a non-positive override, naming it.
    """
    spec = read_spec(path) if path is not None else WheelSpec()
    over = {}
    for key, val in (("radius", radius), ("wheel_mass", wheel_mass),
                     ("battery_voltage", battery_voltage)):
        if val is None:
            continue
        if not (val == val and 0 < val < float("inf")):
            raise SpecError(f"wheel {key}: expected a positive number, got {val!r}")
        _check_range(f"--{key.replace('_', '-')}", key, float(val))
        over[key] = float(val)
    if over:
        src = spec.source if spec.source != "none" else ""
        spec = replace(spec, source=(src + " + command line").lstrip(" +"), **over)
    return spec

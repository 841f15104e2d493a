"""A wheel maker's specification: the few numbers a ride analysis can use.

The format is EUC_core's ``specs/MODEL.csv``: a ``Field|Data`` header and one
``Field| value unit`` row a line (``Wheel diameter| 16 inches``, ``Net weight| 23.5 kg``,
``Tension| 84 V``; optionally ``Max speed``, ``Motor power``, ``Battery``, ``Battery
architecture`` ``20s2p``, ``Cells``, ``Tire dimension``, ``Cell resistance``).  Each of
the first three can be given or overridden alone (:func:`wheel_spec`); what is still
unknown is :attr:`WheelSpec.missing`.  ``data/wheels.csv`` ships the makers' figures of
the shared rides' wheels, found by name or alias (:func:`find_wheel`).
"""

from __future__ import annotations

import csv
import re
from dataclasses import dataclass, replace
from functools import lru_cache
from importlib.resources import files
from pathlib import Path

import numpy as np

from euc_sim.errors import BadInputFile

__all__ = ["SpecError", "WheelSpec", "read_spec", "wheel_spec", "find_wheel", "known_wheels",
           "log_contradictions", "INCH", "SPEC_RANGE", "CELL_V_RANGE", "CELL_V_IMPOSSIBLE",
           "TOP_SPEED_MARGIN"]

INCH = 0.0254     # inch -> m
KMH = 1 / 3.6     # km/h -> m/s

#: Spec field -> (attribute, unit words expected after the number, factor to SI).
_FIELDS = {
    "wheel diameter": ("radius", ("inch", "inches", '"', "in"), INCH / 2.0),
    "net weight": ("wheel_mass", ("kg",), 1.0),
    "tension": ("battery_voltage", ("v",), 1.0),
    "max speed": ("top_speed", ("km/h", "kmh", "km"), KMH),
    "motor power": ("motor_power", ("w",), 1.0),
    "battery": ("energy_Wh", ("wh",), 1.0),
    "cell resistance": ("cell_resistance", ("mohm", "mω", "ohm", "ω"), 1.0),
}
#: Plausible values of a wheel's spec: attribute -> (low, high, unit).
SPEC_RANGE = {"radius": (0.1, 0.4, "m"), "wheel_mass": (5.0, 100.0, "kg"),
              "battery_voltage": (24.0, 250.0, "V"), "top_speed": (10.0 / 3.6, 250.0 / 3.6, "m/s")}
#: A Li-ion cell's voltage over a ride, V: from empty under load (2.5) to just above full (4.25).
CELL_V_RANGE = (2.5, 4.25)
#: The log's 99th-percentile voltage per cell outside this, V: the spec's voltage class is impossible.
CELL_V_IMPOSSIBLE = (3.4, 4.35)
#: The log's wheel speed (99.9th percentile) above this × the spec's top speed contradicts it.
TOP_SPEED_MARGIN = 1.15


class SpecError(BadInputFile):
    """A specification that cannot be used; the message names the file and the field."""


@dataclass(frozen=True)
class WheelSpec:
    """What the analysis takes from a wheel's specification.

    Attributes
    ----------
    radius : float or None
        Wheel radius, m (half the nominal diameter).
    wheel_mass : float or None
        Net weight, kg.
    battery_voltage : float or None
        Full-charge battery voltage ("Tension"), V.
    name, source : str
        Brand and model (or the file name); where the numbers came from.
    top_speed : float or None
        The maker's top speed, m/s.
    motor_power, energy_Wh : float or None
        Rated motor power, W; pack energy, Wh.
    series, parallel : int or None
        Cells in series and in parallel (``20s2p``).
    cell, tyre : str
        Cell model and tyre, as written.
    cell_resistance : float or None
        One cell's DC resistance, Ω.
    """

    radius: float | None = None
    wheel_mass: float | None = None
    battery_voltage: float | None = None
    name: str = ""
    source: str = "none"
    top_speed: float | None = None
    motor_power: float | None = None
    energy_Wh: float | None = None
    series: int | None = None
    parallel: int | None = None
    cell: str = ""
    cell_resistance: float | None = None
    tyre: str = ""

    @property
    def n_series(self) -> int | None:
        """Cells in series: the layout's, else the full-charge voltage over 4.2 V (rounded)."""
        if self.series:
            return self.series
        return round(self.battery_voltage / 4.2) if self.battery_voltage else None

    @property
    def missing(self) -> tuple[str, ...]:
        """Fields still unknown, by attribute name."""
        return tuple(k for k in ("radius", "wheel_mass", "battery_voltage")
                     if getattr(self, k) is None)


_LABEL = {"radius": "Wheel diameter", "wheel_mass": "Net weight", "battery_voltage": "Tension",
          "top_speed": "Max speed"}


def _check_range(where: str, attr: str, value: float) -> None:
    """Refuse a value no wheel has (:data:`SPEC_RANGE`), naming it."""
    lo, hi, unit = SPEC_RANGE[attr]
    if not lo <= value <= hi:
        shown = (f"{2 * value / INCH:.3g} inches (radius {value:.3g} m)" if attr == "radius"
                 else f"{value:g} {unit}")
        raise SpecError(f"{where}: {shown} is no electric unicycle's {attr.replace('_', ' ')} "
                        f"(expected {lo:g}–{hi:g} {unit})")


def _number(path, field: str, text: str, units: tuple[str, ...]) -> float:
    m = re.match(r"\s*([0-9]+(?:[.,][0-9]+)?)\s*([A-Za-z\"/Ωω]*)", text)
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
    return value * (1e-3 if unit in ("mohm", "mω") else 1.0)


def _layout(where: str, text: str) -> tuple[int, int]:
    """``20s2p`` -> (20, 2), or a :class:`SpecError` naming ``where``."""
    m = re.fullmatch(r"\s*(\d+)\s*s\s*(\d+)\s*p\s*", text, re.I)
    if not m or not (1 <= int(m.group(1)) <= 60 and 1 <= int(m.group(2)) <= 20):
        raise SpecError(f"{where}: expected a pack layout such as '20s2p' (cells in series, "
                        f"in parallel), got {text.strip()!r}")
    return int(m.group(1)), int(m.group(2))


def read_spec(path) -> WheelSpec:
    """Read a ``Field|Data`` specification file into a :class:`WheelSpec` (SI units).

    Raises
    ------
    SpecError
        Naming file and field: not text, no header, a field without a number, no ``Net weight``.
    FileNotFoundError
        When the file does not exist.
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
        elif key == "battery architecture":
            got["series"], got["parallel"] = _layout(f"{path}: field {row[0].strip()!r}", text)
        elif key in ("cells", "tire dimension"):
            got["cell" if key == "cells" else "tyre"] = text.strip()
        if key in _FIELDS:
            attr, units, factor = _FIELDS[key]
            try:
                got[attr] = _number(path, row[0].strip(), text, units) * factor
            except SpecError:
                if attr in _LABEL and attr != "top_speed":    # the analysis needs these; the top
                    raise                                     # speed only bounds what the page says
    if "wheel_mass" not in got:
        raise SpecError(f"{path}: field 'Net weight': missing (expected e.g. 'Net weight| 23.5 kg')")
    for attr, val in list(got.items()):
        if attr in _LABEL:
            try:
                _check_range(f"{path}: field {_LABEL[attr]!r}", attr, val)
            except SpecError:
                if attr != "top_speed":
                    raise
                got.pop(attr)               # an unreadable top speed is left out, not refused
    name = " ".join(names.get(k, "") for k in ("brand", "model")).strip() or path.stem
    return WheelSpec(name=name, source=str(path), **got)


def _key(text: str) -> str:
    return re.sub(r"[\s_\-]+", " ", str(text).strip().lower())


@lru_cache(maxsize=1)
def _table() -> tuple[tuple[tuple[str, ...], WheelSpec], ...]:
    """The shipped wheels (``data/wheels.csv``): (names and aliases, spec) per row."""
    text = files("euc_sim.rides.source").joinpath("data", "wheels.csv").read_text(encoding="utf-8")
    out = []
    for r in csv.DictReader(text.splitlines()):
        num = {k: float(r[k]) if r[k] else None for k in ("wheel_diameter_in", "net_weight_kg",
               "pack_voltage_V", "capacity_Wh", "top_speed_kmh", "motor_power_W")}
        series, parallel = _layout(f"wheels.csv: {r['name']}", r["pack_layout"]) if r["pack_layout"] else (None, None)
        name = f"{r['brand']} {r['model']}"
        spec = WheelSpec(radius=num["wheel_diameter_in"] * INCH / 2, wheel_mass=num["net_weight_kg"],
                         battery_voltage=num["pack_voltage_V"], name=name,
                         source=f"euc-sim's wheel table: {name} ({r['source']})",
                         top_speed=num["top_speed_kmh"] * KMH if num["top_speed_kmh"] else None,
                         motor_power=num["motor_power_W"], energy_Wh=num["capacity_Wh"],
                         series=series, parallel=parallel, cell=r["cell"], tyre=r["tyre"])
        keys = (r["name"], name, r["model"], *r["aliases"].split(";"))
        out.append((tuple(dict.fromkeys(_key(k) for k in keys if k.strip())), spec))
    return tuple(out)


def known_wheels() -> list[str]:
    """The shipped wheels' short names (``v9``, ``lynx``, ...)."""
    return [keys[0] for keys, _ in _table()]


def find_wheel(name: str) -> WheelSpec | None:
    """The shipped spec of the wheel named ``name`` (case, spaces, ``-`` and ``_`` ignored), or None."""
    k = _key(name)
    return next((spec for keys, spec in _table() if k in keys), None)


def _resolve(arg) -> WheelSpec:
    """``--wheel``'s argument: an existing file, else a shipped wheel's name or alias."""
    path = Path(arg)
    if path.is_file():
        return read_spec(path)
    spec = find_wheel(str(arg))
    if spec is not None:
        return spec
    names = ", ".join(known_wheels())
    if path.suffix or "/" in str(arg) or "\\" in str(arg):
        raise FileNotFoundError(f"--wheel {arg}: no such file (or name a shipped wheel: {names})")
    raise SpecError(f"--wheel {arg!r}: no such wheel; known wheels: {names} (or give a spec file)")


def wheel_spec(path=None, *, radius: float | None = None, wheel_mass: float | None = None,
               battery_voltage: float | None = None) -> WheelSpec:
    """A spec from a file or a shipped wheel's name (optional) with single values given or overridden.

    Parameters
    ----------
    path : str or path, optional
        A ``Field|Data`` file, or a shipped wheel's name or alias (``v9``).
    radius, wheel_mass, battery_voltage : float, optional
        m, kg, V; each replaces the file's value (checked by
        :func:`euc_sim.rides.request.ride_request` against :data:`SPEC_RANGE`).

    Raises
    ------
    SpecError
        An unknown wheel name.
    FileNotFoundError
        A path (with a suffix or a folder) that does not exist.
    """
    spec = _resolve(path) if path is not None else WheelSpec()
    over = {key: float(val) for key, val in (("radius", radius), ("wheel_mass", wheel_mass),
                                             ("battery_voltage", battery_voltage)) if val is not None}
    if over:
        src = spec.source if spec.source != "none" else ""
        spec = replace(spec, source=(src + " + command line").lstrip(" +"), **over)
    return spec


def log_contradictions(spec: WheelSpec, data) -> list[str]:
    """Where a ride's log contradicts its spec, one sentence each.

    The log's voltage (1st/99th percentiles) outside n_series × :data:`CELL_V_RANGE`, or its
    speed (99.9th percentile, ``data["v"]`` m/s) above :data:`TOP_SPEED_MARGIN` × the top
    speed.  A voltage class the pack cannot have (:data:`CELL_V_IMPOSSIBLE` a cell) raises
    :class:`SpecError`.
    """
    out = []
    n = spec.n_series
    what = f"the spec's {spec.name or 'wheel'}"
    if n and "voltage" in data:
        v = data["voltage"].to_numpy(float)
        v = v[np.isfinite(v) & (v > 0)]
        if v.size:
            lo, hi = (float(x) for x in np.percentile(v, [1, 99]))
            layout = f"{n} cells in series" + (f", {spec.battery_voltage:g} V full" if spec.battery_voltage else "")
            if not CELL_V_IMPOSSIBLE[0] * n <= hi <= CELL_V_IMPOSSIBLE[1] * n:
                raise SpecError(f"the log's battery voltage ({lo:.0f}-{hi:.0f} V) cannot be {what} pack "
                                f"({layout}: {hi / n:.2f} V a cell at the ride's highest); another "
                                f"wheel's spec? give the right --wheel")
            if lo < CELL_V_RANGE[0] * n or hi > CELL_V_RANGE[1] * n:
                out.append(f"battery voltage {lo:.0f}-{hi:.0f} V outside {what} pack's "
                           f"{CELL_V_RANGE[0] * n:.0f}-{CELL_V_RANGE[1] * n:.0f} V ({layout}): "
                           f"the spec may be another wheel's")
    if spec.top_speed and "v" in data:
        s = data["v"].to_numpy(float)
        s = s[np.isfinite(s)]
        if s.size and (top := float(np.percentile(s, 99.9))) > TOP_SPEED_MARGIN * spec.top_speed:
            out.append(f"the wheel ran at {top * 3.6:.0f} km/h, more than {TOP_SPEED_MARGIN - 1:.0%} above "
                       f"{what} top speed of {spec.top_speed * 3.6:.0f} km/h: the spec may be another wheel's")
    return out

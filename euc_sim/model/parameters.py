"""Model parameters of the EUC-rider system (the paper's Table 3): one immutable, validated
object; m, kg, kg·m², m/s² (:data:`UNITS`, :data:`DESCRIPTION`).
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import Any, Mapping

from euc_sim.errors import InputError

#: Parameters that describe an offset or an inertia which the reduced 2-DoF model
#: (Section 3.2) sets to zero; they may be zero but not negative.
MAY_BE_ZERO = frozenset({"J0", "h0", "l0"})

UNITS = {
    "R": "m", "m": "kg", "m0": "kg", "mw": "kg", "J": "kg·m²", "Jw": "kg·m²",
    "J0": "kg·m²", "h0": "m", "l0": "m", "h": "m", "g": "m/s²",
}

DESCRIPTION = {
    "R": "wheel radius",
    "m": "rider's mass",
    "m0": "EUC body's mass",
    "mw": "wheel's mass",
    "J": "rider's mass moment of inertia about G",
    "Jw": "wheel's mass moment of inertia about C",
    "J0": "EUC body's mass moment of inertia about G0",
    "h0": "distance C-G0 (EUC body's centre of gravity above the wheel centre)",
    "l0": "distance A-C (ankle hinge below the wheel centre)",
    "h": "distance A-G (rider's centre of gravity above the ankle)",
    "g": "gravitational acceleration",
}


#: Plausible range of each parameter for an EUC with a human rider, in :data:`UNITS`
#: (:func:`check_plausible`).
PLAUSIBLE = {
    "R": (0.05, 0.5), "m": (30.0, 200.0), "m0": (1.0, 150.0), "mw": (0.2, 50.0),
    "J": (0.1, 100.0), "Jw": (1e-3, 5.0), "J0": (0.0, 20.0), "h0": (0.0, 0.5),
    "l0": (0.0, 0.5), "h": (0.05, 2.5), "g": (1.0, 30.0),
}


class ParameterError(InputError):
    """An invalid model parameter; the message names it and its value."""


@dataclass(frozen=True)
class Params:
    """Parameters of the 3-DoF model, Table 3 of the paper (``h`` defaults to 0.6 m).

    Attributes: R, m, m0, mw, J, Jw, J0, h0, l0, h, g as in :data:`DESCRIPTION`, units
    :data:`UNITS`.  ``ParameterError`` (a ``ValueError``) for a non-finite or negative value,
    or zero for anything but J0, h0, l0.
    """

    R: float = 0.2
    m: float = 65.0
    m0: float = 13.0
    mw: float = 3.0
    J: float = 16.6
    Jw: float = 0.12
    J0: float = 0.5
    h0: float = 0.075
    l0: float = 0.05
    h: float = 0.6
    g: float = 9.81

    def __post_init__(self) -> None:
        for f in dataclasses.fields(self):
            value = getattr(self, f.name)
            try:
                value = float(value)
            except (TypeError, ValueError):
                raise ParameterError(
                    f"parameter {f.name!r} ({DESCRIPTION[f.name]}) must be a number, got {value!r}"
                ) from None
            if not math.isfinite(value):
                raise ParameterError(
                    f"parameter {f.name!r} ({DESCRIPTION[f.name]}) must be finite, got {value!r}"
                )
            if value < 0 or (value == 0 and f.name not in MAY_BE_ZERO):
                need = "non-negative" if f.name in MAY_BE_ZERO else "positive"
                raise ParameterError(
                    f"parameter {f.name!r} ({DESCRIPTION[f.name]}) must be {need}, "
                    f"got {value!r} {UNITS[f.name]}"
                )
            object.__setattr__(self, f.name, value)

    # -- derived quantities -------------------------------------------------
    @property
    def m_eq(self) -> float:
        """Equivalent translating mass m + m0 + mw + Jw/R², kg (eq. 13)."""
        return self.m + self.m0 + self.mw + self.Jw / self.R**2

    @property
    def total_mass(self) -> float:
        """m + m0 + mw, kg."""
        return self.m + self.m0 + self.mw

    def replace(self, **changes: Any) -> "Params":
        """A copy with some parameters changed (validated again); ``ParameterError`` for an unknown name."""
        unknown = sorted(set(changes) - set(names()))
        if unknown:
            raise ParameterError(
                f"unknown parameter {unknown[0]!r}; expected one of {', '.join(names())}"
            )
        return dataclasses.replace(self, **changes)

    def as_dict(self) -> dict[str, float]:
        """The parameters as a plain ``{name: value}`` dictionary."""
        return dataclasses.asdict(self)

    @classmethod
    def from_mapping(cls, values: Mapping[str, Any] | None) -> "Params":
        """Table 3 with the given entries overriding it; unknown names are an error."""
        return TABLE3.replace(**dict(values or {}))

    def reduced(self) -> "Params":
        """The reduced 2-DoF model's parameters: J0 = h0 = l0 = 0 (Section 3.2)."""
        return self.replace(J0=0.0, h0=0.0, l0=0.0)


def check_plausible(p: "Params", given: Mapping[str, Any] | None = None) -> "Params":
    """Refuse parameters outside :data:`PLAUSIBLE` (all, or only the names ``given``); returns
    ``p``, else ``ParameterError`` naming the parameter, its range and the value.
    """
    for name in (given if given is not None else names()):
        lo, hi = PLAUSIBLE[name]
        value = getattr(p, name)
        if not lo <= value <= hi:
            raise ParameterError(
                f"parameter {name!r} ({DESCRIPTION[name]}) must lie in [{lo:g}, {hi:g}] "
                f"{UNITS[name]} for an EUC with a rider, got {value:g} {UNITS[name]}")
    return p


def names() -> tuple[str, ...]:
    """Parameter names in Table 3's order."""
    return tuple(f.name for f in dataclasses.fields(Params))


#: The paper's Table 3 with h = 0.6 m.
TABLE3 = Params()

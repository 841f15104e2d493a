"""The catalog of physical effects: one record per effect, read by every layer.

An :class:`Effect` holds everything the package says about one physical effect (its
CONTRACT name, symbol, unit, bounds and plausible range) and its *faces*, ``None`` where
the effect has none:

================  ==========================================  =====================================
face              read by                                     holds
================  ==========================================  =====================================
``force``         simulation, diagnosis                       generalised force Q_e(value, p, q, q̇)
``balance``       rides.balance (fit), rides.sim (power)      regressor column, bounds, plausible
``conceal``       studies/conceal.py                          how a log hides it (a mechanism)
``compare``       rides.compare                               power signature, pair-fit column
``words``         rides.compare sentence, report.ride page     what a rider reads
================  ==========================================  =====================================

A face's callables take plain arrays or a namespace of arrays, so this module stays free
of the layers above; the records live in :mod:`euc_sim.simulation.effects`.  No code
branches on an effect's name: a layer reads the face it needs.

Adding an effect
----------------
Write one :class:`Effect` with the faces it has and add it to :data:`CATALOG`, in
:mod:`euc_sim.simulation.effects` beside the package's records (its place in that list is
its place among the balance's candidates, the pair fit's columns and the page's lines).
An electrical loss growing with speed, for example::

    Effect("motor_noload_loss", "c_nl", "W·s/m", "the motor's no-load loss c_nl·|v|, drawn from the battery",
           balance=Balance("c_nl", "W·s/m", "no-load loss c_nl·|v|", plausible=(0.0, 20.0),
                           source="where the range comes from", bounds=(0.0, 20.0), scale=1.0,
                           column="noload", column_unit="m/s", regressor=lambda b: b.L1(np.abs(b.v)),
                           electrical=lambda value, F, v: value * np.abs(v)),
           compare=Compare(signature=lambda s: np.abs(s.v), pair=lambda sh, m: sh["rolling"], order=6),
           conceal=Conceal("wheel_power", "W·s/m", lambda kin, size, **kw: size * np.abs(kin.v)),
           words=Words("no-load loss", "motor no-load loss", lambda c: c, " W·s/m", "{:.1f}", ...))

Then, with no other module edited:

- ``balance``: the ride's balance offers it as a candidate (its ``regressor`` column,
  fitted within ``bounds`` from ``nominal``, accepted within ``plausible``) and the ride
  JSON's ``parameters`` and ``effects`` carry it; with ``electrical``, the ride simulation
  adds its battery power;
- ``conceal``: ``conceal.conceal(raw, NAME, size)`` (studies/conceal.py) hides it;
- ``compare``: a pair of rides fits its difference (``pair``), its signature enters the
  alias table (``signature``), and with ``named`` a difference can be named;
- ``words``: the differences' sentence and the differences page say it;
- ``force`` and ``kind`` (the contract's simulator effects, ``effects.CATALOG``):
  ``--effect NAME=VALUE`` accepts it within ``bounds`` and the diagnosis fits its column
  (a force not linear in its estimate registers its estimate map in
  ``euc_sim.diagnosis.candidates.ESTIMATE_MAPS``).  The engines apply the contract's
  eight through their own mechanisms (held forces, tilted gravity, joint damping, h(t),
  the lateral profile): a new force needs its mechanism in ``simulation/engine.py``.

tests/rides/test_effect_record.py adds one record inside the test and follows it through.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Callable, Iterator, Literal

from euc_sim.errors import InputError

__all__ = ["Effect", "Balance", "Conceal", "Compare", "Words", "Catalog", "FaceView", "CATALOG", "G", "RHO_AIR"]

G = 9.81               # m/s²
RHO_AIR = 1.2          # kg/m³ at about 20 °C

Kind = Literal["external", "internal", "parameter", "measurement"]


@dataclass(frozen=True)
class Balance:
    """An effect's term in a ride's energy balance (:mod:`euc_sim.rides.balance.design`).

    Attributes
    ----------
    symbol, unit, meaning : str
        The fitted coefficient as the ride JSON states it.
    plausible : (float, float)
        Range of the estimate met in practice, in ``unit``; ``source`` says where from.
    bounds : (float, float)
        Bounds of the fit, in ``unit``.
    scale : float
        Typical size (the solver's ``x_scale``).
    role : {"column", "constant", "lag"}
        How the model applies it: a coefficient on the regressor ``column`` (W per unit),
        a constant power (W), or a first-order lag of the logged current (s).
    column, column_unit : str or None
        Name and unit of the regressor column (``role == "column"``).
    regressor : callable or None
        ``regressor(b) -> array | str``: the L₁-filtered column on a ride, from ``b`` with
        ``v`` (m/s, raw), ``mg`` (N), ``m_eq`` (kg), ``L1(x, deriv=0)`` (the short filter),
        ``gps_grade`` (sin α from GPS altitude, or None), ``sign_change`` (share of moving
        samples against the main direction) and ``sign_change_fraction`` (the share a
        constant grade needs); a str where the ride cannot offer it, saying why.
    aliases_when_absent : tuple of str
        Candidates that stand in for it when the ride cannot offer it (their estimate
        then holds it too).
    electrical : callable or None
        ``electrical(value, F, v) -> array``: the battery power it adds in the ride's
        simulation, W, from the motor's force F (N) and the speed v (m/s).
    to_contract : callable or None
        Estimate in the balance's unit → the record's contract unit (the simulator's).
    json_extra : callable or None
        ``json_extra(estimate, ci95) -> dict``: more fields of its ride-JSON entry (the
        same quantity in other units).
    nominal : float
        Its value where the assumed physics holds exactly, where the fit starts (0: absent).
    """

    symbol: str
    unit: str
    meaning: str
    plausible: tuple[float, float]
    source: str
    bounds: tuple[float, float]
    scale: float = 0.1
    role: Literal["column", "constant", "lag"] = "column"
    column: str | None = None
    column_unit: str | None = None
    regressor: Callable | None = None
    aliases_when_absent: tuple[str, ...] = ()
    electrical: Callable | None = None
    to_contract: Callable[[float], float] | None = None
    json_extra: Callable | None = None
    nominal: float = 0.0

    def __post_init__(self):
        if self.role not in ("column", "constant", "lag") or (self.role == "column") != (self.column is not None):
            raise ValueError(f"balance term {self.symbol}: role {self.role!r} with column {self.column!r}")


@dataclass(frozen=True)
class Conceal:
    """How a log conceals the effect (studies/conceal.py).

    Attributes
    ----------
    mechanism : str
        ``"wheel_power"`` (more power at the wheel: ``wheel_power(kin, size, **kw)`` W, from
        ``kin.v``, ``kin.a`` (m/s²) and ``kin.sin_grade``), ``"pack_resistance"``,
        ``"speed_scale"`` or ``"channel_delay"`` (the size said in ``unit``).
    unit : str
        Unit of the concealed size.
    wheel_power : callable or None
    """

    mechanism: Literal["wheel_power", "pack_resistance", "speed_scale", "channel_delay"]
    unit: str
    wheel_power: Callable | None = None


@dataclass(frozen=True)
class Compare:
    """How two rides' difference in the effect is tested (:mod:`euc_sim.rides.compare`).

    Attributes
    ----------
    signature : callable or None
        ``signature(s) -> array | None``: battery power per unit of the effect, W, from
        ``s`` with ``v`` (m/s), ``av`` (d/dt v²/2, W/kg), ``P`` (W), ``t`` (s), ``current``
        (A or None), ``climb`` (g·ḣ, W/kg, or None) and ``coef`` (LOG's ``total_mass``,
        ``rolling_resistance``, ``aerodynamic_drag``); None where the rides cannot show it.
    pair : callable or None
        ``pair(shared, m) -> array``: its column in the pair fit of battery power, from
        the shared energy-window columns (``inertia``, ``rolling``, ``drag``, ``copper``,
        ``grade``, ``no_load``) and LOG's mass m, kg.
    named : bool
        Whether a difference may be named (False: a nuisance of the pair fit).
    ratio : bool
        The difference is OTHER/LOG − 1 (a scale), not OTHER − LOG.
    coef : float or None
        LOG's value the signatures assume where LOG's list lacks it.
    order : int
        Position of its signature in the alias table (partners are listed in this order).
    view : str or None
        The ride JSON's key of a view of its difference (its ``independent`` detail).
    """

    signature: Callable | None = None
    pair: Callable | None = None
    named: bool = True
    ratio: bool = False
    coef: float | None = None
    order: int = 0
    view: str | None = None


@dataclass(frozen=True)
class Words:
    """What a rider reads about the effect.

    Attributes
    ----------
    word : str
        One word or two ("drag").
    label : str
        The page's name for it ("drag area").
    scale : callable
        The JSON's unit to the page's.
    unit, fmt : str
        The page's unit (with its leading space) and number format.
    more, less : str
        The page's words after the number, OTHER above or below LOG.
    hint, hint_less : str
        Why a rider would see it, OTHER above or below LOG.
    said : (str, str, str)
        The JSON sentence's words after the number (more, less) and its format, in the JSON's unit.
    meta : str or None
        The ``meta.csv`` column bearing on it.
    """

    word: str
    label: str
    scale: Callable[[float], float]
    unit: str
    fmt: str
    more: str
    less: str
    hint: str
    hint_less: str
    said: tuple[str, str, str]
    meta: str | None = None


@dataclass(frozen=True)
class Effect:
    """One physical effect.

    Attributes
    ----------
    name : str
        CONTRACT's name.
    symbol, unit : str
        The estimate's symbol and unit (CONTRACT's).
    physics : str
        One sentence: what acts, where.
    kind : {"external", "internal", "parameter", "measurement"} or None
        Where the simulator applies it: from outside the EUC–rider system, between its
        bodies, through a parameter, or on the recording; None: not the simulator's.
    kinematic_visible : bool
        Whether M_d,1 − M_d,2 (no torque measured) can reveal it.
    needs : tuple of str
        Recording columns needed beyond t, x, gamma, phi.
    plausible : (float, float)
        Magnitudes met in practice, in ``unit`` (blind studies, plausibility).
    hidden_because : str
        Why a recording without the ``needs`` columns cannot reveal it.
    bounds : (float, float)
        Values an injected effect may take (``--effect NAME=VALUE``), in ``unit``, and the
        diagnosis's validity range.
    force : callable or None
        ``force(value, p, q, qd, extra) -> Q``, the generalised force in the paper's
        coordinates (:func:`euc_sim.simulation.effects.generalized_force`).
    ref : float
        The diagnosis's reference magnitude of its candidate column.
    to_params : callable or None
        ``to_params(p, value) -> Params``: a parameter effect applied to the parameters.
    baseline : str or None
        The parameter (:class:`~euc_sim.model.parameters.Params` attribute) whose nominal value
        is the effect's "absent" value (``rider_mass``: ``m``); None: absent is 0.
    detect_range : (float, float) or None
        Magnitudes against which detection limits are judged (a deviation from the baseline
        where it has one); None: :attr:`plausible`.
    balance, conceal, compare, words
        The faces (see the module docstring); None where the effect has none.
    """

    name: str
    symbol: str
    unit: str
    physics: str
    kind: Kind | None = None
    kinematic_visible: bool = False
    needs: tuple[str, ...] = ()
    plausible: tuple[float, float] = (0.0, 0.0)
    hidden_because: str = ""
    bounds: tuple[float, float] = (0.0, 0.0)
    force: Callable | None = None
    ref: float = 1.0
    to_params: Callable | None = None
    baseline: str | None = None
    detect_range: tuple[float, float] | None = None
    balance: Balance | None = None
    conceal: Conceal | None = None
    compare: Compare | None = None
    words: Words | None = None


class Catalog:
    """The records by name, in the order added."""

    def __init__(self) -> None:
        self._by_name: dict[str, Effect] = {}

    def add(self, record: Effect) -> Effect:
        """Add (or replace) ``record``; returns it."""
        self._by_name[record.name] = record
        return record

    def remove(self, name: str) -> None:
        self._by_name.pop(name, None)

    def get(self, name: str) -> Effect:
        """The record called ``name``; ``InputError`` listing the valid ones otherwise."""
        try:
            return self._by_name[name]
        except KeyError:
            raise InputError(f"unknown effect {name!r}; valid effects: {', '.join(self._by_name)}") from None

    def __contains__(self, name) -> bool:
        return name in self._by_name

    def __iter__(self) -> Iterator[Effect]:
        return iter(tuple(self._by_name.values()))

    def absent_value(self, name: str, params) -> float:
        """The value of ``name`` that means "no effect": its baseline parameter's, else 0."""
        e = self.get(name)
        return 0.0 if e.baseline is None else float(getattr(params, e.baseline))

    def having(self, face: str) -> tuple[Effect, ...]:
        """The records whose ``face`` is set (``"balance"``, ``"conceal"``, ...)."""
        return tuple(e for e in self if getattr(e, face) is not None)

    def names(self, face: str | None = None) -> tuple[str, ...]:
        return tuple(e.name for e in (self if face is None else self.having(face)))

    def view(self, face: str, read: Callable = lambda f: f) -> "FaceView":
        """Name -> ``read(record.<face>)`` over the records with that face, read live."""
        return FaceView(self, face, read)


class FaceView(Mapping):
    """A live mapping name -> ``read(face)`` of a :class:`Catalog`'s records that have ``face``:
    a record added later is in it at once."""

    def __init__(self, catalog: Catalog, face: str, read: Callable):
        self._catalog, self._face, self._read = catalog, face, read

    def __getitem__(self, name):
        f = getattr(self._catalog.get(name), self._face) if name in self._catalog else None
        if f is None:
            raise KeyError(name)
        return self._read(f)

    def __iter__(self):
        return iter(self._catalog.names(self._face))

    def __len__(self):
        return len(self._catalog.having(self._face))


#: The package's catalog (its records: :mod:`euc_sim.simulation.effects`).
CATALOG = Catalog()

"""The validated request of a ride analysis: what ``euc-sim ride`` and :func:`euc_sim.analyse_ride` both build.

:func:`ride_request` checks every option (each number against its bound in :data:`BOUNDS`, the
domain, the rider weights), resolves the wheel's spec, reads each log once and refuses a log the
analysis cannot use, all before any output exists; :func:`~euc_sim.rides.pipeline.ride_pipeline`
takes the :class:`RideRequest` it returns.  Bad input raises :class:`~euc_sim.errors.InputError`
(``OSError`` for a missing file) with one line naming the parameter as ``euc-sim ride`` spells it
(``--n-boot`` for ``n_boot``), so the command and the API refuse a bad request with the same line.
The command declares its numeric options with :data:`BOUNDS` (``--help`` states them) and leaves
their check to :func:`ride_request`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from numbers import Real
from typing import TYPE_CHECKING

from euc_sim.errors import InputError
from euc_sim.model.parameters import TABLE3
from euc_sim.rides.source.sanity import TOTAL_MASS_RANGE
from euc_sim.rides.source.spec import SPEC_RANGE, SpecError, WheelSpec, log_contradictions, wheel_spec

if TYPE_CHECKING:
    from euc_sim.rides.grids.signals import RideAssumptions
    from euc_sim.rides.source.ride import Ride

__all__ = ["RideRequest", "ride_request", "MIN_BOOT", "BOUNDS", "DOMAINS"]

#: Fewest bootstrap replicates: effects are accepted on their 95 % interval, and without
#: replicates there is none (nothing would be accepted).
MIN_BOOT = 10
#: Each numeric option of the request: (low, high, unit, integer); the spec's values span the wheels
#: there are (:data:`~euc_sim.rides.source.spec.SPEC_RANGE`).
BOUNDS = {**{k: (*SPEC_RANGE[k], False) for k in ("radius", "wheel_mass", "battery_voltage")},
          "mass": (*TOTAL_MASS_RANGE, "kg", False), "rider_weight": (20.0, 250.0, "kg", False),
          "efficiency": (0.1, 1.0, "", False), "n_boot": (MIN_BOOT, 100_000, "", True)}
#: The residual's domains: battery power, W, or power divided by ω, N·m.
DOMAINS = ("power", "torque")


@dataclass(frozen=True)
class RideRequest:
    """One ride analysis, every value checked: what :func:`~euc_sim.rides.pipeline.ride_pipeline` runs.

    Built by :func:`ride_request`; a script holding rides already parsed may build one directly
    (its values are then its own to check).

    Attributes
    ----------
    log, compare : Ride
        The ride to fit, and optionally the ride to test on, each parsed once.
    spec : WheelSpec or None
        The wheel's specification, with ``--radius``, ``--wheel-mass``, ``--battery-voltage``.
    assumptions : RideAssumptions or None
        Radius, total mass and efficiency given (None: the spec's and the log's).
    domain : {"power", "torque"}
    n_boot, seed : int
        Bootstrap replicates and the seed of every random draw.
    simulate : bool
        Replay the ride: the closed-loop simulator along the tested ride's speed profile.
    calibrate_rider : bool
        Add the ``calibrated_rider`` step to the replay.
    rider_weight, compare_rider_weight : float or None
        The riders' declared weights, kg: priors the logs' total masses check.
    """

    log: Ride
    compare: Ride | None = None
    spec: WheelSpec | None = None
    assumptions: RideAssumptions | None = None
    domain: str = "power"
    n_boot: int = 200
    seed: int = 0
    simulate: bool = False
    calibrate_rider: bool = False
    rider_weight: float | None = None
    compare_rider_weight: float | None = None


def _check(name: str, value, lo: float, hi: float, unit: str = "", integer: bool = False):
    """``value`` if a finite number (an integer with ``integer``) in ``[lo, hi]``, else an
    InputError naming ``--name``, the bound and the value."""
    ok = isinstance(value, Real) and not isinstance(value, bool) and math.isfinite(value) and lo <= value <= hi
    if not ok or (integer and value != int(value)):
        span = f"[{lo:g}, {hi:g}]{' ' + unit if unit else ''}"
        raise InputError("--" + name.replace("_", "-"), f"{'an integer' if integer else 'a number'} in {span}", value)
    return int(value) if integer else float(value)


def _assumptions(radius, mass, efficiency: float):
    """The ride's assumptions from ``radius``, m, and ``mass`` (rider and EUC), kg."""
    from euc_sim.rides.grids.signals import RideAssumptions  # deferred: loads scipy (1.1 s)

    p, sources = TABLE3, []
    if radius is not None:
        p = p.replace(R=radius)
        sources.append(("R", "--radius"))
    if mass is not None:        # its bound's low end exceeds the EUC's own mass (m0 + mw)
        p = p.replace(m=mass - p.m0 - p.mw)
        sources.append(("total_mass", "--mass"))
    return RideAssumptions.from_params(p, efficiency=efficiency, sources=tuple(sources))


def ride_request(log, compare=None, *, wheel=None, radius: float | None = None, mass: float | None = None,
                 wheel_mass: float | None = None, battery_voltage: float | None = None, efficiency: float = 0.8,
                 rider_weight=None, domain: str = "power", n_boot: int = 200, seed: int = 0,
                 simulate: bool | None = None, calibrate_rider: bool = False) -> RideRequest:
    """The one validated request of ``euc-sim ride`` and :func:`euc_sim.analyse_ride`.

    Parameters
    ----------
    log, compare : path
        The ride to fit and, optionally, a ride of the same wheel to test on (each read once).
    wheel : str or path, optional
        A shipped wheel's name or a spec file (:func:`~euc_sim.rides.source.spec.wheel_spec`).
    radius, mass, wheel_mass, battery_voltage : float, optional
        Wheel radius, m; rider plus EUC, kg; the wheel's net weight, kg; full-charge voltage, V.
    efficiency : float
        Drivetrain efficiency that infers a logged torque from battery power.
    rider_weight : float or sequence of float, optional
        The rider's declared weight with gear, kg; two values: LOG's rider, then COMPARE's.
    domain : {"power", "torque"}
    n_boot : int
        Bootstrap replicates, at least :data:`MIN_BOOT`.
    seed : int
        Seed of every random draw.
    simulate : bool, optional
        Replay the ride (default: with ``compare`` only; ``calibrate_rider`` turns it on).
    calibrate_rider : bool

    Returns
    -------
    RideRequest

    Raises
    ------
    InputError, OSError
        One line naming the option (``--n-boot``), the file or its column.
    """
    from euc_sim.rides.balance.analysis import check_data  # deferred: loads scipy (1.1 s)
    from euc_sim.rides.source.logs import read_log  # deferred: loads euc_sim.rides.source.bounds (0.01 s)

    if domain not in DOMAINS:
        raise InputError(f"--domain must be power or torque, got {domain!r}")
    given = {"mass": mass, "radius": radius, "wheel_mass": wheel_mass, "battery_voltage": battery_voltage,
             "efficiency": efficiency, "n_boot": n_boot}
    for name, value in given.items():
        if value is not None:
            given[name] = _check(name, value, *BOUNDS[name])
    if calibrate_rider and simulate is False:
        raise InputError("--calibrate-rider adds a step to the simulated replay: it cannot go with --no-simulate")
    # with compare the replay runs unless refused: CONTRACT's compared JSON carries its "simulation"
    simulate = bool(calibrate_rider or (compare is not None if simulate is None else simulate))
    assumptions = _assumptions(given["radius"], given["mass"], given["efficiency"])
    weights = [] if rider_weight is None else [rider_weight] if isinstance(rider_weight, Real) else list(rider_weight)
    if len(weights) > 2:
        raise InputError(f"--rider-weight: at most twice (LOG's rider, then OTHER's), got {len(weights)} values")
    if len(weights) == 2 and not compare:
        raise InputError("--rider-weight given twice: the second is OTHER's rider, which needs --compare OTHER.csv")
    weights = [_check("rider_weight", w, *BOUNDS["rider_weight"]) for w in weights]
    spec = wheel_spec(wheel, radius=given["radius"], wheel_mass=given["wheel_mass"],
                      battery_voltage=given["battery_voltage"])
    # each log is parsed once, here; a malformed or too short log fails before any output exists
    ride = read_log(log, emit_warnings=False)
    other = read_log(compare, emit_warnings=False) if compare else None
    if wheel:                   # a spec whose voltage class the log cannot have is refused here
        for path, r in ((log, ride), (compare, other)):
            try:
                r is None or log_contradictions(spec, r.data)
            except SpecError as exc:
                raise SpecError(f"{path}: {exc} (--wheel {wheel})") from None
    check_data(ride, other, assumptions=assumptions, domain=domain)
    return RideRequest(ride, other, spec, assumptions, domain, given["n_boot"], seed, simulate, calibrate_rider,
                       weights[0] if weights else None, weights[-1] if weights and compare else None)

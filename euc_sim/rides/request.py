"""The validated request of a ride analysis, that ``euc-sim ride`` and :func:`euc_sim.analyse_ride` both build.

:func:`ride_request` checks every option (each number against its bound in :data:`BOUNDS`, which
the command's ``--help`` states), resolves the wheel's spec and reads each log once, refusing a log
the analysis cannot use before any output exists; bad input raises :class:`~euc_sim.errors.InputError`
(``OSError`` for a missing file), one line naming the option as the command spells it (``--n-boot``).
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
#: Each numeric option of the request: (low, high, integer, unit), as
#: :func:`euc_sim.cli.options.bounded` takes them; the spec's values span the wheels there are
#: (:data:`~euc_sim.rides.source.spec.SPEC_RANGE`).
BOUNDS = {**{k: (lo, hi, False, unit) for k, (lo, hi, unit) in SPEC_RANGE.items() if k != "top_speed"},
          "mass": (*TOTAL_MASS_RANGE, False, "kg"), "rider_weight": (20.0, 250.0, False, "kg"),
          "efficiency": (0.1, 1.0, False, ""), "n_boot": (MIN_BOOT, 100_000, True, "")}
#: The residual's domains: battery power, W, or power divided by ω, N·m.
DOMAINS = ("power", "torque")


@dataclass(frozen=True)
class RideRequest:
    """One ride analysis, every value checked (by :func:`ride_request`; a script holding rides already
    parsed may build one directly): what :func:`~euc_sim.rides.pipeline.ride_pipeline` runs.  ``log`` and
    ``compare`` are parsed rides; ``assumptions`` the radius, total mass and efficiency given; the rest as
    :func:`ride_request` takes them, ``simulate`` resolved to a bool, the riders' weights in kg."""

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


def _check(name: str, value, lo: float, hi: float, integer: bool, unit: str):
    """``value`` if a finite number (an integer with ``integer``) in ``[lo, hi]``, else an
    InputError naming ``--name``, the bound and the value."""
    ok = isinstance(value, Real) and not isinstance(value, bool) and math.isfinite(value) and lo <= value <= hi
    if not ok or (integer and value != int(value)):
        span = f"[{lo:g}, {hi:g}]{' ' + unit if unit else ''}"
        raise InputError("--" + name.replace("_", "-"), f"{'an integer' if integer else 'a number'} in {span}", value)
    return int(value) if integer else float(value)


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
    radius, mass, wheel_mass, battery_voltage, efficiency : float, optional
        Wheel radius, m; rider plus EUC, kg; the wheel's net weight, kg; full-charge voltage, V;
        the drivetrain efficiency that infers a logged torque from battery power.
    rider_weight : float or sequence of float, optional
        The rider's declared weight with gear, kg; two values: LOG's rider, then COMPARE's.
    domain, n_boot, seed : {"power", "torque"}, int, int
    simulate : bool, optional
        Replay the ride (default: with ``compare`` only; ``calibrate_rider`` turns it on).
    calibrate_rider : bool

    Raises
    ------
    InputError, OSError
        One line naming the option (``--n-boot``), the file or its column.
    """
    from euc_sim.rides.balance.analysis import check_data  # deferred: loads scipy (1.1 s)
    from euc_sim.rides.grids.signals import RideAssumptions  # deferred: loads scipy (1.1 s)
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
    p, sources = TABLE3, []
    if given["radius"] is not None:
        p, sources = p.replace(R=given["radius"]), [("R", "--radius")]
    if given["mass"] is not None:         # its bound's low end exceeds the EUC's own mass (m0 + mw)
        p, sources = p.replace(m=given["mass"] - p.m0 - p.mw), sources + [("total_mass", "--mass")]
    assumptions = RideAssumptions.from_params(p, efficiency=given["efficiency"], sources=tuple(sources))
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
    check_data(ride, other, domain=domain)
    return RideRequest(ride, other, spec, assumptions, domain, given["n_boot"], seed, simulate, calibrate_rider,
                       weights[0] if weights else None, weights[-1] if weights and compare else None)

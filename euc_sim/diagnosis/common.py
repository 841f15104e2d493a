"""What every step of the diagnosis shares: its error, its decision thresholds, its constants.

The steps (docs/diagnosis.md): :mod:`.prepare`, :mod:`.residual`, :mod:`.candidates`,
:mod:`.estimates` (selection and what it names), :mod:`.refine`, :mod:`.verdict`,
:mod:`.localise`, :mod:`.resimulate`; :mod:`.pipeline` runs them in that order.
"""

from __future__ import annotations

from dataclasses import dataclass

from euc_sim.errors import InputError
from euc_sim.model.parameters import PLAUSIBLE
from euc_sim.simulation import effects

__all__ = ["DiagnosisError", "Thresholds", "THRESHOLDS", "SELECT_RATE", "LATERAL_WINDOW",
           "COLUMN_ITERATIONS", "COLUMN_H_TOL", "H_BOUNDS", "NONLINEAR", "RIDER_MASS_RANGE",
           "plausible_range", "H_BOUND_MARGIN", "h_at_bound", "heldout_over_floor"]


class DiagnosisError(InputError):
    """Invalid input to the diagnosis; the message names the argument."""


@dataclass(frozen=True)
class Thresholds:
    """Decision thresholds of the diagnosis (dimensionless unless stated; docs/diagnosis.md, section 4).

    Attributes
    ----------
    min_bic_drop : float
        Smallest BIC drop (with n_eff) to accept a term.
    min_cv_gain : float
        Smallest fractional drop of the held-out RMSE.
    min_t : float
        Smallest |estimate| / standard error of an accepted term.
    max_h_halfwidth : float
        Largest 95 % half-width of h, m, for the recording to decide.
    generic_gain : float
        A generic periodic basis beating the final model by this fraction of held-out RMSE
        means structure is left unexplained.
    floor_ratio : float
        Final held-out RMSE above this multiple of the noise floor, with the generic basis
        helping by half of ``generic_gain``, means the same.
    unexplained_keep : float
        With structure unexplained, an effect is named only when it cut the held-out RMSE to
        at most this fraction; otherwise it is ``tentative``.
    alias_bic : float
        A candidate swapped in within this BIC of the accepted set is an alias.
    alias_cosine : float
        |cosine| between two single-column terms above which they are aliases.
    """

    min_bic_drop: float = 10.0
    min_cv_gain: float = 0.08
    min_t: float = 4.0
    max_h_halfwidth: float = 0.15
    generic_gain: float = 0.25
    floor_ratio: float = 2.0
    unexplained_keep: float = 0.5
    alias_bic: float = 10.0
    alias_cosine: float = 0.95


THRESHOLDS = Thresholds()

#: Residual samples kept per second for selection (the filtered residual is smooth).
SELECT_RATE = 30.0
#: Savitzky–Golay window for the tilt and yaw channels, s: the couplings' bandwidth
#: (:data:`euc_sim.simulation.effects.LATERAL_WINDOW`).
LATERAL_WINDOW = effects.LATERAL_WINDOW
#: Rebuilds of the candidate columns at the augmented h (at most), and the change of
#: h, m, below which they stop.
COLUMN_ITERATIONS = 3
COLUMN_H_TOL = 0.01
#: Search interval of h, m.
H_BOUNDS = (0.25, 1.2)
#: Physical range of a rider's mass, kg: a nominal mass outside it is refused, an
#: estimate outside it is not physics.
RIDER_MASS_RANGE = PLAUSIBLE["m"]
#: An h closer than this to an end of :data:`H_BOUNDS` lies on the bound, m.
H_BOUND_MARGIN = 0.01


def h_at_bound(h: float) -> bool:
    """Whether an identified h lies on the search bound :data:`H_BOUNDS` (a bound, not a minimum)."""
    lo, hi = H_BOUNDS
    return min(h - lo, hi - h) < H_BOUND_MARGIN


def heldout_over_floor(heldout_rmse: float, noise_floor: float) -> float:
    """Held-out RMSE over the noise floor (both N·m): the diagnosis's one "× the noise floor" figure (inf for a
    zero floor)."""
    return heldout_rmse / noise_floor if noise_floor > 0 else float("inf")


#: Nonlinear effects refined by a 1-D search, with their search intervals.
NONLINEAR = {"sensor_time_offset": (-0.3, 0.3), "rider_mass": RIDER_MASS_RANGE}


#: Per nonlinear effect: the half-width of its 1-D search around the current value, the
#: search's tolerance, and the step of its slope's central difference (its unit).
SEARCH = {"sensor_time_offset": (0.05, 1e-4, 0.005), "rider_mass": (25.0, 0.05, 2.0)}


def plausible_range(name: str) -> tuple[float, float]:
    """Magnitudes against which detection limits are judged: the record's ``detect_range``
    (the rider mass: a deviation from the nominal mass, kg), else its plausible range."""
    e = effects.get(name)
    return e.detect_range or e.plausible


"""Errors of the simulation layer: invalid requests and falls."""

from __future__ import annotations

from euc_sim.errors import InputError


class SimulationError(InputError):
    """An invalid simulation request (maneuver, engine, effect, profile); names the argument."""


class FallError(SimulationError):
    """The rider or the EUC fell: a state left its bound or became non-finite.

    Attributes
    ----------
    t : float
        Time of the fall, s.
    quantity : str
        ``"phi"``, ``"gamma"`` or ``"state"`` (non-finite).
    value : float
        The offending value, rad.
    trajectory : pandas.DataFrame or None
        The run up to the fall, where the simulator provides it.
    """

    partial = None
    trajectory = None

    def __init__(self, t: float, quantity: str, value: float, bound: float | None):
        self.t, self.quantity, self.value, self.bound = t, quantity, value, bound
        if bound is None:
            msg = f"fall at t = {t:.3f} s: the state became non-finite ({quantity} = {value!r})"
        else:
            msg = (f"fall at t = {t:.3f} s: |{quantity}| = {abs(value):.3f} rad exceeds the bound "
                   f"{bound:g} rad")
        super().__init__(msg)


class UnstableError(FallError):
    """MuJoCo found a non-finite or huge state and reset it: the run is not a ride.

    Parameters
    ----------
    t : float
        Time at which it was noticed, s.
    detail : str
        Which of MuJoCo's counters fired (:func:`euc_sim.model.mujoco_model.instability`).
    """

    def __init__(self, t: float, detail: str):
        self.t, self.quantity, self.value, self.bound = t, "state", float("nan"), None
        SimulationError.__init__(
            self, f"the simulation went unstable by t = {t:.3f} s: MuJoCo found NaN, infinite or huge "
                  f"values ({detail}) and reset the state; an effect, force or parameter is too large")


def check_stable(data, t: float) -> None:
    """Raise :class:`UnstableError` when MuJoCo's warning counters in ``data`` say it reset the state.

    Parameters
    ----------
    data : mujoco.MjData
        The run's data, after its last step.
    t : float
        The run's end, s.
    """
    from euc_sim.model.mujoco_model import instability  # deferred: loads mujoco (0.1 s)

    detail = instability(data)
    if detail:
        raise UnstableError(t, detail)

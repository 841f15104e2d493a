"""Errors of the simulation layer: invalid requests and falls."""

from __future__ import annotations

from euc_sim.errors import InputError


class SimulationError(InputError):
    """An invalid simulation request (maneuver, engine, effect, profile); names the argument."""


class FallError(SimulationError):
    """The rider or the EUC fell: a state left its bound or became non-finite.

    Attributes: ``t`` (s), ``quantity`` (``"phi"``, ``"gamma"``, ``"theta"`` or ``"state"``),
    ``value`` (rad), ``bound`` (rad or None), ``trajectory`` (the run up to the fall, or None).
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
    """MuJoCo found a non-finite or huge state by ``t``, s, and reset it (``detail``: its counters): not a ride."""

    def __init__(self, t: float, detail: str):
        self.t, self.quantity, self.value, self.bound = t, "state", float("nan"), None
        SimulationError.__init__(
            self, f"the simulation went unstable by t = {t:.3f} s: MuJoCo found NaN, infinite or huge "
                  f"values ({detail}) and reset the state; an effect, force or parameter is too large")


def check_stable(data, t: float) -> None:
    """Raise :class:`UnstableError` when MuJoCo's warning counters in ``data`` say it reset the state by ``t``, s."""
    from euc_sim.model.mujoco_model import instability  # deferred: loads mujoco (0.1 s)

    detail = instability(data)
    if detail:
        raise UnstableError(t, detail)

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

"""The EUC's motor controller: a PD law on the body pitch (Section 3),

    M_d = K_p (γ − γ_ref(ẋ)) + K_d γ̇,        |M_d| ≤ M_max,

γ_ref = −k_tb (|ẋ| − v_tb) sign(ẋ) above the tilt-back speed v_tb, else 0; M_d > 0
drives the wheel forward and pitches the body back (eq. 8).  An optional voltage limit
(from a ride's drivetrain) caps the motoring torque at M_V(ẋ) = (V − K_v|ẋ|)/r_M.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass

from euc_sim.errors import InputError

__all__ = ["MotorPD", "MotorError", "pd_torque"]


class MotorError(InputError):
    """An invalid motor-controller setting; the message names it."""


@dataclass(frozen=True)
class MotorPD:
    """PD law M_d = K_p (γ − γ_ref) + K_d γ̇ with a torque limit and optional tilt-back.

    Attributes
    ----------
    Kp : float
        Proportional gain, N·m/rad.
    Kd : float
        Derivative gain, N·m·s/rad.
    torque_limit : float
        |M_d| limit, N·m.
    tiltback_speed : float
        Speed above which the set-point tilts back, m/s; ``inf`` for none.
    tiltback_gain : float
        Tilt-back slope, rad per m/s.
    voltage : float
        Battery voltage of the voltage limit, V; ``inf`` for none.
    back_emf : float
        K_v, V·s/m.
    drop : float
        r_M, resistive drop per torque, V/(N·m).
    dead_time : float
        c_dt, duty lost to dead time: the motor sees (1 − c_dt)·V.
    flux_weakening : float
        c_fw, V/(m/s)²: back-EMF K_v|ẋ| − c_fw|ẋ| min(|ẋ|, fw_speed) (:mod:`euc_sim.rides.drive.pwm`).
    fw_speed : float
        Speed beyond which the flux weakening stops growing, m/s; ``inf`` for none.
    """

    Kp: float = 600.0
    Kd: float = 40.0
    torque_limit: float = 250.0
    tiltback_speed: float = math.inf
    tiltback_gain: float = 0.03
    voltage: float = math.inf
    back_emf: float = 0.0
    drop: float = 0.0
    dead_time: float = 0.0
    flux_weakening: float = 0.0
    fw_speed: float = math.inf

    def __post_init__(self) -> None:
        if math.isfinite(self.voltage) and not (self.voltage > 0 and self.drop > 0):
            raise MotorError(f"motor voltage limit needs voltage > 0 and drop > 0, got "
                             f"voltage={self.voltage!r}, drop={self.drop!r}")
        for name in ("Kp", "Kd", "torque_limit", "tiltback_gain", "back_emf", "drop"):
            v = getattr(self, name)
            if not (isinstance(v, (int, float)) and math.isfinite(v) and v >= 0):
                raise MotorError(f"motor setting {name!r} must be a finite non-negative number, got {v!r}")
        if not (isinstance(self.dead_time, (int, float)) and -1.0 < self.dead_time < 1.0):
            raise MotorError(f"motor setting 'dead_time' must be a duty in (-1, 1), got {self.dead_time!r}")
        if not (isinstance(self.flux_weakening, (int, float)) and math.isfinite(self.flux_weakening)):
            raise MotorError(f"motor setting 'flux_weakening' must be a finite number, got "
                             f"{self.flux_weakening!r}")
        if not (self.fw_speed > 0):
            raise MotorError(f"motor fw_speed must be positive (inf for none), got {self.fw_speed!r}")
        if self.Kp <= 0 or self.torque_limit <= 0:
            raise MotorError(f"motor Kp and torque_limit must be positive, got Kp={self.Kp!r}, "
                             f"torque_limit={self.torque_limit!r}")
        if not (self.tiltback_speed > 0):
            raise MotorError(f"motor tiltback_speed must be positive (inf for none), got {self.tiltback_speed!r}")

    def gamma_ref(self, speed: float) -> float:
        """Pitch set-point γ_ref(ẋ), rad (0 below the tilt-back speed)."""
        excess = abs(speed) - self.tiltback_speed
        if excess <= 0.0:
            return 0.0
        return -math.copysign(self.tiltback_gain * excess, speed)

    def dgamma_ref_dv(self, speed: float) -> float:
        """∂γ_ref/∂ẋ at ``speed``, rad·s/m (for the linearisation)."""
        return -self.tiltback_gain if abs(speed) > self.tiltback_speed else 0.0

    def torque(self, gamma: float, gamma_dot: float, speed: float = 0.0) -> float:
        """Motor torque M_d, N·m, from γ (rad), γ̇ (rad/s) and ẋ (m/s, for tilt-back and the voltage limit)."""
        return pd_torque(gamma, gamma_dot, speed, *self.law_args())

    def law_args(self) -> tuple:
        """The settings :func:`pd_torque` takes after (γ, γ̇, ẋ), in its order."""
        return (self.Kp, self.Kd, self.torque_limit, self.tiltback_speed, self.tiltback_gain,
                self.voltage, self.back_emf, self.drop, self.dead_time, self.flux_weakening,
                self.fw_speed)

    def voltage_torque(self, speed: float) -> float:
        """Largest motoring torque the battery voltage allows at ``speed`` (m/s), N·m (≥ 0)."""
        if self.voltage == math.inf:
            return math.inf
        v = abs(speed)
        emf = self.back_emf * v - self.flux_weakening * v * min(v, self.fw_speed)
        return max(((1.0 - self.dead_time) * self.voltage - emf) / self.drop, 0.0)

    def as_dict(self) -> dict:
        """Settings as a JSON-ready dict (``inf`` as ``None``; dead time and flux weakening only where set)."""
        d = asdict(self)
        for k, default in (("dead_time", 0.0), ("flux_weakening", 0.0), ("fw_speed", math.inf)):
            if d[k] == default:
                del d[k]
        for k in ("tiltback_speed", "voltage", "fw_speed"):
            if k in d and not math.isfinite(d[k]):
                d[k] = None
        return d


def pd_torque(gamma: float, gamma_dot: float, speed: float, Kp: float, Kd: float, torque_limit: float,
              tiltback_speed: float, tiltback_gain: float, voltage: float, back_emf: float, drop: float,
              dead_time: float, flux_weakening: float, fw_speed: float) -> float:
    """The law of :class:`MotorPD` as a pure function of floats, N·m: the one source of the motor law
    (compiled by the native loops).  Arguments after ``speed`` are :meth:`MotorPD.law_args`.
    """
    g_ref = 0.0
    if tiltback_speed != math.inf:                  # γ_ref(ẋ), MotorPD.gamma_ref
        excess = abs(speed) - tiltback_speed
        if excess > 0.0:
            g_ref = -math.copysign(tiltback_gain * excess, speed)
    M = Kp * (gamma - g_ref) + Kd * gamma_dot
    M = torque_limit if M > torque_limit else (-torque_limit if M < -torque_limit else M)
    if voltage != math.inf and M * speed > 0.0:     # MotorPD.voltage_torque
        v = abs(speed)
        emf = back_emf * v - flux_weakening * v * min(v, fw_speed)
        M_v = max(((1.0 - dead_time) * voltage - emf) / drop, 0.0)
        M = M_v if M > M_v else (-M_v if M < -M_v else M)
    return M

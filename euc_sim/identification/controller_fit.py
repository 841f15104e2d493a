"""Beyond the paper: the EUC's controller law fitted to M_d,2 and the rider's delayed law fitted to M_h."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from euc_sim.model import analytic
from euc_sim.model.parameters import Params
from euc_sim.identification.processing import Kinematics, term_filter


# --- beyond the paper: the EUC's controller and the rider's law ------------------------------
#: Regressors of the controller and rider fits.
_TERMS = {
    "gamma": lambda kin: kin.q[:, 1], "gamma_d": lambda kin: kin.qd[:, 1],
    "phi": lambda kin: kin.q[:, 2], "phi_d": lambda kin: kin.qd[:, 2],
    "const": lambda kin: np.ones(len(kin.t)),
}
_UNITS = {"gamma": "N·m/rad", "gamma_d": "N·m·s/rad", "phi": "N·m/rad", "phi_d": "N·m·s/rad", "const": "N·m"}
#: The EUC controller's terms (K_p γ + K_d γ̇) and the rider's delayed law's.
CONTROLLER_TERMS = ("gamma", "gamma_d")
RIDER_TERMS = ("phi", "phi_d", "const")
#: Longest rider delay searched, s.
MAX_DELAY = 0.5


@dataclass
class ControllerFit:
    """A linear law torque ≈ Σ gain_k · term_k fitted by least squares.

    Attributes
    ----------
    gains : dict of str to float
        Per term (``gamma`` → K_p, ``gamma_d`` → K_d, ...), in ``units``.
    units : dict of str to str
    r2 : float
    rmse : float
        N·m.
    delay : float
        Delay of the regressors, s (0 for the motor law).
    """

    gains: dict
    units: dict
    r2: float
    rmse: float
    delay: float = 0.0

    def as_json(self) -> dict:
        return {"gains": self.gains, "units": self.units, "r2": self.r2, "rmse": self.rmse,
                "delay": self.delay}


def _lstsq_fit(y: np.ndarray, X: np.ndarray) -> tuple[np.ndarray, float, float]:
    coef, *_ = np.linalg.lstsq(X, y, rcond=None)
    res = y - X @ coef
    ss = float(np.sum((y - y.mean()) ** 2))
    r2 = 1.0 - float(res @ res) / ss if ss > 0 else math.nan
    return coef, r2, float(np.sqrt(np.mean(res**2)))


def _filtered_rows(kin: Kinematics, y: np.ndarray, terms) -> tuple[np.ndarray, np.ndarray]:
    """Target y and the named regressors through the same term filter, interior samples."""
    sig = kin.smoothing.sigma_samples(kin.dt)
    sl = kin.interior
    X = np.column_stack([term_filter(_TERMS[t](kin), sig)[sl] for t in terms])
    return term_filter(y, sig)[sl], X


def identify_controller(kin, p) -> ControllerFit:
    """The EUC's controller: M_d,2 (eq. 10) ≈ K_p γ + K_d γ̇ (:data:`CONTROLLER_TERMS`), target and regressors
    term-filtered alike.

    ``kin``, ``p``: one recording or lists pooled into one fit (``p.h`` the rider height used).
    """
    kins = kin if isinstance(kin, (list, tuple)) else [kin]
    ps = p if isinstance(p, (list, tuple)) else [p] * len(kins)
    rows = [_filtered_rows(k, analytic.driving_torque_2(pp, k.q, k.qd, k.qdd), CONTROLLER_TERMS)
            for k, pp in zip(kins, ps)]
    y = np.concatenate([r[0] for r in rows])
    X = np.concatenate([r[1] for r in rows])
    coef, r2, rmse = _lstsq_fit(y, X)
    return ControllerFit(gains={t: float(c) for t, c in zip(CONTROLLER_TERMS, coef)},
                         units={t: _UNITS[t] for t in CONTROLLER_TERMS}, r2=r2, rmse=rmse)


@dataclass
class RiderFit(ControllerFit):
    """The rider's delayed law; ``delay_curve`` holds (delays, rmse); ``at_bound`` when the best delay is the
    first or last searched."""

    delay_curve: tuple = ()
    at_bound: bool = False

    def as_json(self) -> dict:
        out = super().as_json()
        out["delay_curve"] = {"delay": self.delay_curve[0], "rmse": self.delay_curve[1]}
        out["search"] = [float(self.delay_curve[0][0]), float(self.delay_curve[0][-1])]
        return out


def identify_rider_delay(kin: Kinematics, p: Params) -> RiderFit:
    """M_h (row 3 of eq. 5) ≈ Σ k_j · term_j(t − τ) (:data:`RIDER_TERMS`): a delayed PD law, τ searched from 0 to
    :data:`MAX_DELAY` s (:func:`fit_delayed_law`)."""
    y, X = _filtered_rows(kin, analytic.rider_torque(p, kin.q, kin.qd, kin.qdd), RIDER_TERMS)
    fit = fit_delayed_law(y, X, kin.dt, MAX_DELAY)
    coef = fit.pop("coef")
    return RiderFit(gains={t: float(c) for t, c in zip(RIDER_TERMS, coef)},
                    units={t: _UNITS[t] for t in RIDER_TERMS}, **fit)


def fit_delayed_law(y: np.ndarray, X: np.ndarray, dt: float, max_delay: float) -> dict:
    """y(t) ≈ X(t − τ) · coef, τ the whole number of samples in [0, max_delay] (s) with the smallest residual.

    Returns ``coef``, ``r2``, ``rmse``, ``delay`` (s), ``delay_curve`` (delays s, rmse) and
    ``at_bound``; ``y`` (N,), ``X`` (N, k), ``dt`` s.
    """
    n_max = int(min(round(max_delay / dt), len(y) // 2))
    fits = [_lstsq_fit(y[n:], X[: len(X) - n]) for n in range(n_max + 1)]
    rm = np.array([f[2] for f in fits])
    best = int(np.argmin(rm))
    coef, r2, rmse = fits[best]
    return {"coef": coef, "r2": r2, "rmse": rmse, "delay": round(best * dt, 9),
            "delay_curve": (np.arange(n_max + 1) * dt, rm), "at_bound": best in (0, n_max)}

"""Proof that the MuJoCo model and the analytic Lagrange equations agree (``euc-sim crosscheck``).

Every check returns a :class:`Check`, the worst error and its bound.  Relative errors
are ‖MuJoCo − analytic‖∞ / ‖analytic‖∞ per sample, the denominator floored at
1e-6·m g h, N·m.  See docs/simulation.md.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass
from typing import Callable, Iterable

import numpy as np
from scipy.integrate import solve_ivp

from euc_sim.model import analytic
from euc_sim.model.mujoco_model import ContactSettings, EucMujoco
from euc_sim.model.parameters import Params, TABLE3

__all__ = ["Check", "PARAMETER_SETS", "random_states", "STATIC_CHECKS", "check_static", "simulate_mujoco", "simulate_analytic", "check_forward",
           "check_energy", "contact_convergence", "check_contact", "run_all"]

#: Parameter sets of the cross-check: Table 3, a light tall rider, a heavy short one
#: on a bigger wheel, and one with the EUC's centre of gravity below C.
PARAMETER_SETS: dict[str, Params] = {
    "table3": TABLE3,
    "light_tall": TABLE3.replace(m=45.0, J=9.0, h=0.75, l0=0.08),
    "heavy_short": TABLE3.replace(m=110.0, J=25.0, h=0.5, R=0.254, m0=22.0, J0=0.9, mw=6.0, Jw=0.25),
    "low_body": TABLE3.replace(h0=0.02, l0=0.12, J0=0.3, m0=9.0),
}

#: Bounds: relative for the static checks (ideal), rad for the 5 s trajectories, relative energy drift.
STATIC_BOUND = 1e-8
TRAJECTORY_BOUND = 1e-6
ENERGY_BOUND = 1e-6
#: Contact variant against pure rolling over 2 s at the stiffest setting, rad (the soft
#: contact sinks and creeps).
CONTACT_BOUND = 1e-2


@dataclass(frozen=True)
class Check:
    """One cross-check figure: the worst error and its bound."""

    name: str
    value: float
    bound: float
    detail: str = ""

    @property
    def ok(self) -> bool:
        return bool(np.isfinite(self.value) and self.value <= self.bound)

    def as_json(self) -> dict:
        d = asdict(self)
        d["ok"] = self.ok
        return d


def random_states(n: int, seed: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Random (q, q̇, q̈) from ``seed``, each (n, 3): angles over the full circle, rates up to a few rad/s."""
    rng = np.random.default_rng(seed)
    q = np.column_stack([rng.uniform(-5, 5, n), rng.uniform(-np.pi, np.pi, (n, 2))])
    qd = rng.normal(0.0, [3.0, 3.0, 3.0], (n, 3))
    qdd = rng.normal(0.0, [5.0, 20.0, 20.0], (n, 3))
    return q, qd, qdd


def _rel_err(mj: np.ndarray, an: np.ndarray, floor: float) -> float:
    axes = tuple(range(1, an.ndim))
    num = np.max(np.abs(mj - an), axis=axes)
    den = np.maximum(np.max(np.abs(an), axis=axes), floor)
    return float(np.max(num / den))


def _static_pass(p: Params, q, qd, qdd, what: str, mjcf=None) -> tuple[np.ndarray, np.ndarray]:
    sim = EucMujoco(p, "ideal", mjcf)
    out = []
    for i in range(len(q)):
        if what == "inverse":
            out.append(sim.inverse(q[i], qd[i], qdd[i]))
        else:
            sim.set_state(q[i], qd[i])
            out.append(sim.mass_matrix() if what == "mass" else sim.bias())
    if what == "mass":
        an = analytic.mass_matrix(p, q)
    elif what == "bias":
        an = analytic.nonlinear_terms(p, q, qd) - analytic.gravity_forces(p, q)
    else:
        an = analytic.inverse_dynamics(p, q, qd, qdd)
    return np.array(out), an


#: The static checks: ``mass``, MuJoCo's mass matrix mapped to (x, γ, φ) against eq. (6);
#: ``bias``, its bias forces against h − (gravity part of Q), eqs. (7)-(8); ``inverse``,
#: ``mj_inverse`` against M q̈ + h − Q_gravity.  Each: (check name, seed of the random states,
#: stage named to ``progress``).
STATIC_CHECKS = {"mass": ("mass_matrix_eq6", 0, "mass matrix"),
                 "bias": ("bias_forces_eq7_eq8", 100, "bias forces"),
                 "inverse": ("inverse_dynamics", 200, "inverse dynamics")}


def check_static(what: str, sets=PARAMETER_SETS, n: int = 2500, mjcf=None) -> Check:
    """The static check ``what`` of :data:`STATIC_CHECKS` on ``n`` random states of each of
    ``sets``: the worst relative error.
    """
    label, seed, _ = STATIC_CHECKS[what]
    worst, where = 0.0, ""
    for k, (name, p) in enumerate(sets.items()):
        q, qd, qdd = random_states(n, seed + k)
        mj, an = _static_pass(p, q, qd, qdd, what, mjcf)
        err = _rel_err(mj, an, 1e-6 * p.m * p.g * p.h)
        if err >= worst:
            worst, where = err, name
    total = n * len(sets)
    return Check(label, worst, STATIC_BOUND,
                 f"{total} random states over {len(sets)} parameter sets; worst in {where!r}")


# --- trajectories -------------------------------------------------------------------
def simulate_mujoco(sim: EucMujoco, q0, qd0, duration: float, torques=(0.0, 0.0)):
    """Step MuJoCo with constant torques; return times and paper states (N, 6)."""
    sim.set_state(q0, qd0)
    sim.set_torques(*torques)
    n = int(round(duration / sim.model.opt.timestep))
    t, y, e = [0.0], [np.concatenate([sim.q, sim.qd])], [sim.energy()]
    for _ in range(n):
        sim.step()
        t.append(sim.data.time)
        y.append(np.concatenate([sim.q, sim.qd]))
        e.append(sim.energy())
    return np.array(t), np.array(y), np.array(e)


def _pitch_gap(sim: EucMujoco, p: Params, case: str, duration: float):
    """MuJoCo's and scipy's states (N, 6) of a :data:`TRAJECTORY_CASES` case over ``duration`` s and
    their worst |Δγ|, |Δφ|, rad.
    """
    q0, qd0, torques = TRAJECTORY_CASES[case]
    t, y_mj, _ = simulate_mujoco(sim, q0, qd0, duration, torques)
    y_an = simulate_analytic(p, np.array(q0), np.array(qd0), t, torques)
    return y_mj, y_an, float(np.max(np.abs(y_mj[:, 1:3] - y_an[:, 1:3])))


def simulate_analytic(p: Params, q0, qd0, t_eval, torques=(0.0, 0.0)) -> np.ndarray:
    """Integrate eq. (5) with ``solve_ivp`` (DOP853, rtol = atol = 1e-12); states (N, 6)."""
    M_d, M_h = torques
    sol = solve_ivp(lambda t, y: analytic.state_derivative(p, y, M_d, M_h),
                    (t_eval[0], t_eval[-1]), np.concatenate([q0, qd0]), method="DOP853",
                    t_eval=t_eval, rtol=1e-12, atol=1e-12)
    if not sol.success:
        raise RuntimeError(f"analytic integration failed: {sol.message}")
    return sol.y.T


#: Initial states and torques (N·m) of the trajectory checks: passive (the rider falls and
#: swings through) and constant torques; rates stay below 30 rad/s, where RK4 at 1 kHz is exact.
TRAJECTORY_CASES = {
    "passive": ((0.0, 0.05, 0.1), (0.5, 0.0, 0.0), (0.0, 0.0)),
    "constant_torques": ((0.0, 0.1, -0.05), (0.0, 0.0, 0.0), (20.0, 10.0)),
}


def check_forward(p: Params = TABLE3, duration: float = 5.0, mjcf=None) -> list[Check]:
    """MuJoCo (RK4, 1 kHz, ideal) against scipy on eq. (5): worst |Δγ|, |Δφ| over 5 s."""
    sim = EucMujoco(p, "ideal", mjcf)
    checks = []
    for case in TRAJECTORY_CASES:
        y_mj, y_an, ang = _pitch_gap(sim, p, case, duration)
        dx = float(np.max(np.abs(y_mj[:, 0] - y_an[:, 0])))
        checks.append(Check(f"forward_{case}_ideal", ang, TRAJECTORY_BOUND,
                            f"max |Δγ|,|Δφ| in rad over {duration:g} s; max |Δx| = {dx:.2e} m; "
                            f"final φ = {y_an[-1, 2]:.2f} rad"))
    return checks


def check_energy(p: Params = TABLE3, duration: float = 5.0, mjcf=None) -> list[Check]:
    """Passive motion: MuJoCo's energy against analytic T + V, and its drift."""
    sim = EucMujoco(p, "ideal", mjcf)
    q0, qd0, _ = TRAJECTORY_CASES["passive"]
    t, y, e_mj = simulate_mujoco(sim, q0, qd0, duration)
    e_an = analytic.kinetic_energy(p, y[:, :3], y[:, 3:]) + analytic.potential_energy(p, y[:, :3])
    scale = abs(e_an[0])
    return [
        Check("energy_mujoco_vs_analytic", float(np.max(np.abs(e_mj - e_an)) / scale), ENERGY_BOUND,
              "max |E_mj − (T+V)| / |E(0)| along the passive MuJoCo trajectory"),
        Check("energy_drift", float(np.max(np.abs(e_mj - e_mj[0])) / scale), ENERGY_BOUND,
              f"max |E(t) − E(0)| / |E(0)| over {duration:g} s, no torque"),
    ]


#: Contact stiffness ladder: solref time constants, s (down to one timestep).
CONTACT_TIMECONSTS = (0.02, 0.008, 0.002, 0.001)


def contact_convergence(p: Params = TABLE3, duration: float = 2.0,
                        timeconsts: Iterable[float] = CONTACT_TIMECONSTS,
                        mjcf=None) -> list[tuple[float, float]]:
    """(timeconst, max |Δγ|,|Δφ|) of the contact variant against pure rolling, stiffer and stiffer, on the constant-torque case."""
    return [(tc, _pitch_gap(EucMujoco(p, "contact", mjcf, contact=ContactSettings(timeconst=tc)), p,
                             "constant_torques", duration)[2]) for tc in timeconsts]


def check_contact(p: Params = TABLE3, mjcf=None) -> list[Check]:
    """The contact variant's tolerance, and that it shrinks as the contact stiffens."""
    rows = contact_convergence(p, mjcf=mjcf)
    errs = [e for _, e in rows]
    ladder = ", ".join(f"tc={tc:g} s: {e:.2e} rad" for tc, e in rows)
    shrinking = all(b < a for a, b in zip(errs, errs[1:]))
    return [
        Check("forward_contact_stiffest", errs[-1], CONTACT_BOUND, ladder),
        Check("contact_error_shrinks_with_stiffness", 0.0 if shrinking else 1.0, 0.0,
              "1 when the error does not fall at each stiffer step: " + ladder),
    ]


def run_all(n_per_set: int = 2500, progress: Callable[[str], None] | None = None,
            sets: dict[str, Params] | None = None, mjcf=None) -> list[Check]:
    """All cross-checks: the static ones on ``n_per_set`` random states of each of ``sets`` (default
    :data:`PARAMETER_SETS`), the trajectory, energy and contact ones on the first set;
    ``progress(stage)`` names each stage.
    """
    say = progress or (lambda s: None)
    sets = sets or PARAMETER_SETS
    p0 = next(iter(sets.values()))
    checks = []
    for what, (_, _, stage) in STATIC_CHECKS.items():
        say(stage)
        checks.append(check_static(what, sets, n_per_set, mjcf=mjcf))
    say("forward simulation (ideal)")
    checks += check_forward(p0, mjcf=mjcf)
    say("energy")
    checks += check_energy(p0, mjcf=mjcf)
    say("contact variant")
    checks += check_contact(p0, mjcf=mjcf)
    return checks

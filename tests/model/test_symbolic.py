"""The symbolic proof: Lagrange's equations from the geometry equal eqs. (6)-(8), (13)."""

import numpy as np
import pytest
import sympy as sp

from euc_sim.model import analytic
from euc_sim.model.parameters import TABLE3
from euc_sim.model.symbolic import derive, paper_equations, paper_reduced_torques, reduced_torques_from_lagrange


@pytest.fixture(scope="module")
def d():
    return derive()


def test_kinetic_energy_from_geometry_is_eq_A1(d):
    assert sp.simplify(sp.expand_trig(d.T - paper_equations(d)["T"])) == 0


def test_generalised_forces_are_eq_8_and_A2(d):
    paper = paper_equations(d)
    assert sp.simplify(d.Q - paper["Q"]) == sp.zeros(3, 1)
    assert sp.simplify(d.Q - paper["virtual_power_Q"]) == sp.zeros(3, 1)


def test_lagrange_equations_are_eqs_5_to_8(d):
    paper = paper_equations(d)
    printed = paper["M"] * d.qdd + paper["h"] - paper["Q"]          # eq. (5)
    diff = (d.lagrange - printed).applyfunc(lambda e: sp.simplify(sp.expand_trig(sp.expand(e))))
    assert diff == sp.zeros(3, 1)


def test_reduced_torques_are_eq_13(d):
    Md1, Md2 = reduced_torques_from_lagrange(d)
    P1, P2 = paper_reduced_torques(d)
    assert sp.simplify(Md1 - P1) == 0
    assert sp.simplify(Md2 - P2) == 0


def test_a_wrong_term_is_caught(d):
    """The proof can fail: flip the sign of one Coriolis term and it no longer simplifies to 0."""
    paper = paper_equations(d)
    h_wrong = paper["h"].copy()
    h_wrong[1] = -h_wrong[1]
    diff = d.lagrange - (paper["M"] * d.qdd + h_wrong - paper["Q"])
    assert sp.simplify(sp.expand_trig(sp.expand(diff[1]))) != 0


def test_code_matches_symbolic_equations(d):
    """euc_sim.model.analytic evaluates the derived equations at random points."""
    rng = np.random.default_rng(3)
    P = d.params
    p = TABLE3
    subs_p = {P[k]: getattr(p, k) for k in P}
    for _ in range(5):
        q, qd, qdd = rng.normal(0, 1, 3), rng.normal(0, 2, 3), rng.normal(0, 3, 3)
        Md, Mh = rng.normal(0, 20, 2)
        # substitute second derivatives, then first, then the coordinates
        expr = d.lagrange.subs({d.qdd[k]: qdd[k] for k in range(3)})
        expr = expr.subs({d.qd[k]: qd[k] for k in range(3)})
        expr = expr.subs({d.q[k]: q[k] for k in range(3)}).subs(subs_p).subs({d.M_d: Md, d.M_h: Mh})
        symbolic = np.array([float(e) for e in expr])
        numeric = (analytic.mass_matrix(p, q) @ qdd + analytic.nonlinear_terms(p, q, qd)
                   - analytic.generalized_forces(p, q, Md, Mh))
        np.testing.assert_allclose(numeric, symbolic, atol=1e-9)


def test_rider_lean_forces_are_the_derivation_to_first_order_in_the_lean():
    """effects.rider_lean_forces against symbolic.derive_rider_lean (Kane's method on
    the leaning, slender rider) less its value for the upright rider (λ = λ̇ = λ̈ = 0,
    which lateral_forces' isotropic rider leaves out): exact at λ = 0, and the
    difference falls as λ² (the terms left out are of second order)."""
    from euc_sim.model.parameters import TABLE3 as p
    from euc_sim.model.symbolic import derive_rider_lean
    from euc_sim.simulation import effects

    syms, Q = derive_rider_lean()
    f = sp.lambdify(syms, list(Q), "numpy")
    rng = np.random.default_rng(0)
    scale = np.array([0.05, 0.05, 1, .2, .2, .1, .2, .5, .5, 0, .2, .3, .5, .5, .5, .5])
    consts = (p.R, p.m, p.J, effects.RIDER_YAW_INERTIA_RATIO * p.J, p.l0, p.h, p.g)
    worst = {}
    for eps in (0.0, 1e-2, 1e-3):
        worst[eps], size = 0.0, 0.0
        for _ in range(10):
            v = rng.normal(size=16) * scale + np.r_[0, 0, 2.0, np.zeros(13)]
            v[9] = eps * rng.choice([-1, 1])
            upright = v.copy()
            upright[[9, 10, 15]] = 0.0                       # λ, λ̇, λ̈
            exact = np.array(f(*consts, *v), dtype=float) - np.array(f(*consts, *upright), dtype=float)
            g_, ph, xd, gd, pd, th, thd, psd, psdd, lam, lamd, thdd, a0, a1, a2, lamdd = v
            ours = effects.rider_lean_forces(p, np.array([0.0, g_, ph]), np.array([xd, gd, pd]), th, thd, psd, psdd,
                                             lam, lamd, lamdd, thdd)
            worst[eps] = max(worst[eps], float(np.max(np.abs(exact - ours))))
            size = max(size, float(np.max(np.abs(exact))))
        assert size > 1.0
    assert worst[0.0] < 1e-10
    assert worst[1e-2] < 1e-3 * size
    assert worst[1e-3] < worst[1e-2] / 50.0          # second order: 100× for 10× less lean

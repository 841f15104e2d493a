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

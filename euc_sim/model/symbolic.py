"""Symbolic derivation of the equations of motion with sympy (the paper's Appendix A).

From the geometry of Fig. 5: the kinetic energy T (eq. A.1), the potential V, the torques'
generalised forces by virtual power (eqs. A.2, 8) and Lagrange's equations (4); and the
printed equations (6)-(8), (13) for comparison.  The lateral terms by Kane's method
(:func:`derive_lateral`, :func:`derive_rider_lean`).  A proof, run by the tests.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import sympy as sp
from sympy.physics.mechanics import dynamicsymbols

__all__ = ["Derivation", "derive", "paper_equations", "paper_reduced_torques",
           "reduced_torques_from_lagrange", "derive_lateral", "derive_rider_lean"]


@dataclass(frozen=True)
class Derivation:
    """Symbols and expressions of one derivation."""

    t: sp.Symbol
    q: sp.Matrix            # (x, gamma, phi) as functions of t
    qd: sp.Matrix
    qdd: sp.Matrix
    params: dict[str, sp.Symbol]
    M_d: sp.Symbol
    M_h: sp.Symbol
    T: sp.Expr              # kinetic energy from the geometry
    V: sp.Expr              # gravitational potential
    Q: sp.Matrix            # generalised forces: −∂V/∂q + torques by virtual power
    lagrange: sp.Matrix     # d/dt ∂T/∂q̇ − ∂T/∂q − Q (= 0 on motions)


@lru_cache(maxsize=1)
def derive() -> Derivation:
    """Derive T, V, Q and Lagrange's equations from the geometry of Fig. 5."""
    t = sp.Symbol("t")
    R, m, m0, mw, J, Jw, J0, h0, l0, h, g = sp.symbols("R m m0 mw J Jw J0 h0 l0 h g", positive=True)
    params = dict(R=R, m=m, m0=m0, mw=mw, J=J, Jw=Jw, J0=J0, h0=h0, l0=l0, h=h, g=g)
    M_d, M_h = sp.symbols("M_d M_h")
    x, gamma, phi = dynamicsymbols("x gamma phi")
    q = sp.Matrix([x, gamma, phi])
    qd = q.diff(t)
    qdd = qd.diff(t)

    # positions in the (horizontal, vertical) plane; angles from vertical, + forward
    r_C = sp.Matrix([x, R])
    r_G0 = r_C + h0 * sp.Matrix([sp.sin(gamma), sp.cos(gamma)])
    r_A = r_C - l0 * sp.Matrix([sp.sin(gamma), sp.cos(gamma)])
    r_G = r_A + h * sp.Matrix([sp.sin(phi), sp.cos(phi)])
    omega_wheel = qd[0] / R                       # pure rolling, v_P = 0

    def trans(mass, r):
        v = r.diff(t)
        return sp.Rational(1, 2) * mass * (v.T * v)[0]

    T = (trans(mw, r_C) + sp.Rational(1, 2) * Jw * omega_wheel**2
         + trans(m0, r_G0) + sp.Rational(1, 2) * J0 * qd[1]**2
         + trans(m, r_G) + sp.Rational(1, 2) * J * qd[2]**2)
    V = g * (mw * r_C[1] + m0 * r_G0[1] + m * r_G[1])

    # virtual power of the internal torques: M_d between wheel and body, M_h between
    # body and rider (eq. 8 signs): δP = M_d (δω_wheel − δγ̇) + M_h (δγ̇ − δφ̇)
    dv = sp.Matrix(sp.symbols("dxd dgd dpd"))
    dP = M_d * (dv[0] / R - dv[1]) + M_h * (dv[1] - dv[2])
    Q_torque = sp.Matrix([sp.diff(dP, s) for s in dv])
    Q = Q_torque - sp.Matrix([sp.diff(V, s) for s in q])

    dT_dqd = sp.Matrix([sp.diff(T, s) for s in qd])
    dT_dq = sp.Matrix([sp.diff(T, s) for s in q])
    lagrange = dT_dqd.diff(t) - dT_dq - Q                                   # eq. (4)
    return Derivation(t, q, qd, qdd, params, M_d, M_h, T, V, Q, lagrange)


def paper_equations(d: Derivation) -> dict[str, sp.Expr | sp.Matrix]:
    """The paper's printed ``T`` (A.1), ``M`` (6), ``h`` (7), ``Q`` (8) and ``virtual_power_Q`` (A.2) in the derivation's symbols."""
    P = d.params
    R, m, m0, mw, J, Jw, J0, h0, l0, h, g = (P[k] for k in "R m m0 mw J Jw J0 h0 l0 h g".split())
    _, gamma, phi = d.q
    xd, gd, pd = d.qd
    T = (sp.Rational(1, 2) * (m + m0 + mw + Jw / R**2) * xd**2                   # (A.1)
         + sp.Rational(1, 2) * (J0 + m * l0**2 + m0 * h0**2) * gd**2
         + sp.Rational(1, 2) * (J + m * h**2) * pd**2
         - (m * l0 - m0 * h0) * xd * gd * sp.cos(gamma) + m * h * xd * pd * sp.cos(phi)
         - m * h * l0 * gd * pd * sp.cos(phi - gamma))
    M = sp.Matrix([                                                             # (6)
        [m + m0 + mw + Jw / R**2, -(m * l0 - m0 * h0) * sp.cos(gamma), m * h * sp.cos(phi)],
        [-(m * l0 - m0 * h0) * sp.cos(gamma), J0 + m0 * h0**2 + m * l0**2, -m * h * l0 * sp.cos(phi - gamma)],
        [m * h * sp.cos(phi), -m * h * l0 * sp.cos(phi - gamma), J + m * h**2]])
    hv = sp.Matrix([                                                            # (7)
        -m * h * pd**2 * sp.sin(phi) + (m * l0 - m0 * h0) * gd**2 * sp.sin(gamma),
        m * h * l0 * pd**2 * sp.sin(phi - gamma),
        -m * h * l0 * gd**2 * sp.sin(phi - gamma)])
    Q = sp.Matrix([                                                             # (8)
        d.M_d / R,
        d.M_h - d.M_d + (m0 * h0 - m * l0) * g * sp.sin(gamma),
        m * g * h * sp.sin(phi) - d.M_h])
    dv = sp.symbols("dxd dgd dpd")
    dP = (d.M_d / R * dv[0] + (m * g * h * sp.sin(phi) - d.M_h) * dv[2]           # (A.2)
          + (d.M_h - d.M_d + (m0 * h0 - m * l0) * g * sp.sin(gamma)) * dv[1])
    Q_A2 = sp.Matrix([sp.diff(dP, s) for s in dv])
    return {"T": T, "M": M, "h": hv, "Q": Q, "virtual_power_Q": Q_A2}


def paper_reduced_torques(d: Derivation) -> tuple[sp.Expr, sp.Expr]:
    """M̄_d,1 and M̄_d,2 as printed in eq. (13)."""
    P = d.params
    R, m, mw, m0, J, Jw, h, g = (P[k] for k in "R m mw m0 J Jw h g".split())
    phi = d.q[2]
    pd, xdd, pdd = d.qd[2], d.qdd[0], d.qdd[2]
    m_eq = m + m0 + mw + Jw / R**2
    Md1 = -m * h * R * sp.sin(phi) * pd**2 + m_eq * R * xdd + m * h * R * sp.cos(phi) * pdd   # (13)
    den = m * h * sp.cos(phi) + m_eq * R
    Md2 = (m_eq * m * g * h * R * sp.sin(phi) / den
           - m**2 * h**2 * R * sp.sin(phi) * sp.cos(phi) / den * pd**2
           + (m**2 * h**2 * R * sp.cos(phi)**2 - m_eq * R * (J + m * h**2)) / den * pdd)
    return Md1, Md2


def reduced_torques_from_lagrange(d: Derivation) -> tuple[sp.Expr, sp.Expr]:
    """M̄_d,1, M̄_d,2 solved from the derived equations with J0 = h0 = l0 = 0: row 1 for M_d, and
    rows 1 and 2+3 with ẍ eliminated (eqs. 9-12).
    """
    P = d.params
    red = {P["J0"]: 0, P["h0"]: 0, P["l0"]: 0}
    L = d.lagrange.subs(red)
    Md1 = sp.solve(L[0], d.M_d)[0]
    xdd = d.qdd[0]
    sol = sp.solve([L[0], L[1] + L[2]], [d.M_d, xdd], dict=True)[0]
    return Md1, sol[d.M_d]


@lru_cache(maxsize=1)
def derive_lateral() -> tuple[tuple[sp.Symbol, ...], sp.Matrix]:
    """The ``lateral_dynamics`` generalised force from the 3-D positions, by Kane's method.

    The paper's plane rides on P (velocity ẋ e_f(ψ)), yawed by ψ and tilted by ϑ (eq. 2);
    each body turns about the tilted pitch axis e_a at its pitch rate plus Ω·e_a.  Wheel and
    body are isotropic; the rider's inertia is diag(J, J, k·J) with the full Euler equation
    (k = 1: :func:`euc_sim.simulation.effects.lateral_forces`; k = 0.2: the slender rider).
    Q is the planar generalised inertia and gravity forces less the spatial ones.

    Returns
    -------
    symbols : tuple of sympy.Symbol
        ``(R, m, m0, mw, J, Jw, J0, h0, l0, h, g, k, gamma, phi, x_d, gamma_d, phi_d, theta,
        theta_d, psi_d, psi_dd)`` for ``sympy.lambdify``.
    Q : sympy.Matrix, shape (3, 1)
        (N, N·m, N·m).
    """
    t = sp.Symbol("t")
    R, m, m0, mw, J, Jw, J0, h0, l0, h, g, k_yaw = sp.symbols("R m m0 mw J Jw J0 h0 l0 h g k", positive=True)
    x, gamma, phi, psi, th = dynamicsymbols("x gamma phi psi theta")
    qd = [s.diff(t) for s in (x, gamma, phi)]
    e_f = sp.Matrix([sp.cos(psi), sp.sin(psi), 0])
    e_l = sp.Matrix([-sp.sin(psi), sp.cos(psi), 0])
    e_z = sp.Matrix([0, 0, 1])
    e_u = sp.cos(th) * e_z - sp.sin(th) * e_l      # ϑ > 0 tilts to the right (eq. 2, CONTRACT)
    e_a = e_u.cross(e_f)
    Omega = psi.diff(t) * e_z + th.diff(t) * e_f
    w_frame = (Omega.T * e_a)[0]

    def velocity(xi, zeta):     # Ṗ = ẋ e_f, r − P = ξ e_f + ζ e_u
        return qd[0] * e_f + (xi * e_f).diff(t) + (zeta * e_u).diff(t)

    # wheel and EUC body isotropic (their pitch inertias alone are known): (I ω̇)·∂ω/∂u
    # reduces to inertia · d/dt(ω·e_a) · ∂(ω·e_a)/∂u, ω·ė_a = ω·(Ω × e_a) = 0
    bodies = ((mw, sp.Integer(0), R, Jw, qd[0] / R + w_frame),
              (m0, h0 * sp.sin(gamma), R + h0 * sp.cos(gamma), J0, qd[1] + w_frame),
              (m, -l0 * sp.sin(gamma) + h * sp.sin(phi), R - l0 * sp.cos(gamma) + h * sp.cos(phi),
               None, None))
    # the rider: inertia J 1 + (k J − J) n nᵀ about G (diag(J, J, k J) in his
    # own frame, n his long axis), ω = Ω + φ̇ e_a; Euler: I ω̇ + ω × I ω
    n = sp.sin(phi) * e_f + sp.cos(phi) * e_u
    w_rider = Omega + qd[2] * e_a
    I_rider = J * sp.eye(3) + (k_yaw * J - J) * n * n.T
    rot_rider = I_rider * w_rider.diff(t) + w_rider.cross(I_rider * w_rider)
    F = sp.zeros(3, 1)
    for mass, xi, zeta, inertia, w in bodies:
        v = velocity(xi, zeta)
        a = v.diff(t)
        for i, u in enumerate(qd):
            F[i] += mass * ((a + g * e_z).T * v.diff(u))[0]
            if inertia is None:
                F[i] += (rot_rider.T * w_rider.diff(u))[0]
            else:
                F[i] += inertia * w.diff(t) * sp.diff(w, u)
    # plain symbols; the planar case sets every ψ, ϑ term to zero
    sym = sp.symbols("gamma phi x_d gamma_d phi_d theta theta_d psi_d psi_dd")
    rep = {th.diff(t): sym[6], psi.diff(t, 2): sym[8], psi.diff(t): sym[7]}
    flat = {}
    for k, s in enumerate((x, gamma, phi)):
        flat[s.diff(t, 2)] = sp.Symbol(f"acc{k}")
    flat.update({qd[0]: sym[2], qd[1]: sym[3], qd[2]: sym[4], gamma: sym[0], phi: sym[1], th: sym[5]})

    def plain(e):
        e = e.subs({th.diff(t, 2): sp.Symbol("theta_dd")}).subs(rep).subs(flat)
        return e.subs(psi, 0)   # ψ itself drops out of every projection
    full = F.applyfunc(plain)
    planar = full.subs({sym[5]: 0, sym[6]: 0, sym[7]: 0, sym[8]: 0, sp.Symbol("theta_dd"): 0})
    c2 = {sp.cos(sym[5])**2: 1 - sp.sin(sym[5])**2}    # e_u·e_u = 1
    Q = (planar - full).applyfunc(lambda e: sp.expand(sp.expand(e).subs(c2)))
    return (R, m, m0, mw, J, Jw, J0, h0, l0, h, g, k_yaw) + tuple(sym), Q


@lru_cache(maxsize=1)
def derive_rider_lean() -> tuple[tuple[sp.Symbol, ...], sp.Matrix]:
    """The rider's lean λ (about his fore-aft axis after φ, as ``mjcf/euc_3d.xml``), by Kane's method.

    G = A + h n, n = cos λ e_z' − sin λ e_a; ω = Ω + φ̇ e_a + λ̇ e_x'; inertia J 1 + (J_z − J) n nᵀ.
    Q is the in-plane isotropic rider's generalised forces less this rider's: what
    :func:`euc_sim.simulation.effects.rider_lean_forces` keeps to first order in λ.

    Returns
    -------
    symbols : tuple of sympy.Symbol
        ``(R, m, J, J_z, l0, h, g, gamma, phi, x_d, gamma_d, phi_d, theta, theta_d, psi_d,
        psi_dd, lean, lean_d, theta_dd, acc0, acc1, acc2, lean_dd)`` (acc: ẍ, γ̈, φ̈).
    Q : sympy.Matrix, shape (3, 1)
        (N, N·m, N·m), not simplified.
    """
    t = sp.Symbol("t")
    R, m, J, J_z, l0, h, g = sp.symbols("R m J J_z l0 h g", positive=True)
    x, gamma, phi, psi, th, lam = dynamicsymbols("x gamma phi psi theta lean")
    qd = [s.diff(t) for s in (x, gamma, phi)]
    e_f = sp.Matrix([sp.cos(psi), sp.sin(psi), 0])
    e_l = sp.Matrix([-sp.sin(psi), sp.cos(psi), 0])
    e_z = sp.Matrix([0, 0, 1])
    e_u = sp.cos(th) * e_z - sp.sin(th) * e_l      # ϑ > 0 tilts to the right (eq. 2)
    e_a = e_u.cross(e_f)
    Omega = psi.diff(t) * e_z + th.diff(t) * e_f
    e_z1 = sp.sin(phi) * e_f + sp.cos(phi) * e_u
    e_x1 = sp.cos(phi) * e_f - sp.sin(phi) * e_u

    def rider(lean, J_axis):
        """Kane's generalised forces (x, γ, φ rows) of the rider leaning by ``lean``."""
        n = sp.cos(lean) * e_z1 - sp.sin(lean) * e_a
        r_PG = (R - l0 * sp.cos(gamma)) * e_u - l0 * sp.sin(gamma) * e_f + h * n
        v = qd[0] * e_f + r_PG.diff(t)
        a = v.diff(t)
        w = Omega + qd[2] * e_a + lean.diff(t) * e_x1
        I = J * sp.eye(3) + (J_axis - J) * n * n.T
        rot = I * w.diff(t) + w.cross(I * w)
        F = sp.zeros(3, 1)
        for i, u in enumerate(qd):
            F[i] = m * ((a + g * e_z).T * v.diff(u))[0] + (rot.T * w.diff(u))[0]
        return F

    Q = rider(sp.Integer(0), J) - rider(lam, J_z)
    sym = sp.symbols("gamma phi x_d gamma_d phi_d theta theta_d psi_d psi_dd lean lean_d theta_dd "
                     "acc0 acc1 acc2 lean_dd")
    rep = [(lam.diff(t, 2), sym[15]), (th.diff(t, 2), sym[11]), (psi.diff(t, 2), sym[8])]
    rep += [(s.diff(t, 2), sym[12 + k]) for k, s in enumerate((x, gamma, phi))]
    rep += [(lam.diff(t), sym[10]), (th.diff(t), sym[6]), (psi.diff(t), sym[7])]
    rep += [(qd[0], sym[2]), (qd[1], sym[3]), (qd[2], sym[4])]
    rep += [(gamma, sym[0]), (phi, sym[1]), (th, sym[5]), (lam, sym[9])]
    Q = Q.subs(rep).subs(psi, 0)    # ψ itself drops out of every projection
    return (R, m, J, J_z, l0, h, g) + tuple(sym), Q

"""diagnosis.prepare reads the rider's lateral lean from G out of the EUC's plane."""

import numpy as np
import pandas as pd

from euc_sim.diagnosis.prepare import prepare
from euc_sim.model.parameters import TABLE3


def _rot(axis, a):
    c, s = np.cos(a), np.sin(a)
    o, z = np.ones_like(a), np.zeros_like(a)
    rows = {"x": ((o, z, z), (z, c, -s), (z, s, c)), "y": ((c, z, s), (z, o, z), (-s, z, c)),
            "z": ((c, -s, z), (s, c, z), (z, z, o))}[axis]
    return np.stack([np.stack(r, -1) for r in rows], -2)


def _turning_recording(lean_amplitude: float):
    """Motion capture of a rider circling at 2 m/s (R 4 m), leaning λ(t) relative to
    the EUC as the 3-D model's hinges: G − C = R_t Ry(γ)(0, 0, −l0) + R_t Ry(φ) Rx(λ)(0, 0, h)."""
    p = TABLE3
    t = np.arange(0.0, 10.0, 1.0 / 120.0)
    psi = 0.5 * t
    theta = -0.1 + 0.02 * np.sin(1.3 * t)
    gamma = 0.02 * np.sin(2.0 * t)
    phi = 0.03 * np.sin(1.1 * t)
    lean = lean_amplitude * np.sin(0.8 * t)
    C = np.column_stack([4.0 * np.sin(psi), 4.0 * (1 - np.cos(psi)), np.full_like(t, p.R)])
    Rt = _rot("z", psi) @ _rot("x", theta)
    A = C + np.einsum("nij,j->ni", Rt @ _rot("y", gamma), [0.0, 0.0, -p.l0])
    G = A + np.einsum("nij,j->ni", Rt @ _rot("y", phi) @ _rot("x", lean), [0.0, 0.0, p.h])
    df = pd.DataFrame({"t": t, "psi": psi, "theta": theta, "gamma": gamma,
                       **{f"C_{a}": C[:, i] for i, a in enumerate("XYZ")},
                       **{f"G_{a}": G[:, i] for i, a in enumerate("XYZ")}})
    return df, lean, 0.8 * lean_amplitude * np.cos(0.8 * t)


def test_the_lean_is_recovered_from_the_markers_whatever_h():
    df, lean, lean_d = _turning_recording(0.12)
    prep = prepare(df, params=TABLE3, meta={"name": "lean"})
    k = slice(120, -120)
    np.testing.assert_allclose(prep.lateral["lean"][k], lean[k], atol=2e-4)
    np.testing.assert_allclose(prep.lateral["lean_d"][k], lean_d[k], atol=2e-3)
    assert {"theta_dd", "psi_dd"} <= set(prep.lateral)


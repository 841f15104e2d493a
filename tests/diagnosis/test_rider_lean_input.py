"""diagnosis.prepare reads the rider's lateral lean from G out of the EUC's plane."""

import numpy as np
import pandas as pd
from scipy.spatial.transform import Rotation

from euc_sim.diagnosis.prepare import prepare
from euc_sim.model.parameters import TABLE3


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
    body = Rotation.from_euler("ZXY", np.column_stack([psi, theta, gamma]))     # Rz Rx Ry, intrinsic
    rider = Rotation.from_euler("ZXY", np.column_stack([psi, theta, phi])) * Rotation.from_euler("X", lean[:, None])
    A = C + body.apply([0.0, 0.0, -p.l0])
    G = A + rider.apply([0.0, 0.0, p.h])
    E = C + body.apply([0.0, 0.0, 0.42])
    df = pd.DataFrame({"t": t, "psi": psi, "theta": theta, "gamma": gamma,
                       **{f"C_{a}": C[:, i] for i, a in enumerate("XYZ")},
                       **{f"E_{a}": E[:, i] for i, a in enumerate("XYZ")},
                       **{f"G_{a}": G[:, i] for i, a in enumerate("XYZ")}})
    return df, lean, 0.8 * lean_amplitude * np.cos(0.8 * t)


def test_the_lean_is_recovered_from_the_markers_whatever_h():
    df, lean, lean_d = _turning_recording(0.12)
    prep = prepare(df, params=TABLE3, meta={"name": "lean"})
    k = slice(120, -120)
    np.testing.assert_allclose(prep.lateral["lean"][k], lean[k], atol=2e-4)
    np.testing.assert_allclose(prep.lateral["lean_d"][k], lean_d[k], atol=2e-3)
    assert {"theta_dd", "psi_dd"} <= set(prep.lateral)


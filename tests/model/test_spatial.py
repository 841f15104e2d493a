"""The spatial model: named readouts, Euler angles of Fig. 2, the tyre on the floor,
and MuJoCo's linearisation of lateral motion checked against MuJoCo itself."""

import math

import mujoco
import numpy as np
import pytest

from euc_sim.model.mujoco_model import ModelError
from euc_sim.model.parameters import TABLE3
from euc_sim.model.spatial import EucSpatial, TyreContact, euler_rates, euler_yaw_tilt_pitch


def _R(psi, theta, gamma):
    cz, sz, cx, sx, cy, sy = (math.cos(psi), math.sin(psi), math.cos(theta), math.sin(theta),
                              math.cos(gamma), math.sin(gamma))
    Rz = np.array([[cz, -sz, 0], [sz, cz, 0], [0, 0, 1]])
    Rx = np.array([[1, 0, 0], [0, cx, -sx], [0, sx, cx]])
    Ry = np.array([[cy, 0, sy], [0, 1, 0], [-sy, 0, cy]])
    return Rz @ Rx @ Ry


def test_euler_angles_invert_yaw_tilt_pitch():
    for angles in [(0.3, -0.2, 0.1), (-2.5, 0.4, -0.3), (3.0, 0.0, 0.05)]:
        assert np.allclose(euler_yaw_tilt_pitch(_R(*angles)), angles, atol=1e-12)


def test_euler_rates_from_angular_velocity():
    a = np.array([0.4, 0.2, -0.1])
    rates = np.array([0.7, -0.3, 1.1])
    h = 1e-7
    Rd = (_R(*(a + h * rates)) - _R(*(a - h * rates))) / (2 * h)
    W = Rd @ _R(*a).T                                   # [ω]×
    omega = np.array([W[2, 1], W[0, 2], W[1, 0]])
    assert np.allclose(euler_rates(a[0], a[1], omega), rates, atol=1e-6)


def test_resting_model_reads_by_name():
    sim = EucSpatial()
    sim.set_straight(0.0, heading=0.7)
    psi, theta, gamma = sim.euler()
    assert psi == pytest.approx(0.7) and abs(theta) < 1e-12 and abs(gamma) < 1e-12
    C, G = sim.site_pos("C"), sim.site_pos("G")
    assert C[2] == pytest.approx(TABLE3.R, abs=5e-4)              # static sinkage below 0.5 mm
    assert G[2] - C[2] == pytest.approx(TABLE3.h - TABLE3.l0, abs=1e-9)
    point, force = sim.contact()
    total = TABLE3.m + TABLE3.m0 + TABLE3.mw
    assert force[2] == pytest.approx(total * TABLE3.g, rel=1e-3)  # the floor carries the weight
    assert point[2] == pytest.approx(0.0, abs=5e-4)


def test_crown_radius_sets_the_tyre_section():
    sim = EucSpatial(tyre=TyreContact(crown_radius=0.05))
    gid = sim.tyre_geom
    a, w, c = sim.model.geom_size[gid]
    assert a == c == pytest.approx(TABLE3.R) and w * w / a == pytest.approx(0.05)


def test_bad_tyre_setting_is_named():
    with pytest.raises(ModelError, match="crown_radius"):
        TyreContact(crown_radius=-0.01)


def test_lateral_linearisation_predicts_mujoco():
    """Φ, Γ from mjd_transitionFD against a 0.2 s lean-torque pulse in MuJoCo."""
    from euc_sim.controllers.lateral import lateral_plant

    Phi, Gam = lateral_plant(speed=2.5)
    sim = EucSpatial()
    sim.set_straight(2.5)
    for _ in range(20):
        mujoco.mj_step(sim.model, sim.data)
    y0 = sim.data.qpos[sim.qadr["root"] + 1]
    z = np.zeros(11)
    for k in range(200):
        u = np.array([5.0, -2.0]) if k < 50 else np.zeros(2)
        z = Phi @ z + Gam @ u
        sim.set_torques(0.0, 0.0, *u)
        sim.step()
    psi, theta, _ = sim.euler()
    got = [sim.data.qpos[sim.qadr["root"] + 1] - y0, psi, theta,
           sim.data.qpos[sim.qadr["rider_lean"]], sim.data.qpos[sim.qadr["rider_twist"]]]
    assert np.allclose(got, z[:5], atol=0.03 * np.max(np.abs(z[:5])))

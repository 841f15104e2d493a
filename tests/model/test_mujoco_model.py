"""The MJCF model, its parameters through MjSpec, and the coordinate map."""

import mujoco
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from euc_sim.model import analytic as A
from euc_sim.model.mujoco_model import MJCF_PATH, ContactSettings, EucMujoco, JointIndex, ModelError, build_spec, from_mujoco, load_model, paper_jacobian, to_mujoco
from euc_sim.model.parameters import TABLE3


def test_xml_loads_on_its_own_with_table3():
    m = mujoco.MjModel.from_xml_path(str(MJCF_PATH))
    names = {mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_BODY, i) for i in range(m.nbody)}
    assert {"euc", "wheel", "rider"} <= names
    assert m.nu == 2 and m.nq == 4
    mass = {n: m.body(n).mass[0] for n in ("euc", "wheel", "rider")}
    assert mass == {"euc": 13.0, "wheel": 3.0, "rider": 65.0}
    # visual geoms carry no mass: the body masses are the explicit inertials
    assert m.body_subtreemass[m.body("euc").id] == pytest.approx(81.0)


def test_params_applied_through_mjspec():
    p = TABLE3.replace(h=0.75, m=80.0, R=0.25, l0=0.07, h0=0.1, Jw=0.2, J=20.0)
    m = load_model(p)
    assert m.body("rider").mass[0] == 80.0
    assert m.body("rider").ipos[2] == pytest.approx(0.75)
    assert m.body("rider").pos[2] == pytest.approx(-0.07)
    assert m.body("euc").ipos[2] == pytest.approx((p.m0 * 0.1) / (p.m0 + p.mw))   # with the wheel at C
    assert m.body("euc").pos[2] == pytest.approx(0.25)
    # ideal variant, reduced coordinates: the wheel turns at x/R, its spin inertia is the
    # slide's armature J_w/R², and its body (no joint) is fused into the EUC body
    assert m.dof_armature[m.joint("x").dofadr[0]] == pytest.approx(0.2 / 0.25**2)
    assert m.body("euc").mass[0] == pytest.approx(p.m0 + p.mw)
    assert m.body("rider").inertia[1] == pytest.approx(20.0)
    mc = load_model(p, "contact")
    assert mc.body("wheel").inertia[1] == pytest.approx(0.2)
    assert mc.dof_armature[mc.joint("x").dofadr[0]] == 0.0
    assert mc.geom("wheel_contact").size[0] == pytest.approx(0.25)
    assert mc.body("euc").ipos[2] == pytest.approx(0.1) and mc.body("euc").pos[2] == pytest.approx(0.25)


def test_ideal_variant_is_reduced():
    """No wheel hinge, no equality: three DoF, the motor on the rotor tendon x/R − gamma."""
    m = load_model()
    idx = JointIndex.of(m)
    assert (m.nq, m.nv, m.neq, m.nu) == (3, 3, 0, 2) and not idx.has_spin
    assert m.ngeom == 0 and m.nsite == 0 and m.nbody == 3            # physics only, wheel fused
    motor = m.actuator("motor")
    assert motor.trntype[0] == mujoco.mjtTrn.mjTRN_TENDON
    assert m.tendon(motor.trnid[0]).name == "motor_shaft"


def test_missing_file_and_missing_element(tmp_path):
    with pytest.raises(ModelError, match=r"MJCF file not found: .*nope.xml"):
        load_model(mjcf=tmp_path / "nope.xml")
    broken = tmp_path / "broken.xml"
    broken.write_text(MJCF_PATH.read_text().replace('name="rider"', 'name="passenger"'))
    with pytest.raises(ModelError, match=r"body 'rider' not found"):
        load_model(mjcf=broken)
    with pytest.raises(ModelError, match=r"unknown ground variant 'ice'.*ideal, contact"):
        build_spec(variant="ice")


def test_contact_variant_structure():
    m = load_model(variant="contact")
    idx = JointIndex.of(m)
    assert idx.has_z and m.neq == 0 and m.nq == 5
    assert m.geom("wheel_contact").contype == 1


@settings(max_examples=200, deadline=None)
@given(st.lists(st.floats(-10, 10), min_size=9, max_size=9), st.sampled_from(["ideal", "contact"]),
       st.floats(0.1, 0.4))
def test_map_round_trips(values, variant, R):
    idx = JointIndex.of(load_model(TABLE3.replace(R=R), variant)) if variant == "contact" else IDEAL_INDEX
    q, qd, qdd = np.reshape(values, (3, 3))
    qpos, qvel, qacc = to_mujoco(idx, R, q, qd, qdd)
    q2, qd2, qdd2 = from_mujoco(idx, qpos, qvel, qacc)
    np.testing.assert_allclose(q2, q, atol=1e-12)
    np.testing.assert_allclose(qd2, qd, atol=1e-12)
    np.testing.assert_allclose(qdd2, qdd, atol=1e-12)
    # the contact variant's wheel hinge is set to pure rolling: x = R (euc_pitch + wheel_spin)
    i = idx.qpos
    if variant == "contact":
        assert qpos[i["x"]] == pytest.approx(R * (qpos[i["euc_pitch"]] + qpos[i["wheel_spin"]]), abs=1e-9)


IDEAL_INDEX = JointIndex.of(load_model())


def test_map_by_name_not_by_position():
    """Reordering bodies in the XML changes qpos addresses but not the map's meaning."""
    spec = build_spec(variant="contact")            # the variant with a wheel hinge
    xml = spec.to_xml()
    # move the rider before the wheel: rider_pitch gets the lower address
    m = mujoco.MjModel.from_xml_string(xml)
    idx = JointIndex.of(m)
    T = paper_jacobian(idx, TABLE3.R)
    assert T.shape == (m.nv, 3)
    np.testing.assert_allclose(T[idx.dof["wheel_spin"]], [1 / TABLE3.R, -1, 0])
    np.testing.assert_allclose(T[idx.dof["rider_pitch"]], [0, -1, 1])


def test_named_readouts_and_state():
    sim = EucMujoco()
    sim.set_state([0.3, 0.02, -0.05], [1.2, 0.1, -0.2])
    np.testing.assert_allclose(sim.q, [0.3, 0.02, -0.05])
    np.testing.assert_allclose(sim.qd, [1.2, 0.1, -0.2])
    with pytest.raises(ValueError, match="state must be finite"):
        sim.set_state([0.0, np.nan, 0.0])


def test_actuator_signs_follow_eq8():
    """The motor and ankle actuators produce eq. (8)'s generalised forces."""
    sim = EucMujoco()
    q, qd = np.array([0.0, 0.03, -0.04]), np.array([2.0, 0.3, -0.1])
    M_d, M_h = 12.0, -7.0
    qdd = A.forward_dynamics(TABLE3, q, qd, M_d, M_h)
    np.testing.assert_allclose(sim.inverse(q, qd, qdd), [M_d / TABLE3.R, M_h - M_d, -M_h], atol=1e-10)
    # and in MuJoCo's own joint space: ctrl = (M_d, M_h) is qfrc_actuator on the two joints
    sim.set_state(q, qd)
    sim.set_torques(M_d, M_h)
    mujoco.mj_forward(sim.model, sim.data)
    act = sim.T.T @ sim.data.qfrc_actuator
    np.testing.assert_allclose(act, [M_d / TABLE3.R, M_h - M_d, -M_h], atol=1e-12)


def test_disc_rolls_down_incline_in_contact_variant():
    """A uniform disc on a slope (friction) accelerates at 2 g sin α / 3."""
    tiny = 1e-5
    p = TABLE3.replace(m=tiny, m0=tiny, J=tiny, J0=tiny, Jw=0.5 * 3.0 * 0.2**2)
    sim = EucMujoco(p, "contact")
    alpha = 0.1
    sim.model.opt.gravity[:] = [-p.g * np.sin(alpha), 0.0, -p.g * np.cos(alpha)]
    sim.set_state([0.0, 0.0, 0.0], [0.0, 0.0, 0.0])
    sim.step(500)
    xd = sim.qd[0]
    assert xd / sim.data.time == pytest.approx(-2 * p.g * np.sin(alpha) / 3, rel=2e-3)


def test_contact_settings_validated():
    with pytest.raises(ModelError, match=r"'friction' must be positive"):
        ContactSettings(friction=0.0)


def test_disc_rolls_down_incline_in_ideal_variant():
    """Reduced coordinates: a uniform disc on a slope accelerates at exactly 2 g sin α / 3
    (the spin inertia on the slide's armature, no constraint to soften it)."""
    tiny = 1e-9
    p = TABLE3.replace(m=tiny, m0=tiny, J=tiny, J0=tiny, Jw=0.5 * 3.0 * 0.2**2)
    sim = EucMujoco(p)
    alpha = 0.1
    sim.model.opt.gravity[:] = [-p.g * np.sin(alpha), 0.0, -p.g * np.cos(alpha)]
    sim.set_state([0.0, 0.0, 0.0], [0.0, 0.0, 0.0])
    assert sim.qdd[0] == pytest.approx(-2 * p.g * np.sin(alpha) / 3, rel=1e-7)

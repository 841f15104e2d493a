"""The cross-check functions: they pass on the model and fail on a wrong one."""

import numpy as np

from euc_sim.model import crosscheck as cc
from euc_sim.model.mujoco_model import MJCF_PATH
from euc_sim.model.parameters import TABLE3

SMALL = {"table3": TABLE3, "light_tall": cc.PARAMETER_SETS["light_tall"]}


def test_static_checks_pass_at_round_off():
    for check in (cc.check_static(what, SMALL, n=200) for what in cc.STATIC_CHECKS):
        assert check.ok, check
        assert check.value < 1e-10


def test_static_check_detects_a_wrong_inertia(tmp_path):
    """A flipped rider hinge axis in the XML (a sign error MjSpec does not touch) is caught."""
    text = MJCF_PATH.read_text()
    wrong = tmp_path / "wrong.xml"
    wrong.write_text(text.replace('<joint name="rider_pitch" type="hinge" axis="0 1 0"/>',
                                  '<joint name="rider_pitch" type="hinge" axis="0 -1 0"/>'))
    check = cc.check_static("mass", {"table3": TABLE3}, n=50, mjcf=wrong)
    assert not check.ok and check.value > 1e-3


def test_forward_and_energy_checks():
    checks = cc.check_forward(duration=2.0) + cc.check_energy(duration=2.0)
    for c in checks:
        assert c.ok, c


def test_contact_error_shrinks_with_stiffness():
    rows = cc.contact_convergence(duration=1.0, timeconsts=(0.02, 0.002))
    (_, loose), (_, stiff) = rows
    assert stiff < loose
    assert stiff < cc.CONTACT_BOUND


def test_check_json_form():
    c = cc.Check("x", 1e-9, 1e-8, "d")
    assert c.as_json() == {"name": "x", "value": 1e-9, "bound": 1e-8, "detail": "d", "ok": True}
    assert not cc.Check("y", float("nan"), 1.0).ok


def test_random_states_reproducible():
    a = cc.random_states(10, seed=4)
    b = cc.random_states(10, seed=4)
    for u, v in zip(a, b):
        np.testing.assert_array_equal(u, v)

import math

import pytest

from euc_sim.model.parameters import TABLE3, ParameterError, Params, names


def test_table3_values():
    p = TABLE3
    assert (p.R, p.m, p.m0, p.mw, p.J, p.Jw, p.J0, p.h0, p.l0, p.h) == (
        0.2, 65.0, 13.0, 3.0, 16.6, 0.12, 0.5, 0.075, 0.05, 0.6)
    assert p.m0 + p.mw == 16.0          # Table 3: EUC total mass
    assert p.m_eq == pytest.approx(65 + 13 + 3 + 0.12 / 0.04)


def test_immutable():
    with pytest.raises(AttributeError):
        TABLE3.m = 70.0


@pytest.mark.parametrize("name", ["R", "m", "m0", "mw", "J", "Jw", "h", "g"])
def test_non_positive_is_named(name):
    with pytest.raises(ParameterError, match=rf"parameter '{name}' .* must be positive, got 0.0"):
        TABLE3.replace(**{name: 0.0})
    with pytest.raises(ValueError, match=rf"'{name}'.*-1.0"):
        TABLE3.replace(**{name: -1.0})


@pytest.mark.parametrize("name", ["J0", "h0", "l0"])
def test_offsets_may_be_zero_not_negative(name):
    assert getattr(TABLE3.replace(**{name: 0.0}), name) == 0.0
    with pytest.raises(ParameterError, match=rf"'{name}'.*non-negative"):
        TABLE3.replace(**{name: -0.01})


@pytest.mark.parametrize("bad", [math.nan, math.inf, -math.inf])
def test_non_finite(bad):
    with pytest.raises(ParameterError, match=r"parameter 'h' .* must be finite"):
        Params(h=bad)


def test_not_a_number():
    with pytest.raises(ParameterError, match=r"parameter 'm' .* must be a number, got 'heavy'"):
        Params(m="heavy")


def test_unknown_name():
    with pytest.raises(ParameterError, match=r"unknown parameter 'mass'"):
        TABLE3.replace(mass=3)


def test_from_mapping_and_reduced():
    p = Params.from_mapping({"h": 0.7})
    assert p.h == 0.7 and p.m == 65.0
    r = p.reduced()
    assert (r.J0, r.h0, r.l0) == (0.0, 0.0, 0.0)
    assert set(p.as_dict()) == set(names())

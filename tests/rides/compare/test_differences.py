"""What differs between two rides: intervals, the naming rule, aliases, the adapter, the sentence."""

import math
from dataclasses import replace

import numpy as np
import pytest

from euc_sim.rides.compare import differences as df
from euc_sim.rides.grids.power import RHO_AIR
from euc_sim.report.ride.contract import difference_json, differences_json


def _ride(seed, n=4000):
    rng = np.random.default_rng(seed)
    t = np.arange(n) * 0.1
    v = 8.0 + 4.0 * np.sin(2 * np.pi * t / 50.0) + 2.0 * np.sin(2 * np.pi * t / 170.0)
    av = v * np.gradient(v, t)
    P = 90.0 * av + 20.0 * v + 0.3 * v ** 3 + 5.0 * rng.standard_normal(n)
    return t, v, av, P


def test_difference_interval_of_two_symmetric_intervals():
    d, (lo, hi) = df.difference_interval(1.0, (0.7, 1.3), 1.5, (1.1, 1.9))
    assert d == pytest.approx(0.5)
    assert hi - d == pytest.approx(math.hypot(0.3, 0.4))
    assert d - lo == pytest.approx(math.hypot(0.3, 0.4))


def test_ratio_interval_in_logarithms():
    r, (lo, hi) = df.difference_interval(1.0, (0.99, 1.01), 0.95, (0.94, 0.96), ratio=True)
    assert r == pytest.approx(-0.05)
    assert lo < r < hi < 0


def test_aliases_drag_and_rolling_on_a_steady_ride_not_mass():
    t = np.arange(3000) * 0.1
    v = 10.0 + 0.5 * np.sin(2 * np.pi * t / 40.0)
    av = v * np.gradient(v, t)
    cols = df.signature_columns(v, av, 100.0 * v, t, coef={"total_mass": 100.0})
    aliases, cannot = df.alias_table(cols)
    assert "rolling_resistance" in aliases["aerodynamic_drag"]
    assert "aerodynamic_drag" not in aliases["total_mass"]
    assert not cannot


def test_constant_signature_cannot_be_seen():
    t = np.arange(500) * 0.1
    v = np.full_like(t, 8.0)
    cols = df.signature_columns(v, np.zeros_like(t), 100.0 * v, t)
    _, cannot = df.alias_table(cols)
    assert "total_mass" in cannot


def _params(mass, cdA, crr, R, scale, w=0.02):
    from types import SimpleNamespace

    from euc_sim.rides.drive.drivetrain import Term

    return df.parameters_from_fit(
        SimpleNamespace(estimate=mass, ci95=(mass - 20, mass + 20), stat_ci95=(mass - 5, mass + 5), lag=0.0),
        {"C_dA": Term(cdA, (cdA - 0.05, cdA + 0.05), "m^2"),
         "C_rr": Term(crr, (crr - 0.002, crr + 0.002), "dimensionless"),
         "internal_resistance": Term(R, (R - 0.01, R + 0.01), "ohm"),
         "speed_scale": Term(scale, (scale - w, scale + w), "dimensionless"),
         "ocv_start": Term(84.0, (83.9, 84.1), "V")})


def test_adapter_maps_names_and_drag_area_to_k():
    p = {x.name: x for x in _params(100.0, 0.5, 0.01, 0.2, 1.0)}
    assert p["aerodynamic_drag"].estimate == pytest.approx(0.5 * RHO_AIR * 0.5)
    assert p["aerodynamic_drag"].unit == "kg/m"
    assert p["total_mass"].ci95 == (95.0, 105.0)          # statistical part
    assert p["current_delay"].ci95 is None
    assert {"rolling_resistance", "internal_resistance", "speed_scale", "ocv_start"} <= set(p)


def _tested(**kw):
    """Pair-fit entries: name=(estimate, lo, hi, significant): p = 0.001 where significant, else 0.4."""
    return {n: df.Tested(e, (lo, hi), 0.05 if kept else 0.001, kept, 0.001 if kept else 0.4)
            for n, (e, lo, hi, kept) in kw.items()}


def test_drag_named_alone_and_said_in_a_riders_words():
    a, b = _params(100.0, 0.5, 0.01, 0.2, 1.0), _params(100.0, 0.8, 0.01, 0.2, 1.0)
    res = df.ride_differences(a, b, _tested(aerodynamic_drag=(0.18, 0.1, 0.26, True),
                                            rolling_resistance=(0.001, -0.01, 0.012, False)),
                              {}, {}, "the 16 May ride")
    named = [d.name for d in res.items if d.named]
    assert named == ["aerodynamic_drag"]
    drag = next(d for d in res.items if d.name == "aerodynamic_drag")
    assert drag.estimate == pytest.approx(0.18)                     # the pair fit's
    assert drag.independent[0] == pytest.approx(0.5 * RHO_AIR * 0.3)   # the rides' own, beside it
    assert "0.18 kg/m more drag" in res.sentence and "16 May" in res.sentence
    js = differences_json(res)
    assert {"name", "estimate", "ci95", "unit", "named", "why", "aliases", "independent"} \
        <= set(js["differences"][0])
    assert "named_given_log_model" not in js["differences"][0]


def test_interval_alone_does_not_name_when_not_significant():
    a, b = _params(100.0, 0.5, 0.01, 0.2, 1.0), _params(100.0, 0.8, 0.01, 0.2, 1.0)
    res = df.ride_differences(a, b, _tested(aerodynamic_drag=(0.18, 0.1, 0.26, False)), {}, {}, "x")
    assert not any(d.named for d in res.items)
    assert "nothing" in res.sentence


def test_significant_but_interval_through_zero_is_not_named():
    a, b = _params(100.0, 0.5, 0.01, 0.2, 1.0), _params(100.0, 0.5, 0.01, 0.2, 1.0)
    res = df.ride_differences(a, b, _tested(total_mass=(10.0, -2.0, 22.0, True)), {}, {}, "x")
    m = next(d for d in res.items if d.name == "total_mass")
    assert not m.named and "includes zero" in m.why


def test_state_of_charge_never_named():
    a, b = _params(100.0, 0.5, 0.01, 0.2, 1.0), _params(100.0, 0.5, 0.01, 0.2, 1.0)
    b = [replace(p, estimate=80.0, ci95=(79.9, 80.1)) if p.name == "ocv_start" else p for p in b]
    res = df.ride_differences(a, b, _tested(), {}, {}, "x")
    ocv = next(d for d in res.items if d.name == "ocv_start")
    assert ocv.estimate == pytest.approx(-4.0) and not ocv.named


def test_unseen_physics_is_never_named():
    a, b = _params(100.0, 0.5, 0.01, 0.2, 1.0), _params(130.0, 0.5, 0.01, 0.2, 1.0)
    cannot = {"total_mass": "its signature does not vary on these rides"}
    res = df.ride_differences(a, b, _tested(total_mass=(30.0, 20.0, 40.0, True)), {}, cannot, "x")
    m = next(d for d in res.items if d.name == "total_mass")
    assert not m.named and m.why == cannot["total_mass"]


def test_speed_scale_is_a_ratio_minus_one():
    a, b = _params(100.0, 0.5, 0.01, 0.2, 1.0, 0.005), _params(100.0, 0.5, 0.01, 0.2, 1 / 1.05, 0.005)
    res = df.ride_differences(a, b, {}, {}, {}, "x")
    s = next(d for d in res.items if d.name == "speed_scale")
    assert s.estimate == pytest.approx(1 / 1.05 - 1) and not s.named and s.unit == "1"


def test_mass_difference_view_is_the_independent_detail():
    a, b = _params(100.0, 0.5, 0.01, 0.2, 1.0), _params(130.0, 0.5, 0.01, 0.2, 1.0)
    from euc_sim.rides.source.systematic import MassDifference

    view = MassDifference(29.0, (10.0, 48.0), "heavier")
    res = df.ride_differences(a, b, _tested(total_mass=(31.0, 22.0, 40.0, True)), {}, {}, "x",
                              views={"mass_difference": view})
    m = next(d for d in res.items if d.name == "total_mass")
    assert m.estimate == pytest.approx(31.0) and m.named
    assert m.independent[0] == pytest.approx(29.0) and m.independent[1] == pytest.approx((10.0, 48.0))


def test_a_tested_delay_reaches_the_list_with_its_unit():
    a, b = _params(100.0, 0.5, 0.01, 0.2, 1.0), _params(100.0, 0.5, 0.01, 0.2, 1.0)
    res = df.ride_differences(a, b, _tested(current_delay=(0.39, 0.34, 0.44, True)), {}, {}, "x")
    d = next(d for d in res.items if d.name == "current_delay")
    assert d.named and d.unit == "s" and "0.4 s more delay" in res.sentence


def test_q_values_control_the_false_names_across_the_tested_physics():
    a, b = _params(100.0, 0.5, 0.01, 0.2, 1.0), _params(100.0, 0.5, 0.01, 0.2, 1.0)
    tested = _tested(total_mass=(30.0, 20.0, 40.0, True), aerodynamic_drag=(0.18, 0.1, 0.26, True),
                     rolling_resistance=(0.01, 0.002, 0.02, True), drivetrain_idle_loss=(5.0, 1.0, 9.0, True))
    # alone below 5 %, not after the control over three
    tested["total_mass"] = replace(tested["total_mass"], p_value=0.04)
    tested["rolling_resistance"] = replace(tested["rolling_resistance"], p_value=0.01)
    res = df.ride_differences(a, b, tested, {}, {}, "x")
    by = {d.name: d for d in res.items}
    # the family: the three tested physics (the idle loss is a nuisance, never named, not counted)
    assert by["aerodynamic_drag"].q_value == pytest.approx(0.003)
    assert by["rolling_resistance"].q_value == pytest.approx(0.015)
    assert by["total_mass"].q_value == pytest.approx(0.04)
    assert by["drivetrain_idle_loss"].q_value is None and not by["drivetrain_idle_loss"].named
    tested["total_mass"] = replace(tested["total_mass"], p_value=0.06)
    by = {d.name: d for d in df.ride_differences(a, b, tested, {}, {}, "x").items}
    assert [n for n, d in by.items() if d.named] == ["aerodynamic_drag", "rolling_resistance"]
    js = difference_json(by["total_mass"])
    assert js["p_value"] == pytest.approx(0.06) and js["q_value"] == pytest.approx(0.06)
    assert "alias_set" not in js and "not significant" in js["why"]


def test_an_alias_set_is_said_on_the_named_entry_and_in_the_sentence():
    a, b = _params(100.0, 0.5, 0.01, 0.2, 1.0), _params(100.0, 0.5, 0.01, 0.2, 1.0)
    tested = _tested(aerodynamic_drag=(0.18, 0.1, 0.26, True), rolling_resistance=(0.01, -0.01, 0.03, False))
    tested["aerodynamic_drag"] = replace(tested["aerodynamic_drag"], alias_set=(
        "aerodynamic_drag", "rolling_resistance", "drivetrain_idle_loss"))
    res = df.ride_differences(a, b, tested, {}, {}, "the 16 May ride")
    by = {d.name: difference_json(d) for d in res.items}
    assert by["aerodynamic_drag"]["named"]
    assert by["aerodynamic_drag"]["alias_set"] == ["aerodynamic_drag", "rolling_resistance"]
    assert "alias_set" not in by["rolling_resistance"]
    assert "drag or rolling resistance: this pair cannot tell them apart" in res.sentence
    assert "16 May" in res.sentence


def test_a_delay_within_the_logs_resolution_is_not_named():
    a, b = _params(100.0, 0.5, 0.01, 0.2, 1.0), _params(100.0, 0.5, 0.01, 0.2, 1.0)
    tested = _tested(current_delay=(0.07, 0.06, 0.08, True))
    tested["current_delay"] = replace(tested["current_delay"], resolution=0.1)
    res = df.ride_differences(a, b, tested, {}, {}, "x")
    d = next(d for d in res.items if d.name == "current_delay")
    assert not d.named and "resolve" in d.why


def test_the_page_names_the_alias_set():
    from euc_sim.report.ride.differences_page import difference_lines

    a, b = _params(100.0, 0.5, 0.01, 0.2, 1.0), _params(100.0, 0.5, 0.01, 0.2, 1.0)
    tested = _tested(aerodynamic_drag=(0.18, 0.1, 0.26, True), rolling_resistance=(0.01, -0.01, 0.03, False))
    tested["aerodynamic_drag"] = replace(tested["aerodynamic_drag"],
                                         alias_set=("aerodynamic_drag", "rolling_resistance"))
    lines = difference_lines(df.ride_differences(a, b, tested, {}, {}, "x"), "b.csv")
    assert any(line.startswith("- Drag area: 95 % interval") and
               "drag area or rolling resistance: this pair cannot tell them apart" in line for line in lines)


def test_compare_returns_no_plain_dict():
    """The pair comparison returns typed records; a dict only as a mapping keyed by name (``dict[str, X]``)."""
    import ast
    from pathlib import Path

    folder = Path(df.__file__).parent
    plain = [f"{p.name}:{fn.name}" for p in sorted(folder.glob("*.py"))
             for fn in ast.walk(ast.parse(p.read_text()))
             if isinstance(fn, ast.FunctionDef) and fn.returns is not None
             and ast.unparse(fn.returns) in ("dict", "list[dict]")]
    assert not plain

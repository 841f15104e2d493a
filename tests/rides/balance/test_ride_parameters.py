"""The ride's one parameter set: bounded fits, the held-out selection, ``parameters`` and its views.

Twin experiments (synthetic WheelLog logs with known physics, :mod:`ridesynth`) and
:mod:`euc_sim.stats`'s pieces; the real logs' checks are in ``test_ride_pages.py``.
"""

from __future__ import annotations

import re

import numpy as np
import pytest
from ridesynth import TRUTH, synth_log

from euc_sim.rides.balance.crossride import (admissible, cross_ride, heldout_score,
                                             select_effects)
from euc_sim.rides.balance.design import (BOUNDS, CANDIDATES, NOMINAL, PLAUSIBLE, balance_design,
                                          on_bound)
from euc_sim.rides.balance.fit import fit_balance, plausibility
from euc_sim.rides.balance.normal import coefficients
from euc_sim.rides.balance.parameters import Parameter, drivetrain_view, effect_estimates, parameter_list
from euc_sim.rides.balance.verdict import ride_verdict, verdict_of
from euc_sim.rides.grids.signals import ride_signals
from euc_sim.stats import forward_select, percentile_interval, time_blocks, wild_block_signs
from euc_sim.rides.source.logs import read_log


@pytest.fixture(scope="module")
def designs(tmp_path_factory):
    d = tmp_path_factory.mktemp("params")
    fit = balance_design(ride_signals(read_log(synth_log(d / "fit.csv", seed=21), emit_warnings=False)))
    test = balance_design(ride_signals(read_log(synth_log(d / "test.csv", seed=22), emit_warnings=False)))
    return fit, test


# --- euc_sim.stats ---------------------------------------------------------------------
def test_time_blocks_are_contiguous_and_equal():
    label = time_blocks(np.linspace(0.0, 99.0, 100), 5)
    assert np.all(np.diff(label) >= 0) and np.bincount(label).tolist() == [20] * 5


def test_forward_select_keeps_only_what_lowers_the_score():
    errors = {(): 10.0, ("a",): 6.0, ("b",): 9.95, ("a", "b"): 5.99, ("c",): np.inf, ("a", "c"): 1.0}
    score = lambda names: errors.get(tuple(n for n in names if n != "base"), 10.0)  # noqa: E731
    names, history = forward_select(score, ["base"], ["a", "b", "c"], min_gain=0.01)
    # "c" alone is not admissible (inf); after "a" it lowers the score most; "b" gains < 1 %
    assert names == ["base", "a", "c"]
    assert [h["term"] for h in history] == ["base", "a", "c"]


def test_forward_select_takes_two_terms_that_are_admissible_only_together():
    # "a" and "b" alone are not admissible (inf), together they halve the error; "c" gains 5 %
    errors = {(): 10.0, ("a",): np.inf, ("b",): np.inf, ("c",): 9.5, ("a", "b"): 5.0,
              ("a", "c"): np.inf, ("b", "c"): np.inf, ("a", "b", "c"): 4.99}
    score = lambda names: errors[tuple(sorted(n for n in names if n != "base"))]  # noqa: E731
    one, _ = forward_select(score, ["base"], ["a", "b", "c"], min_gain=0.01)
    assert one == ["base", "c"]                      # one term per step never reaches {a, b}
    two, history = forward_select(score, ["base"], ["a", "b", "c"], min_gain=0.01, max_step=2)
    assert two == ["base", "a", "b"]                 # c then gains < 1 %
    assert [h["term"] for h in history] == ["base", "a+b"]


def test_forward_select_takes_two_terms_that_each_gain_too_little_alone():
    # "a" and "b" each lower the error by 0.5 % (below the 1 % gate), together by 3 %
    errors = {(): 10.0, ("a",): 9.95, ("b",): 9.95, ("c",): 9.97, ("a", "b"): 9.7,
              ("a", "c"): 9.93, ("b", "c"): 9.93, ("a", "b", "c"): 9.69}
    score = lambda names: errors[tuple(sorted(n for n in names if n != "base"))]  # noqa: E731
    one, _ = forward_select(score, ["base"], ["a", "b", "c"], min_gain=0.01)
    assert one == ["base"]
    two, history = forward_select(score, ["base"], ["a", "b", "c"], min_gain=0.01, max_step=2)
    assert two == ["base", "a", "b"] and history[-1]["term"] == "a+b"


def test_percentile_interval_and_wild_signs_are_seeded():
    draws = np.arange(1001, dtype=float)
    lo, hi = percentile_interval(draws)
    assert lo == pytest.approx(25.0) and hi == pytest.approx(975.0)
    assert percentile_interval(draws[:0]) is None
    s1 = wild_block_signs(25, 10, 3, np.random.default_rng(1))
    s2 = wild_block_signs(25, 10, 3, np.random.default_rng(1))
    assert s1.shape == (3, 3) and np.array_equal(s1, s2)         # one row per block of 10 rows
    assert set(np.unique(s1)) <= {-1.0, 1.0}


# --- bounded fits ----------------------------------------------------------------------
def test_the_balance_fits_no_efficiency_and_every_term_is_bounded_physically():
    assert NOMINAL == ()                                     # inertia only: nothing fitted
    assert not [n for n in CANDIDATES if n.startswith("eta")]
    for name in CANDIDATES:                                  # bounds within the plausible range
        lo, hi = BOUNDS[name]
        assert PLAUSIBLE[name][1] == hi
        assert lo == 0.0 or lo == PLAUSIBLE[name][0]


def test_a_copper_loss_beyond_its_plausible_range_sits_on_its_bound(designs):
    """Battery power with k_cu = 0.01 + 0.1 W/N² (a winding that burns more than the wheel
    moves): the bounded fit stops at the top of the plausible range; admissible there, and
    marked as on the edge (the data asks for more)."""
    d, _ = designs
    from dataclasses import replace

    P_full = d.P_full.copy()
    P_full[d.use] += 0.1 * d.operator.K @ d.operator.columns["copper"]
    heavy = replace(d, P_full=P_full)
    fit = fit_balance(heavy, sorted(TRUTH), n_boot=20, seed=1)
    assert fit.estimate["copper_loss"] == BOUNDS["copper_loss"][1]
    assert on_bound("copper_loss", fit.estimate["copper_loss"])
    assert all(BOUNDS[k][0] <= fit.ci95[k][0] <= fit.ci95[k][1] <= BOUNDS[k][1] for k in fit.names)
    assert "copper_loss" in admissible(fit, fit.names)
    phys = plausibility(fit)
    assert phys["copper_loss"]["on_bound"] and phys["copper_loss"]["plausible"]
    assert not phys["rolling_resistance"]["on_bound"]


def test_a_drag_beyond_its_plausible_range_is_accepted_on_its_edge_and_said(designs):
    """Drag six times a rider's: kept at the top of its plausible range (the most plausible
    drag gives), its entry and the verdict say the ride asks for more."""
    d, _ = designs
    from dataclasses import replace

    extra = 3.0 * d.operator.K @ d.operator.columns["drag"]
    P_full = d.P_full.copy()
    P_full[d.use] += extra                       # k = 0.35 + 3: C_dA 6 m², no rider
    heavy = replace(d, P_full=P_full)
    fit = fit_balance(heavy, list(NOMINAL) + ["aerodynamic_drag"], n_boot=0)
    assert fit.estimate["aerodynamic_drag"] == BOUNDS["aerodynamic_drag"][1]
    kept, _, blocked = select_effects(heavy, heavy.candidates)
    assert "aerodynamic_drag" in kept and "aerodynamic_drag" not in blocked
    full = fit_balance(heavy, list(NOMINAL) + kept, n_boot=0)
    assert admissible(full, kept) == kept                     # what is kept is all admissible
    assert plausibility(full)["aerodynamic_drag"]["on_bound"]
    assert np.isfinite(heldout_score(heavy, list(NOMINAL) + kept, admit="plausible"))
    cr = cross_ride(heavy, heavy, n_boot=0)
    entry = next(e for e in effect_estimates(cr, parameter_list(cr, None, {})) if e.name == "aerodynamic_drag")
    assert entry.on_bound and "ON THE EDGE" in entry.evidence
    params = {p.name: p for p in parameter_list(cr, None, {})}
    assert params["aerodynamic_drag"].accepted and "edge" in params["aerodynamic_drag"].why
    verdict = verdict_of(cr, parameter_list(cr, None, {}))
    assert "aerodynamic_drag" in verdict.named and re.search(r"\baerodynamic_drag\b[^;]* on the edge of (its|their) plausible", verdict.text)


def test_a_speed_squared_loss_would_impersonate_rolling_and_drag(tmp_path):
    """Why b·ω² (a hub motor's eddy-current loss) is no balance candidate: offered on the
    twin, which has rolling and drag and no b·ω², the selection names b and drops both
    (docs/missing_loss.md): over one ride's speeds v² is nearly a sum of |v| and |v|³."""
    from euc_sim.model.catalog import CATALOG, Balance, Effect

    name, unit = "speed_squared_loss", "W·s²/m²"
    record = Effect(name, "b", unit, "a loss b·v² drawn from the battery",
                    balance=Balance("b", unit, "loss b·v²", (0.0, 5.0), "Apex 0's free spin (docs/missing_loss.md)",
                                    (0.0, 5.0), 1.0, "column", "spin", "m²/s²", lambda b: b.L1(b.v ** 2)))
    assert name not in CATALOG
    CATALOG.add(record)
    try:
        fit_d = balance_design(ride_signals(read_log(synth_log(tmp_path / "fit.csv", seed=21), emit_warnings=False)))
        test_d = balance_design(ride_signals(read_log(synth_log(tmp_path / "test.csv", seed=22), emit_warnings=False)))
        cr = cross_ride(fit_d, test_d, n_boot=0)
    finally:
        CATALOG.remove(name)
    assert name in cr.accepted
    assert not {"rolling_resistance", "aerodynamic_drag"} & set(cr.accepted)


# --- the selection and the parameter set -----------------------------------------------
@pytest.fixture(scope="module")
def cross(designs):
    return cross_ride(*designs, n_boot=20, seed=2)


def test_held_out_selection_names_the_true_effects(cross):
    """The twin's losses, added to the demand in both regimes, are selected and recovered."""
    assert {"aerodynamic_drag", "rolling_resistance", "copper_loss"} <= set(cross.accepted)
    for name in ("aerodynamic_drag", "rolling_resistance", "copper_loss"):
        lo, hi = cross.augmented.ci95[name]
        assert lo <= TRUTH[name] <= hi, (name, cross.augmented.estimate[name], (lo, hi))
    h = [s["heldout_rmse"] for s in cross.selection]
    assert all(b < a for a, b in zip(h, h[1:]))              # each kept step lowered it
    assert cross.heldout_augmented <= 1.05 * cross.heldout_full


def test_parameters_list_each_quantity_once_and_accepts_only_plausible(cross):
    from types import SimpleNamespace

    from euc_sim.rides.drive.drivetrain import Term

    total = SimpleNamespace(estimate=84.0, ci95=(80.0, 88.0), why=None)
    dt = {"C_rr": Term(0.5, (0.4, 0.6), "dimensionless"),
          "internal_resistance": Term(0.2, (0.19, 0.21), "ohm"),
          "ocv_per_Ah": Term(-3.0, (-4.0, -2.0), "V/Ah")}
    params = parameter_list(cross, total, dt)
    names = [p.name for p in params]
    assert len(names) == len(set(names))
    assert "C_rr" not in names                                 # the mass fit's nuisance term
    by = {p.name: p for p in params}
    assert all(p.plausible for p in params if p.accepted)
    assert not [n for n in by if n.startswith("eta")]         # no efficiency anywhere
    assert not by["ocv_per_Ah"].accepted and by["internal_resistance"].accepted
    assert set(cross.accepted) <= {n for n, p in by.items() if p.accepted}
    view = drivetrain_view(dt, params)
    assert view["C_rr"].estimate == by["rolling_resistance"].estimate
    assert view["C_rr"].parameter == "rolling_resistance"
    assert view["copper_loss_per_force2"].estimate == by["copper_loss"].estimate


# --- the lag of the logged current ------------------------------------------------------
def _lagged_design(tmp_path, a: float):
    """The twin ride's design, its logged battery power through y[n] = (1 − a)·x[n] + a·y[n − 1].

    On the 10 Hz grid that filter's mean delay (its time constant to first order) is
    a/(1 − a)·0.1 s.
    """
    from dataclasses import replace

    from scipy.signal import lfilter

    sig = ride_signals(read_log(synth_log(tmp_path / "lag.csv", seed=23, noise_w=10.0), emit_warnings=False))
    raw = sig.raw.copy()
    if a > 0:
        P = raw["P"].to_numpy().copy()
        for s in np.unique(raw["segment"]):
            i = raw["segment"].to_numpy() == s
            P[i] = lfilter([1 - a], [1, -a], P[i], zi=[a * P[i][0]])[0]
        raw["P"] = P
    return balance_design(replace(sig, raw=raw))


def test_a_lagged_current_is_found_and_an_unlagged_one_is_not(tmp_path):
    names = ["copper_loss", "rolling_resistance", "aerodynamic_drag", "drivetrain_idle_loss",
             "current_lag"]
    a = 0.6
    lagged = fit_balance(_lagged_design(tmp_path, a), names, n_boot=0)
    plain = fit_balance(_lagged_design(tmp_path, 0.0), names, n_boot=0)
    assert abs(lagged.estimate["current_lag"] - a / (1 - a) * 0.1) < 0.02    # 0.15 s
    assert plain.estimate["current_lag"] < 0.02
    for fit in (lagged, plain):           # the physics is recovered with or without the lag
        assert abs(fit.estimate["rolling_resistance"] - TRUTH["rolling_resistance"]) < 0.005


def test_the_lag_jacobian_matches_finite_differences(designs):
    d, _ = designs
    names = ["copper_loss", "rolling_resistance", "current_lag"]
    th = np.array([0.01, 0.02, 0.2])
    J = d.basis.Z @ coefficients(d.basis.columns, names, th)[1]
    for j, h in enumerate([1e-8, 1e-8, 1e-6]):
        e = np.zeros_like(th)
        e[j] = h
        num = (d.residual(dict(zip(names, th + e))) - d.residual(dict(zip(names, th - e)))) / (2 * h)
        assert np.allclose(J[:, j], num, rtol=1e-4, atol=1e-6 * np.abs(num).max())


def test_the_standstill_power_caps_the_idle_drain():
    from euc_sim.rides.balance.crossride import _all_admissible
    from euc_sim.rides.balance.design import standstill_power

    rng = np.random.default_rng(5)
    v = np.r_[np.zeros(200), np.full(200, 5.0)]               # 20 s still, 20 s riding, 10 Hz
    P = np.r_[3.0 + rng.normal(0, 1, 200), np.full(200, 400.0)]
    cap = standstill_power(v, P, 10.0)
    assert cap == pytest.approx(np.percentile(P[:200], 75))
    assert standstill_power(v[110:], P[110:], 10.0) is None    # 9 s still: too little
    zeroed = np.where(v == 0, 0.0, P)                          # a report that zeroes small currents
    assert standstill_power(v, zeroed, 10.0) is None
    assert _all_admissible({"drivetrain_idle_loss": 2.0}, cap)
    assert not _all_admissible({"drivetrain_idle_loss": 50.0}, cap)
    assert _all_admissible({"drivetrain_idle_loss": 50.0}, None)


def test_a_term_fitted_to_absent_is_not_named(tmp_path):
    """A lag on its lower bound 0 (inside its plausible range 0-0.3 s) is 'absent': nothing
    to name, while the same fit's rolling resistance is admissible."""
    from dataclasses import replace

    names = ["rolling_resistance", "current_lag"]
    plain = fit_balance(_lagged_design(tmp_path, 0.0), names, n_boot=0)
    assert admissible(plain, names)[0] == "rolling_resistance"
    at_zero = replace(plain, estimate={**plain.estimate, "current_lag": 0.0})
    assert admissible(at_zero, names) == ["rolling_resistance"]


def test_the_verdict_says_what_is_held_out_and_why():
    """A named effect on its edge, and a candidate that helps only beside an implausible term."""
    from dataclasses import replace

    edge = Parameter("rolling_resistance", 0.05, None, "1", True, True, None, "balance", (0.005, 0.05), True)
    inside = Parameter("aerodynamic_drag", 0.3, None, "kg/m", True, True, None, "balance", (0.18, 0.6), False)
    selection = [{"term": "inertia only", "heldout_rmse": 500.0}]
    v = ride_verdict([edge, inside], selection, ["current_lag"])
    assert v.named == ("rolling_resistance", "aerodynamic_drag")
    assert "; rolling_resistance sits on the edge of its plausible range: the ride asks" in v.text
    assert "0.05" not in v.text and "0.3" not in v.text      # the values are the table's, said once
    three = ride_verdict([edge, replace(inside, on_bound=True), replace(edge, name="drivetrain_idle_loss")],
                         selection, ["current_lag"])
    assert ("rolling_resistance, aerodynamic_drag and drivetrain_idle_loss sit on the edge of their "
            "plausible ranges: the ride asks for more than plausible physics") in three.text
    assert "current_lag would lower the held-out error further only in a model" in v.text
    nothing = ride_verdict([], selection, ["current_lag"])
    assert nothing.named == () and "outside its plausible range, so nothing is named" in nothing.text

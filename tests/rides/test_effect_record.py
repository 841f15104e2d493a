"""One record added to the effect catalog, here and nowhere else, reaches every layer that reads it.

The record below (an eddy-current loss k_e·v² of the motor, W) exists only in this test:
no module names it.  Added to :data:`euc_sim.model.catalog.CATALOG`, it is a candidate of
the ride's balance fit (and found there on a ride that has it), part of the ride
simulation's battery power, concealable in a log, compared between two rides (a pair
fit names it in the ride that has more of it) and named on the differences page.
"""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pandas as pd
import pytest
import conceal as cc
import ridesynth

from euc_sim.model.catalog import CATALOG, Balance, Compare, Conceal, Effect, Words
from euc_sim.rides.balance.crossride import cross_ride, select_effects
from euc_sim.rides.balance.design import CANDIDATES, balance_design
from euc_sim.rides.balance.fit import fit_balance, plausibility
from euc_sim.rides.balance.parameters import effect_estimates, parameter_list
from euc_sim.rides.compare import differences as df
from euc_sim.rides.compare.differences_fit import PairDesign, pair_fit
from euc_sim.rides.compare.differences_report import _power_columns, _stack
from euc_sim.rides.grids.signals import ride_signals
from euc_sim.report.ride.differences_page import difference_lines
from euc_sim.rides.sim import sim_steps
from euc_sim.rides.sim.simulate import _on_grid
from euc_sim.rides.source.logs import read_log

NAME = "eddy_current_loss"
UNIT = "W·s²/m²"
EDDY = Effect(
    NAME, "k_e", UNIT, "the motor's eddy-current loss k_e·v², drawn from the battery",
    balance=Balance("k_e", UNIT, "eddy-current loss k_e·v²", (0.0, 10.0), "this test's own range", (0.0, 10.0),
                    1.0, "column", "eddy", "m²/s²", lambda b: b.L1(b.v ** 2),
                    electrical=lambda value, F, v: value * v ** 2),
    conceal=Conceal("wheel_power", UNIT, lambda kin, size, **kw: size * kin.v ** 2),
    compare=Compare(signature=lambda s: s.v ** 2, pair=lambda sh, m: sh["rolling"] ** 2, order=6),
    words=Words("eddy loss", "eddy-current loss", lambda k: k, f" {UNIT}", "{:.1f}", "more eddy-current loss",
                "less eddy-current loss", "a hotter motor?", "a cooler motor?",
                (f"{UNIT} more eddy-current loss", f"{UNIT} less eddy-current loss", "{:.1f}")))
TRUE_K = 3.0


@pytest.fixture
def eddy():
    """The catalog with the test's record added, as it was after the test."""
    assert NAME not in CATALOG
    CATALOG.add(EDDY)
    yield EDDY
    CATALOG.remove(NAME)


def test_the_record_is_selected_and_sized_by_the_balance_fit(eddy, tmp_path, monkeypatch):
    # the ride's truth: no drag (a k_e·v² loss and k·|v|³ are near aliases over 0-8 m/s), the eddy loss
    plain, truth = ridesynth.battery_power, {**ridesynth.TRUTH, "aerodynamic_drag": 0.0}
    monkeypatch.setattr(ridesynth, "battery_power",
                        lambda v, a, truth=truth, slope=0.0: plain(v, a, truth, slope) + TRUE_K * v ** 2)
    design, held = (balance_design(ride_signals(read_log(ridesynth.synth_log(tmp_path / f"eddy{seed}.csv", seed=seed,
                                                                             truth=truth), emit_warnings=False)))
                    for seed in (31, 33))
    assert NAME in design.candidates and "eddy" in design.columns_full
    assert CANDIDATES[NAME] == ("k_e", UNIT, "eddy-current loss k_e·v²", "eddy", "m²/s²")
    fit = fit_balance(design, ("copper_loss", "rolling_resistance", "drivetrain_idle_loss", NAME), n_boot=40)
    lo, hi = fit.ci95[NAME]
    assert lo < TRUE_K < hi and hi - lo < TRUE_K
    entry = plausibility(fit)[NAME]
    assert entry["plausible"] and entry["symbol"] == "k_e" and entry["unit"] == UNIT
    selected, _, _ = select_effects(design, design.candidates)
    assert NAME in selected
    cr = cross_ride(design, held, n_boot=20)          # the ride JSON's ``parameters`` and ``effects``
    assert NAME in cr.accepted and NAME in [e.name for e in effect_estimates(cr, parameter_list(cr, None, {}))]
    entry = next(p for p in parameter_list(cr, None, {}) if p.name == NAME)
    assert entry.accepted and entry.unit == UNIT


def test_the_record_is_simulated_in_the_ride_simulations_battery_power(eddy, tmp_path):
    assert NAME in sim_steps.power_terms()
    eff, notes = sim_steps.effects_to_inject({NAME: TRUE_K}, [NAME])
    assert eff == {} and notes[0].startswith(f"{NAME} = 3 is electrical")
    sig = ride_signals(read_log(ridesynth.synth_log(tmp_path / "ride.csv", seed=32, gap_at=None), emit_warnings=False))
    t = sig.frame["t"].to_numpy()
    run = pd.DataFrame({"t": t, "M_d": np.full(t.size, 10.0), "x_dot": np.full(t.size, 5.0),
                        "gamma_dot": np.zeros(t.size), "gamma": np.zeros(t.size)})
    with_loss = sim_steps.SimStep("drivetrain", "", power=sim_steps._power({NAME: TRUE_K}))
    without = sim_steps.SimStep("drivetrain", "", power={})
    P = [_on_grid(run, sig, step, 0.25, sim_steps.LogChannels(), {}, t)[1]["P"] for step in (with_loss, without)]
    ok = np.isfinite(P[0]) & np.isfinite(P[1])
    assert ok.sum() > 100
    np.testing.assert_allclose((P[0] - P[1])[ok], TRUE_K * 5.0 ** 2, rtol=1e-9)


def _raw(n=3000):
    """A synthetic EUC World table: speed waves on a flat road, a pack with no sag."""
    t = np.arange(n) * 0.2
    v = 8.0 + 4.0 * np.sin(2 * np.pi * t / 60.0)
    P = (20.0 + 0.3 * v ** 2 + 60.0 * np.gradient(v, t)) * v
    ts = pd.Timestamp("2025-05-16T10:00:00+02:00") + pd.to_timedelta(t, unit="s")
    return pd.DataFrame({"datetime": ts.strftime("%Y-%m-%dT%H:%M:%S.%f+0200"), "speed": v * 3.6,
                         "voltage": np.full(n, 84.0), "current": P / 84.0, "extra": [""] * n})


def test_the_record_is_concealable_in_a_log(eddy):
    assert cc.concealable()[NAME] == UNIT
    raw = _raw()
    out = cc.conceal(raw, NAME, TRUE_K, eta=1.0)
    v = raw["speed"].to_numpy() / 3.6
    moving = v > cc.V_MIN
    dP = (out["voltage"] * out["current"] - raw["voltage"] * raw["current"]).to_numpy()
    np.testing.assert_allclose(dP[moving], TRUE_K * v[moving] ** 2, rtol=1e-6)
    with pytest.raises(Exception, match="not one of null"):
        cc.conceal(raw, "no_such_effect", 1.0)


def _ride(seed, n=12000, rate=10.0):
    rng = np.random.default_rng(seed)
    t = np.arange(n) / rate
    ph = rng.uniform(0, 2 * np.pi, 3)
    v = (9.0 + 4.0 * np.sin(2 * np.pi * t / (60 + 10 * seed) + ph[0])
         + 2.5 * np.sin(2 * np.pi * t / 230.0 + ph[1]) + 1.0 * np.sin(2 * np.pi * t / 9.0 + ph[2]))
    a = np.gradient(v, t)
    P = 90.0 * v * a + 20.0 * v + 0.3 * v ** 3 + 30.0 + 20.0 * rng.standard_normal(n)
    return SimpleNamespace(t=t, v=v, a=a, av=v * a, P=P, extra={}, climb=None)


def test_the_record_is_compared_between_rides_and_named_on_the_page(eddy):
    log, other = _ride(1), _ride(2)
    other.P = other.P + TRUE_K * other.v ** 2
    assert NAME in df.physics()
    sigs = df.signature_columns(np.r_[log.v, other.v], np.r_[log.av, other.av], np.r_[log.P, other.P],
                                np.r_[log.t, other.t + 2000.0])
    np.testing.assert_allclose(sigs[NAME], np.r_[log.v, other.v] ** 2)
    # the pair fit of battery power: shared terms on both rides, each compared record's column on OTHER's rows
    (sL, dL), (sO, dO) = _power_columns(log, 0, None, 90.0), _power_columns(other, 0, None, 90.0)
    assert NAME in dL
    okL, okO = np.ones(log.t.size, bool), np.ones(other.t.size, bool)
    scale = {n: float(np.sqrt(np.mean(x ** 2))) or 1.0 for n, x in (sL | dO).items()}
    design = PairDesign((*sL, *dL), tuple(dL), log.t, _stack(True, sL, dL, log.P, okL, scale),
                        other.t, (_stack(False, sO, dO, other.P, okO, scale),))
    res = pair_fit(design, family=len(df.physics()), transform={n: (lambda co, n=n: co[n] / scale[n]) for n in dL},
                   n_boot=40)
    assert NAME in res.selected
    est, ci = res.estimates[NAME]
    assert ci[0] < TRUE_K < ci[1]
    tested = {NAME: df.Tested(est, ci, res.gains.get(NAME), True, res.p_values.get(NAME))}
    out = df.ride_differences([], [], tested, {}, {}, "the 16 May ride")
    d = next(x for x in out.items if x.name == NAME)
    assert d.named and d.unit == UNIT
    assert f"{UNIT} more eddy-current loss (a hotter motor?)" in out.sentence
    page = "\n".join(difference_lines(out, "b.csv"))
    assert "more eddy-current loss (a hotter motor?)" in page and "- Eddy-current loss: 95 % interval" in page


def test_the_catalog_is_as_before_without_it():
    assert NAME not in CATALOG and NAME not in CANDIDATES and NAME not in df.physics()

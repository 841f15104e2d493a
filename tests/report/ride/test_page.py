"""The ride page's folded parts (euc_sim.report.ride.page): every fitted value said once.

The Lynx ride 2 page gave C_rr 0.0251 and k 0.553 kg/m in 'Estimates' and again in the
simulation's section ("effects injected ...: rolling_resistance = 0.0251, ..."), k_cu in a
simulation note, and the firmware law's K_i, K_d in its table and in the notes.
"""

from __future__ import annotations

import sys
from dataclasses import replace
from pathlib import Path

import pandas as pd

from euc_sim.report.ride.page import _simulation_md, said_once
from euc_sim.rides.sim.sim_steps import SimStep
from euc_sim.rides.sim.simulate import RideSimulation, StepScore

sys.path.append(str(Path(__file__).resolve().parents[2] / "report"))
import pagenumbers as P  # noqa: E402


def _report(res, notes):
    """``res`` simulated along b.csv (4828 rows scored), with the simulation's ``notes``."""
    steps = [StepScore(SimStep(name, name), {"P_W": p}, None, None, None) for name, p in (("nominal", 300.0),
                                                                                          ("augmented", 99.0))]
    sim = RideSimulation("b.csv", pd.DataFrame({"scored": [True] * 4828}),
                         {"nominal": {"P_W": 300.0}, "augmented": {"P_W": 99.0}}, "power_efficiency",
                         {"rolling_resistance": 0.0251, "aerodynamic_drag": 0.553}, [], {}, steps, tuple(notes))
    an = res.balance
    return replace(res, simulation=sim, balance=replace(an, assumptions=replace(an.assumptions, efficiency=0.8)))


def _notes(res, notes, **summary):
    """``res`` with the ride's ``notes`` and its summary's fields replaced."""
    return replace(res, notes=tuple(notes), rider=replace(res.rider, summary=replace(res.rider.summary, **summary)))


def test_the_simulation_names_its_physics_without_repeating_their_values(ride_result):
    notes = ["drivetrain: copper_loss = 0.00609 is electrical: added to the predicted battery power, "
             "not to the mechanics",
             "measured_law: K_i = -144 N·m/(rad·s) measured but not simulated (MotorPD has no such term)"]
    md = "\n".join(_simulation_md(_report(ride_result, notes), {}))
    assert "rolling_resistance, aerodynamic_drag at their estimates above" in md
    for value in ("0.0251", "0.553", "0.00609", "-144"):
        assert value not in md
    assert "copper_loss is electrical" in md and "K_i measured but not simulated" in md
    assert not [q for q in P.quantities("sim", md) if q.name in ("rolling_resistance", "aerodynamic_drag")]


def test_said_once_keeps_what_the_tables_do_not_give():
    kd = ("measured_law: K_d measured 4.2 N·m·s/rad, 95 % interval [-54.3, 63.1]: not resolved by the "
          "log (the interval reaches 0 or below); the simulator uses K_d = 87.2 N·m·s/rad")
    assert said_once(kd) == ("measured_law: K_d as measured (the law's table): not resolved by the log "
                             "(the interval reaches 0 or below); the simulator uses K_d = 87.2 N·m·s/rad")
    other = "nominal: tracking correction 1: RMS speed error while riding 0.455 -> 0.034 m/s"
    assert said_once(other) == other


def test_the_sampling_note_agrees_with_the_tiles_rate(ride_result):
    """V9 0: the Data quality tile gave '2.9 samples/s', the notes 'about 37.0 Hz' (the median
    interval of rows that come in bursts between 409 gaps)."""
    from euc_sim.report.ride.page import _assumptions_md

    note = ("irregular sampling: intervals 0.008-5.072 s (median 0.027 s, about 37.0 Hz); 409 gap(s) "
            "longer than 1 s; 883 interval(s) shorter than 20 ms (near-repeats, kept)")
    rep = _notes(ride_result, [note], sampling_hz=2.877)
    md = "\n".join(_assumptions_md(rep, frozenset({"gaps"})))
    assert ("(median 0.027 s: 37.0 Hz within bursts between gaps; the tile's rate counts the whole log); "
            "gaps longer than 1 s as the tile counts;") in md
    assert not [q for q in P.quantities("notes", md) if q.name == "sampling_rate"]   # the tile's, said once
    assert "37.0 Hz" in "\n".join(_assumptions_md(rep))         # index.md has no tile: as written
    even = _notes(ride_result, [note.replace("0.027 s, about 37.0 Hz", "0.200 s, about 5.0 Hz")], sampling_hz=4.9)
    said = "\n".join(_assumptions_md(even, frozenset({"gaps"})))     # near the tile's: no second rate
    assert "(median 0.200 s between rows; the tile's rate counts the whole log)" in said and "Hz" not in said


def test_the_torque_inferred_from_power_is_said_as_an_assumption_for_the_torque_only(ride_result):
    """The pages read 'Logged torque from power_efficiency (assumed efficiency 0.8)' and, among
    the balance fit's assumptions, 'torque from power_efficiency', beside a balance with no efficiency."""
    from euc_sim.report.ride.page import _assumptions_md

    rep = _report(ride_result, [])
    md = "\n".join(_simulation_md(rep, {}))
    assert "power_efficiency" not in md
    assert ("The torque column scores against a logged torque from battery power at an assumed drivetrain "
            "efficiency of 0.8 (--efficiency; only for this torque, the energy balance has no efficiency).") in md
    sig = replace(rep.balance.sig_fit, torque_method="power_efficiency", power_source="voltage*current")
    rep = replace(rep, balance=replace(rep.balance, sig_fit=sig, domain="power"))
    line = _assumptions_md(rep)[2]
    assert "torque" not in line and line.endswith("power from voltage*current.")
    torque = replace(rep, balance=replace(rep.balance, domain="torque"))
    assert "torque from battery power at an assumed" in _assumptions_md(torque)[2]


def test_the_mass_fits_delay_says_it_is_not_the_balances_current_lag(ride_result):
    """Z10 0: the mass section said "current–speed delay +0.4 s" and Estimates "current_lag 0.3 s":
    one lag of the logged current, two figures, neither saying what it is.  The mass section says
    its delay is a shift and where the balance's first-order lag is."""
    from euc_sim.rides.balance.parameters import Parameter
    from euc_sim.report.ride.drivetrain_page import _mass_md
    from tests.rides.typed_ride import mass_fit

    lag = Parameter("current_lag", 0.3, None, "s", True, True, None, "balance")
    rep = replace(ride_result, mass=replace(ride_result.mass, mass=mass_fit(110.0, (72.0, 148.0), lag=0.4)),
                  parameters=(lag,))
    line = _mass_md(rep, frozenset({"total_mass"}))[2]
    assert ("current–speed delay +0.4 s, a shift of the current; the balance's own lag of it, current_lag, "
            "is in Estimates, a first-order lag)") in line
    assert _mass_md(replace(rep, parameters=()))[2].endswith("current–speed delay +0.4 s, a shift of the current).")

"""The terminal's summary of a ride (euc_sim.report.ride.terminal): lines from the result alone."""

from __future__ import annotations

import json
from dataclasses import replace
from pathlib import Path

import pandas as pd

from euc_sim.report.ride.terminal import history_lines, summary_lines
from euc_sim.rides.sim.sim_steps import SimStep
from euc_sim.rides.sim.simulate import RideSimulation, StepScore
from euc_sim.rides.summary.rider_view import Clock

RIDE = Path(__file__).resolve().parents[3] / "docs" / "ride" / "ride.json"


def _simulated(res, skip_last: str | None = None):
    """``res`` with the simulation of the documented ride (docs/ride/ride.json); its last step not run,
    saying ``skip_last``, where given."""
    sim = json.loads(RIDE.read_text())["simulation"]
    steps = [StepScore(SimStep(s["step"], s["what"], why=None if s["ran"] else s["why"]), s["heldout_rmse"] or {},
                       None, s["ratio_to_balance"], s["fell"]) for s in sim["steps"]]
    if skip_last:
        steps[-1] = replace(steps[-1], step=replace(steps[-1].step, why=skip_last))
    errors = {k: v for k, v in sim["errors"].items() if isinstance(v, dict)}
    table = pd.DataFrame({"scored": [True] * sim["scored_rows"]})
    return replace(res, simulation=RideSimulation(sim["ride"], table, errors, sim["errors"]["M_log_method"],
                                                  sim["effects_injected"], sim["falls"], {}, steps,
                                                  tuple(sim["notes"])), simulation_why=None)


def test_each_simulated_step_has_its_line_and_a_step_not_run_says_why(ride_result):
    res = _simulated(ride_result)
    steps = res.simulation.steps
    lines = summary_lines(res)
    assert all("\n" not in line for line in lines)
    assert [ln.strip().split(":")[0] for ln in lines if ln.startswith("    step ")] == [f"step {s.step.name}"
                                                                                      for s in steps]
    assert summary_lines(_simulated(ride_result, "no time left"))[-1].endswith(
        f"step {steps[-1].step.name}: not run (no time left)")


def test_a_ride_not_simulated_says_why_in_its_last_line(ride_result):
    res = replace(ride_result, simulation=None, simulation_why="--no-simulate")
    assert summary_lines(res)[-1] == "  simulated replay: --no-simulate"


def _history(verdict: str = "as new", **summary_fields):
    from tests.rides.typed_ride import battery, history_of, ride_entry_of

    fields = {"distance_m": 12200.0, "Wh_per_km": 37.8, "battery_used_pct": 10.0, "pwm_max_pct": 91.0,
              **summary_fields}
    ride = ride_entry_of("/logs/2.csv", "2025-07-17T14:48:00", 7200.0, fields, battery(0.148, verdict))
    return history_of([ride], basis="as logged")


def test_the_rides_table_is_in_the_one_zone_and_says_a_verdict_only_with_a_pack():
    lines = history_lines(_history(), verdicts=False)
    assert lines == ["start times in UTC+02:00",
                     "2025-07-17 16:48  2.csv: 12.2 km, 37.8 Wh/km, battery 10 %, "
                     "max PWM 91 % BAD (≥ 90 %: close to a cut-out), resistance 148 mΩ"]
    assert history_lines(_history(), verdicts=True)[-1].endswith("resistance 148 mΩ (as new)")


def test_a_ride_number_not_known_reads_as_the_json_writes_it():
    """A summary's NaN is null in the JSON: the table says it as unknown, never "nan"."""
    nan = float("nan")
    line = history_lines(_history(distance_m=nan, Wh_per_km=nan, battery_used_pct=nan, pwm_max_pct=nan))[-1]
    assert line == "2025-07-17 16:48  2.csv: 0.0 km, nan Wh/km, battery 0 %, max PWM –, resistance 148 mΩ"


def test_the_windows_and_the_compared_ride_read_as_the_page_says_them(compared_result):
    """The terminal said "windows (s): 76.6-96.3, …" beside tiles in clock time, and "compared:
    this ride needed …" under this ride's own figures, meaning the compared one."""
    from euc_sim.report.ride.ride_time import span_at

    rep = json.loads(RIDE.read_text())
    clock = Clock(**rep["clock"])
    trace = replace(compared_result.traces[0], localisation={**compared_result.traces[0].localisation,
                                                             "windows": rep["windows"]})
    res = replace(compared_result, traces=(trace,) + compared_result.traces[1:],
                  rider=replace(compared_result.rider, clock=clock),
                  differences=replace(compared_result.differences, sentence=rep["differences_sentence"]))
    lines = summary_lines(res)
    win = next(ln for ln in lines if ln.startswith("  windows"))
    a, b = rep["windows"][0]
    assert win.startswith("  windows, clock time in the phone's local time (time into the ride, min:s): "
                          + span_at(clock, a, b, "-")) and f"{a:.1f}" not in win
    said = next(ln for ln in lines if ln.startswith("  compared: "))
    assert said.startswith(f"  compared: the compared ride ({res.balance.compare}) needed ") and "this ride" not in said

"""The terminal's summary of a ride (euc_sim.rides.render.terminal): lines from the result alone."""

from __future__ import annotations

import copy
import json
from pathlib import Path

from euc_sim.rides.render.terminal import summary_lines

RIDE = Path(__file__).resolve().parents[3] / "docs" / "ride" / "ride.json"


def test_each_simulated_step_has_its_line_and_a_step_not_run_says_why():
    rep = json.loads(RIDE.read_text())
    steps = rep["simulation"]["steps"]
    lines = summary_lines(rep)
    assert all("\n" not in line for line in lines)
    assert [ln.strip().split(":")[0] for ln in lines if ln.startswith("    step ")] == [f"step {s['step']}" for s in steps]
    skipped = copy.deepcopy(rep)
    skipped["simulation"]["steps"][-1].update(ran=False, why="no time left")
    assert summary_lines(skipped)[-1].endswith(f"step {steps[-1]['step']}: not run (no time left)")


def test_a_ride_not_simulated_says_why_in_its_last_line():
    rep = json.loads(RIDE.read_text())
    rep.update(simulation=None, simulation_why="--no-simulate")
    assert summary_lines(rep)[-1] == "  simulated replay: --no-simulate"

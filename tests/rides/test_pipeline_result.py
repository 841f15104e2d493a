"""The ride pipeline returns the typed result and writes nothing; the JSON is rendered from it."""

from __future__ import annotations

import warnings

from ridesynth import synth_log

from euc_sim.rides.balance.parameters import Parameter
from euc_sim.rides.balance.verdict import Verdict
from euc_sim.rides.drive.drivetrain import Term
from euc_sim.rides.drive.drivetrain_report import MassDrivetrain
from euc_sim.rides.law.controller_report import ControllerFit
from euc_sim.rides.pipeline import REPLAY_NOT_ASKED, ride_pipeline
from euc_sim.report.ride.contract import ride_json
from euc_sim.rides.request import RideRequest
from euc_sim.rides.result import RideResult
from euc_sim.rides.source.logs import read_log


def test_the_pipeline_returns_the_typed_result_and_writes_no_file(tmp_path, monkeypatch):
    log = read_log(synth_log(tmp_path / "fit.csv", seed=3), emit_warnings=False)
    monkeypatch.chdir(tmp_path)
    before = sorted(tmp_path.rglob("*"))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        res = ride_pipeline(RideRequest(log, n_boot=10))
    assert sorted(tmp_path.rglob("*")) == before                   # no file, no folder
    assert isinstance(res, RideResult) and isinstance(res.mass, MassDrivetrain)
    assert isinstance(res.verdict, Verdict) and isinstance(res.law, ControllerFit)
    assert res.parameters and all(isinstance(p, Parameter) for p in res.parameters)
    assert all(isinstance(t, Term) for t in res.drivetrain.values())
    assert res.simulation is None and res.simulation_why == REPLAY_NOT_ASKED
    rep = ride_json(res)
    assert rep["verdict"]["named"] == list(res.verdict.named)
    assert [p["name"] for p in rep["parameters"]] == [p.name for p in res.parameters]
    assert rep["total_mass"]["estimate"] == res.mass.mass.estimate
    assert rep["notes"] == list(res.notes) and rep["report"] is None and "figures" not in rep
    assert ride_json(res) == rep                                    # rendering changes nothing


def test_the_requests_replicates_and_seed_reach_the_pair_fits(tmp_path, monkeypatch):
    """``--n-boot`` and ``--seed`` hold for every draw of a compared ride, the pair fits' included."""
    import euc_sim.rides.pipeline as pipeline
    seen = []
    real = pipeline.pair_differences
    monkeypatch.setattr(pipeline, "pair_differences",
                        lambda *a, **k: seen.append(a[3:] + tuple(k.values())) or real(*a, **k))
    log = read_log(synth_log(tmp_path / "fit.csv", seed=3), emit_warnings=False)
    other = read_log(synth_log(tmp_path / "test.csv", seed=4), emit_warnings=False)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        res = ride_pipeline(RideRequest(log, other, n_boot=12, seed=7))
    assert seen == [(12, 7)] and res.differences is not None


def test_the_requests_replicates_and_seed_reach_the_simulated_steps(tmp_path, monkeypatch):
    """``--n-boot`` and ``--seed`` reach the steps of the simulated ride (the calibrated rider's fit)."""
    import euc_sim.rides.pipeline as pipeline
    seen = []

    class Stop(Exception):
        pass

    def spy(inp, builders):
        seen.append((inp.n_boot, inp.seed))
        raise Stop

    monkeypatch.setattr(pipeline, "build_steps", spy)
    log = read_log(synth_log(tmp_path / "fit.csv", seed=3), emit_warnings=False)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        try:
            ride_pipeline(RideRequest(log, n_boot=12, seed=7, simulate=True, calibrate_rider=True))
        except Stop:
            pass
    assert seen == [(12, 7)]

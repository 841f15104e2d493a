"""One ``euc-sim ride`` run parses each log once (:mod:`euc_sim.rides.ride`)."""

from __future__ import annotations

from pathlib import Path

import pytest
from ridesynth import synth_log

import euc_sim.rides.logs as logs
from euc_sim.cli.app import main
from euc_sim.rides.ride import as_ride, read_ride, ride_name


@pytest.fixture()
def counted(monkeypatch):
    """Paths the log reader parsed, in order."""
    seen: list[str] = []
    real = logs._read_table

    def counting(path):
        seen.append(Path(path).name)
        return real(path)

    monkeypatch.setattr(logs, "_read_table", counting)
    return seen


def test_one_ride_run_reads_each_log_once(tmp_path, counted):
    fit = synth_log(tmp_path / "fit.csv", seed=31)
    test = synth_log(tmp_path / "test.csv", seed=32)
    code = main(["ride", str(fit), "--compare", str(test), "--no-simulate", "--n-boot", "10",
                 "--quiet", "--json", str(tmp_path / "ride.json")])
    assert code == 0
    assert sorted(counted) == ["fit.csv", "test.csv"]


def test_a_ride_carries_its_quality_facts(tmp_path, counted):
    ride = read_ride(synth_log(tmp_path / "fit.csv", seed=33))
    assert ride.name == "fit.csv" and counted == ["fit.csv"]
    q = ride.quality
    assert 4.0 < q.rate_hz < 10.0                        # rows every 0.1-0.3 s
    assert any(length > 1.5 for _, length in q.gaps)     # the synthetic log's 2 s gap
    assert "tilt" in q.zero_channels
    assert as_ride(ride) is ride and as_ride(ride.log).log is ride.log
    assert ride_name(ride.log) == ride_name(str(ride.path)) == "fit.csv"
    assert counted == ["fit.csv"]

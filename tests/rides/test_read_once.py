"""One ``euc-sim ride`` run parses each log once (:mod:`euc_sim.rides.grids.ride`)."""

from __future__ import annotations

from pathlib import Path

import pytest
from ridesynth import synth_log

import euc_sim.rides.source.logs as logs
from euc_sim.cli.app import main
from euc_sim.rides.grids.ride import GAP_POLICY, as_ride, read_ride, ride_name


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
    # the synthetic log's 2 s gap is bridged (the policy splits only beyond 2.5 s)
    assert GAP_POLICY.bridge == 2.5 and all(length > GAP_POLICY.bridge for _, length in q.gaps)
    assert "tilt" in q.zero_channels
    assert as_ride(ride) is ride and as_ride(ride.log).log is ride.log
    assert ride_name(ride.log) == ride_name(str(ride.path)) == "fit.csv"
    assert counted == ["fit.csv"]


def test_one_ride_run_builds_each_grid_once_per_log(tmp_path, monkeypatch):
    """The grid (resampling), the balance fit's filtered signals and the mass fit's, once per log."""
    import euc_sim.rides.law.controller_report as controller_report
    import euc_sim.rides.grids.power as power
    import euc_sim.rides.grids.signals as signals

    built: list[tuple[str, str]] = []

    def counting(mod, name, log_of):
        real = getattr(mod, name)

        def wrapper(*args, **kwargs):
            built.append((name, Path(ride_name(log_of(args))).name))
            return real(*args, **kwargs)
        monkeypatch.setattr(mod, name, wrapper)

    counting(signals, "resample", lambda a: a[0])
    counting(signals, "_balance_grid", lambda a: a[0])
    counting(power, "_filtered", lambda a: a[0])
    counting(controller_report, "law_rows", lambda a: a[0])
    fit = synth_log(tmp_path / "fit.csv", seed=34)
    test = synth_log(tmp_path / "test.csv", seed=35)
    code = main(["ride", str(fit), "--compare", str(test), "--no-simulate", "--n-boot", "10",
                 "--quiet", "--json", str(tmp_path / "ride.json")])
    assert code == 0
    for kind in ("resample", "_balance_grid", "_filtered"):
        assert sorted(n for k, n in built if k == kind) == ["fit.csv", "test.csv"], (kind, built)
    # the law's rows (on the log's own stamps) at most once per log: here the fit log's, which
    # has no pitch, so the law is not read and the compared log is not asked
    assert [n for k, n in built if k == "law_rows"] == ["fit.csv"]

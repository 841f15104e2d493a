"""One ``euc-sim ride`` run, and one :func:`euc_sim.analyse_ride`, read each log file once.

The count is of the file itself: every ``open`` of its path (``builtins.open``, ``io.open``,
which ``Path.open``/``read_text``/``read_bytes`` and ``pandas.read_csv`` go through) and every
``pandas.read_csv`` given its path, whoever calls them.
"""

from __future__ import annotations

import builtins
import io
import os
from pathlib import Path

import pandas as pd
import pytest
from ridesynth import synth_log

import euc_sim
from euc_sim.cli.app import main


@pytest.fixture()
def reads(monkeypatch):
    """``{file name: reads}`` of the files a test registers in ``reads.watch``."""
    seen: dict[str, int] = {}
    watched: set[str] = set()
    inside_read_csv = [0]

    def name_of(f) -> str | None:
        if isinstance(f, (str, os.PathLike)):
            p = os.path.realpath(os.fspath(f))
            return Path(p).name if p in watched else None
        return None

    def spy_open(real):
        def opening(file, *args, **kwargs):
            name = name_of(file)
            if name is not None and not inside_read_csv[0]:
                seen[name] = seen.get(name, 0) + 1
            return real(file, *args, **kwargs)
        return opening

    real_read_csv = pd.read_csv

    def read_csv(f, *args, **kwargs):
        name = name_of(f)
        if name is not None:
            seen[name] = seen.get(name, 0) + 1
        inside_read_csv[0] += 1
        try:
            return real_read_csv(f, *args, **kwargs)
        finally:
            inside_read_csv[0] -= 1

    monkeypatch.setattr(builtins, "open", spy_open(builtins.open))
    monkeypatch.setattr(io, "open", spy_open(io.open))
    monkeypatch.setattr(pd, "read_csv", read_csv)

    class Reads(dict):
        def watch(self, *paths):
            watched.update(os.path.realpath(p) for p in paths)

    out = Reads()
    out.counts = seen
    return out


def test_the_cli_reads_each_log_once(tmp_path, reads):
    fit = synth_log(tmp_path / "fit.csv", seed=31)
    test = synth_log(tmp_path / "test.csv", seed=32)
    reads.watch(fit, test)
    code = main(["ride", str(fit), "--compare", str(test), "--no-simulate", "--n-boot", "10",
                 "--quiet", "--json", str(tmp_path / "ride.json")])
    assert code == 0
    assert reads.counts == {"fit.csv": 1, "test.csv": 1}


def test_the_api_reads_each_log_once(tmp_path, reads):
    fit = synth_log(tmp_path / "fit.csv", seed=36)
    test = synth_log(tmp_path / "test.csv", seed=37)
    reads.watch(fit, test)
    res = euc_sim.analyse_ride(fit, test, n_boot=10, simulate=False)
    assert res.summary is not None
    assert reads.counts == {"fit.csv": 1, "test.csv": 1}


def test_the_api_reads_a_single_log_once(tmp_path, reads):
    fit = synth_log(tmp_path / "fit.csv", seed=38)
    reads.watch(fit)
    euc_sim.analyse_ride(fit, n_boot=10, simulate=False)
    assert reads.counts == {"fit.csv": 1}


def test_the_spy_sees_every_way_of_reading(tmp_path, reads):
    """The counter is honest: each of the ways a module could read the file counts."""
    p = synth_log(tmp_path / "fit.csv", seed=39)
    reads.watch(p)
    pd.read_csv(p)
    open(p).close()
    p.read_text()
    p.read_bytes()
    with p.open() as fh:
        fh.readline()
    assert reads.counts == {"fit.csv": 5}


def test_a_ride_carries_its_counters(tmp_path):
    from euc_sim.rides.source.logs import read_log

    ride = read_log(synth_log(tmp_path / "fit.csv", seed=33), emit_warnings=False)
    assert ride.name == "fit.csv" and "tilt" in ride.absent
    assert ride.counters.alarm_rows == 0 and ride.counters.battery_start_pct is not None


def test_one_ride_run_builds_each_grid_once_per_log(tmp_path, monkeypatch):
    """The grid (resampling), the balance fit's filtered signals and the mass fit's, once per log."""
    import euc_sim.rides.grids.power as power
    import euc_sim.rides.grids.signals as signals
    import euc_sim.rides.law.controller_report as controller_report

    built: list[tuple[str, str]] = []

    def counting(mod, name):
        real = getattr(mod, name)

        def wrapper(*args, **kwargs):
            built.append((name, args[0].name))
            return real(*args, **kwargs)
        monkeypatch.setattr(mod, name, wrapper)

    for mod, name in ((signals, "resample"), (signals, "_balance_grid"), (power, "_filtered"),
                      (controller_report, "law_rows")):
        counting(mod, name)
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

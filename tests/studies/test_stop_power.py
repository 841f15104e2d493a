"""studies/stop_power.py: the power at stands, and its bad-input exit (the survey itself is a study)."""

import sys

import numpy as np
import pytest

import stop_power


def test_stand_power_splits_stops_short_stands_and_riding():
    t = np.arange(0.0, 60.0, 0.1)
    v = np.full(t.size, 6.0)
    v[(t >= 10.0) & (t < 20.0)] = 0.0          # a 10 s stop: nobody balancing, 0 W
    v[(t >= 40.0) & (t < 41.0)] = 0.05         # a 1 s stand: somebody balancing, 30 W
    P = np.where(v > 1.0, 900.0, 0.0)
    P[(t >= 40.0) & (t < 41.0)] = 30.0
    got = stop_power.stand_power(t, v, P, 0.1, 3.0)
    assert got["stops"] == 1 and got["stop_s"] == pytest.approx(9.9)
    assert got["stop"] == (0.0, 0.0)
    assert got["short"] == (30.0, 30.0)
    assert got["riding"] == (900.0, 900.0)
    assert stop_power.stand_power(t, np.full(t.size, 5.0), P, 0.1, 3.0)["stop"] is None


def test_missing_data_exits_2(tmp_path, capsys):
    assert stop_power.main(["--data", str(tmp_path / "nope")]) == 2
    err = capsys.readouterr().err
    assert "--data" in err and len(err.strip().splitlines()) == 1

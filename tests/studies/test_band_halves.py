"""studies/band_halves.py: a ride's two halves band by band, and its bad-input exit (the survey is a study)."""

import sys

import numpy as np
import pytest

import band_halves


def test_a_ride_whose_second_half_swings_twice_as_hard_is_six_db_up_in_every_band():
    rng = np.random.default_rng(0)
    t = np.arange(0.0, 1200.0, 0.1)
    P = 600.0 + 200.0 * rng.normal(size=t.size)
    same = band_halves.half_ratio_db(t, P, np.zeros(t.size, int), 10.0)
    assert np.max(np.abs(same)) < 0.5                                   # white noise: the same
    louder = np.where(t >= np.median(t), 2.0 * (P - 600.0), P - 600.0)
    up = band_halves.half_ratio_db(t, louder, np.zeros(t.size, int), 10.0)
    assert up == pytest.approx([20 * np.log10(2.0)] * 8, abs=0.5)


def test_a_folder_without_logs_is_one_line_and_exit_2(tmp_path, capsys):
    assert band_halves.main(["--data", str(tmp_path)]) == 2
    err = capsys.readouterr().err
    assert str(tmp_path) in err and "Traceback" not in err and err.count("\n") == 1

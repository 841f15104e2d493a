"""Reading and validating recordings: CSV, Parquet, sidecars, one-line errors."""

from __future__ import annotations

import json

import numpy as np
import pandas as pd
import pytest

from euc_sim.cli import main
from euc_sim.model.parameters import TABLE3
from euc_sim.identification.processing import Smoothing, kinematics
from euc_sim.identification.recordings import RecordingError, RecordingWarning, read_recording


def _frame(n: int = 240) -> pd.DataFrame:
    t = np.arange(n) / 120.0
    return pd.DataFrame({"t": t, "x": 2.0 * t, "gamma": 0.01 * np.sin(t),
                         "phi": 0.05 * np.sin(2 * t)})


def _write(tmp_path, df, name="rec.csv", meta=None):
    path = tmp_path / name
    if name.endswith(".parquet"):
        df.to_parquet(path)
    else:
        df.to_csv(path, index=False)
    if meta is not None:
        path.with_suffix(".json").write_text(json.dumps(meta))
    return path


def test_reads_csv_and_parquet_alike(tmp_path):
    df = _frame()
    a, _ = read_recording(_write(tmp_path, df, "a.csv"))
    b, _ = read_recording(_write(tmp_path, df, "b.parquet"))
    np.testing.assert_allclose(a[["t", "x", "gamma", "phi"]], b[["t", "x", "gamma", "phi"]],
                               rtol=1e-12)


def test_sidecar_read_truth_never(tmp_path):
    path = _write(tmp_path, _frame(), meta={"params": {"m": 80}, "maneuver": "deceleration"})
    (tmp_path / "rec.truth.json").write_text("this is not JSON and must never be opened")
    df, meta = read_recording(path)
    assert meta["params"] == {"m": 80} and meta["maneuver"] == "deceleration"
    assert set(meta) == {"params", "maneuver", "path"}


def test_missing_column_names_file_and_column(tmp_path):
    path = _write(tmp_path, _frame().drop(columns="phi"))
    with pytest.raises(RecordingError, match=r"rec\.csv: column 'phi' row 0: missing"):
        read_recording(path)


def test_duplicate_time_names_row(tmp_path):
    df = _frame()
    df.loc[10, "t"] = df.loc[9, "t"]
    with pytest.raises(RecordingError, match=r"column 't' row 11: duplicate time"):
        read_recording(_write(tmp_path, df))


def test_decreasing_time_names_row(tmp_path):
    df = _frame()
    df.loc[20, "t"] = 0.0
    with pytest.raises(RecordingError, match=r"column 't' row 21: decreasing time"):
        read_recording(_write(tmp_path, df))


def test_short_gap_interpolated_with_count(tmp_path):
    df = _frame()
    df.loc[50:51, "gamma"] = np.nan
    df.loc[70, "phi"] = np.inf
    with pytest.warns(RecordingWarning, match=r"interpolated 3 missing"):
        out, _ = read_recording(_write(tmp_path, df))
    assert np.all(np.isfinite(out[["gamma", "phi"]].to_numpy()))
    np.testing.assert_allclose(out.loc[50, "gamma"], 0.01 * np.sin(50 / 120), atol=1e-6)


def test_long_gap_is_an_error(tmp_path):
    df = _frame()
    df.loc[100:111, "phi"] = np.nan
    with pytest.raises(RecordingError, match=r"column 'phi' row 101: 12 missing"):
        read_recording(_write(tmp_path, df))


def test_gap_at_the_start_is_an_error(tmp_path):
    df = _frame()
    df.loc[0, "x"] = np.nan
    with pytest.raises(RecordingError, match=r"column 'x' row 1: 1 missing .*at the start"):
        read_recording(_write(tmp_path, df))


def test_degrees_are_refused(tmp_path):
    df = _frame()
    df["phi"] = np.degrees(df["phi"]) * 30          # up to 86 "rad"
    with pytest.raises(RecordingError, match=r"column 'phi' row \d+: .* looks like degrees"):
        read_recording(_write(tmp_path, df))


def test_text_in_a_number_column(tmp_path):
    df = _frame().astype({"gamma": object})
    df.loc[5, "gamma"] = "oops"
    with pytest.raises(RecordingError, match=r"column 'gamma' row 6: not a number"):
        read_recording(_write(tmp_path, df))


def test_too_short_for_the_smoothing_window(tmp_path):
    df, _ = read_recording(_write(tmp_path, _frame(60)))
    with pytest.raises(RecordingError, match=r"rec\.csv: column 't' row 60: only 60 samples, too short"):
        kinematics(df, TABLE3, Smoothing(), name=str(tmp_path / "rec.csv"))


def test_cli_bad_recording_one_line_exit_2(tmp_path, capsys):
    df = _frame()
    df.loc[10, "t"] = df.loc[9, "t"]
    path = _write(tmp_path, df)
    code = main(["torques", str(path), "--out", str(tmp_path / "T.csv")])
    err = capsys.readouterr().err
    assert code == 2
    assert err.count("\n") == 1 and "rec.csv: column 't' row 11: duplicate time" in err
    assert not (tmp_path / "T.csv").exists()


def test_cli_missing_file_exit_2(tmp_path, capsys):
    code = main(["identify", str(tmp_path / "nope.csv")])
    err = capsys.readouterr().err
    assert code == 2 and err.count("\n") == 1 and "nope.csv: no such recording" in err

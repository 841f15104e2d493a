"""Every log channel's physical range (euc_sim.rides.source.bounds), applied by read_log."""

from __future__ import annotations

import glob
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from layoutsynth import layout_log

from euc_sim.rides.source import logs
from euc_sim.rides.source.bounds import CHANNEL_BOUNDS
from euc_sim.rides.source.logs import LogFormatError, read_log


def _log(tmp_path, layout="wheellog_new", edit=None, name="log.csv", duration=60.0) -> Path:
    """A synthetic log of ``layout``, its text cells changed by ``edit(frame)``."""
    path = layout_log(tmp_path / name, layout, duration=duration)
    if edit is not None:
        frame = pd.read_csv(path, dtype=str, keep_default_na=False)
        edit(frame)
        frame.to_csv(path, index=False)
    return path


def _read(path):
    return read_log(path, emit_warnings=False)


def test_a_clean_log_reads_without_repairs(tmp_path):
    log = _read(_log(tmp_path))
    assert log.repairs == () and log.n_rows_read == len(log.data)


@pytest.mark.parametrize("layout, column, value, bound", [
    ("wheellog_new", "voltage", "-65", r"\[0, 200\] V"),
    ("wheellog_new", "pwm", "1e300", r"\[0, 110\] %"),
    ("eucworld", "safety_margin", "250", r"\[-10, 100\] %"),
    ("wheellog_new", "battery_level", "500", r"\[0, 100\] %"),
    ("wheellog_new", "latitude", "999", r"\[-90, 90\] °"),
    ("wheellog_new", "speed", "9e300", r"\[-150, 150\] km/h"),
])
def test_a_channel_mostly_out_of_range_refuses_the_log(tmp_path, layout, column, value, bound):
    def edit(f):
        f.loc[f[column] != "", column] = value
    with pytest.raises(LogFormatError, match=rf"log\.csv: column '{column}', line 2: \d+ of \d+ values "
                                             rf"outside {bound} \(first "):
        _read(_log(tmp_path, layout, edit))


def test_a_few_cells_out_of_range_are_emptied_and_said(tmp_path):
    def edit(f):
        f.loc[10, "pwm"] = "1e300"
    log = _read(_log(tmp_path, edit=edit))
    assert log.repairs == ("pwm: 1 value(s) outside [0, 110] %, first 1e+300 % at line 12; cells emptied "
                           "(the rows kept)",)
    assert np.isnan(log.data["pwm"].iloc[10]) and np.isfinite(log.data["v"].iloc[10])


def test_a_few_speeds_out_of_range_drop_their_rows(tmp_path):
    n = len(_read(_log(tmp_path)).data)

    def edit(f):
        f.loc[[10, 20], "speed"] = "-9999"
    log = _read(_log(tmp_path, edit=edit))
    assert len(log.data) == n - 2 and log.repairs[0].startswith("speed: 2 value(s) outside [-150, 150] km/h")


def test_negative_speeds_are_refused_as_such(tmp_path):
    def edit(f):
        f["speed"] = "-" + f["speed"]
    with pytest.raises(LogFormatError, match=r"column 'speed': \d+ of \d+ moving speeds are negative"):
        _read(_log(tmp_path, edit=edit))


def test_isolated_sign_flips_are_turned_back_and_said(tmp_path):
    clean = _read(_log(tmp_path)).data["v"].to_numpy()
    rows = [i for i in range(5, len(clean) - 5) if clean[i] > 2.0][::40][:3]

    def edit(f):
        f.loc[rows, "speed"] = "-" + f.loc[rows, "speed"]
    log = _read(_log(tmp_path, edit=edit))
    assert log.repairs[0].startswith("speed: 3 isolated sign flip(s)")
    np.testing.assert_array_equal(log.data["v"].to_numpy(), clean)


def test_many_sign_flips_refuse_the_log(tmp_path):
    def edit(f):
        rows = f.index[f["speed"].astype(float) > 7.2][::10]      # 10 % of the moving rows
        f.loc[rows, "speed"] = "-" + f.loc[rows, "speed"]
    with pytest.raises(LogFormatError, match=r"column 'speed': \d+ of \d+ moving rows have their speed's "
                                             r"sign flipped .* more than 1%"):
        _read(_log(tmp_path, edit=edit))


def test_a_column_named_twice_is_refused(tmp_path):
    path = _log(tmp_path)
    lines = path.read_text().splitlines()
    lines = [lines[0] + ",speed"] + [ln + ",1.0" for ln in lines[1:]]
    path.write_text("\n".join(lines) + "\n")
    with pytest.raises(LogFormatError, match=r"column 'speed', line 1: the header names this column twice "
                                             r"\(columns 9 and 25\)"):
        _read(path)


def test_a_folder_is_not_a_missing_file(tmp_path):
    with pytest.raises(LogFormatError, match=r"a folder, not a log file"):
        _read(tmp_path)


def test_too_many_rows_are_refused_before_parsing(tmp_path, monkeypatch):
    path = _log(tmp_path)
    n = len(path.read_text().splitlines()) - 1
    monkeypatch.setattr(logs, "MAX_ROWS", n - 1)
    monkeypatch.setattr(logs, "_check_field_counts", lambda p: pytest.fail("parsed before counting"))
    with pytest.raises(LogFormatError, match=rf"log\.csv: {n} rows, more than the {n - 1} a log may have"):
        _read(path)


def test_every_repair_is_a_repair_note(tmp_path):
    path = _log(tmp_path)
    header, *rows = path.read_text().splitlines()
    rows = rows[:5] + [rows[5]] + rows[5:] + [rows[-1].split(",", 3)[0]]     # a repeat, a truncated line
    rows[8], rows[9] = rows[9], rows[8]                                        # time runs back once
    path.write_text("\n".join([header] + rows) + "\n")
    log = _read(path)
    assert [r.split(" ")[:2] for r in log.repairs] == [["dropped", "the"], ["time", "ran"], ["repeated", "time"]]
    assert set(log.repairs) <= set(log.warnings)


SHARED = sorted(glob.glob("/work/shared/data/euc_core/trips/*/*/*/[0-9]*.csv")
                + glob.glob("/work/shared/data/wheellog/*.csv"))


@pytest.mark.skipif(not SHARED, reason="the shared rides are absent")
def test_no_bound_touches_a_shared_ride():
    """Every real ride reads with no value outside its channel's range and no sign repaired."""
    for f in SHARED:
        log = _read(f)
        assert not [r for r in log.repairs if "outside" in r or "sign" in r], (f, log.repairs)
        for ch in set(CHANNEL_BOUNDS) & set(log.data.columns):
            lo, hi, _, si = CHANNEL_BOUNDS[ch]
            x = log.data[ch].to_numpy(float) / si
            assert np.all((x[np.isfinite(x)] >= lo) & (x[np.isfinite(x)] <= hi)), (f, ch)

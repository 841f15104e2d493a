"""Every numeric option and every ride-log channel has a bound, checked before any work.

Bad values give exit 2 and one line naming the option (or the file and column) and the
bound; ``--help`` states each option's range.  Repairs of a log (merged stamps, re-sorted
rows, a dropped line, dropped out-of-range cells) are each one line on stderr.
"""

from __future__ import annotations

import argparse
import re

import pytest

from euc_sim.cli import main
from euc_sim.cli.app import build_parser
from euc_sim.cli.options import DeprecatedOption


def _commands() -> dict[str, argparse.ArgumentParser]:
    sub = next(a for a in build_parser()._actions if isinstance(a, argparse._SubParsersAction))
    return dict(sub.choices)


def _numeric_options():
    from euc_sim.cli.common import seed

    for command, parser in _commands().items():
        for action in parser._actions:
            if isinstance(action, DeprecatedOption) or action.type in (None, str, seed):
                continue
            yield command, parser, action


def test_every_numeric_option_is_bounded_and_says_its_range_in_help():
    unbounded, unsaid = [], []
    for command, parser, action in _numeric_options():
        span = getattr(action.type, "span", None)
        if span is None:
            unbounded.append(f"{command} {action.option_strings[0]}")
            continue
        formatter = parser._get_formatter()
        formatter.add_argument(action)
        if span not in " ".join(formatter.format_help().split()):
            unsaid.append(f"{command} {action.option_strings[0]}")
    assert not unbounded, "numeric options without a bound: " + ", ".join(unbounded)
    assert not unsaid, "bounded options whose --help hides the range: " + ", ".join(unsaid)


def _refused(argv, pattern, capsys) -> str:
    try:                # refused by argparse, or by the command's request (euc-sim ride)
        code = main(argv)
    except SystemExit as exc:
        code = exc.code
    assert code == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and re.search(pattern, err[0]), err
    return err[0]


@pytest.mark.parametrize("argv, pattern", [
    (["simulate", "--out", "o.csv", "--duration", "1e300"], r"--duration: .*\[0\.1, 3600\] s, got 1e300"),
    (["simulate", "--out", "o.csv", "--duration", "1e6"], r"--duration: .*\[0\.1, 3600\] s"),
    (["simulate", "--out", "o.csv", "--duration", "1e-9"], r"--duration: .*\[0\.1, 3600\] s"),
    (["simulate", "--out", "o.csv", "--rider-noise", "1e300"], r"--rider-noise: .*\[0, 100\] N·m"),
    (["crosscheck", "--samples", "100000000"], r"--samples: .*\[1, 100000\]"),
    (["stability", "--kp", "1e300"], r"--kp: .*\[1, 100000\] N·m/rad"),
    (["design", "--rides", "100000000"], r"--rides: .*\[3, 10000\]"),
    (["dataset", "--out-dir", "d", "--workers", "1000"], r"--workers: .*\[1, \d+\] \(this machine's cores\)"),
    (["ride", "x.csv", "--mass", "1e300"], r"--mass: .*\[35, 350\] kg"),
    (["render", "r.csv", "--out", "r.png", "--width", "100000"], r"--width: .*\[16, 7680\] px"),
])
def test_option_out_of_bounds_is_refused_naming_the_bound(argv, pattern, capsys):
    _refused(argv, pattern, capsys)


@pytest.mark.parametrize("argv, pattern", [
    (["--effect", "sensor_time_offset=1e6"], r"effect sensor_time_offset: expected a value in \[0, 0\.3\] s, got 1e6"),
    (["--effect", "cog_height_drift=10"], r"effect cog_height_drift: expected a value in \[0, 0\.6\] m, got 10"),
    (["--effect", "cog_height_drift=0.6", "--param", "h=0.3", "--duration", "12"],
     r"cog_height_drift=0\.6 m takes h from 0\.3 m down to .*; h must stay at least 0\.05 m"),
])
def test_effect_size_out_of_its_bound_is_refused(argv, pattern, tmp_path, capsys):
    out = tmp_path / "o.csv"
    assert main(["simulate", "--out", str(out), "--duration", "1", *argv]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and re.search(pattern, err[0]), err
    assert not out.exists()


def test_effect_bounds_are_in_help():
    from euc_sim.simulation.effects import CATALOG

    text = " ".join(_commands()["simulate"].format_help().split())
    for e in CATALOG.values():
        assert f"{e.name} [{e.bounds[0]:g}, {e.bounds[1]:g}]" in text
        assert e.bounds[0] <= e.plausible[0] <= e.plausible[1] <= e.bounds[1], e.name


# --- ride logs ---------------------------------------------------------------------------------
HEADER = "date,time,speed,voltage,current,power,battery_level,distance,totaldistance,system_temp,cpu_temp,tilt,roll,mode,alert"


def _wheellog(path, n: int = 300, volt: float = 65.0, battery: float = 90.0, speed=None, repeat: int = 0):
    """A WheelLog (old layout) log of ``n`` rows at 5 Hz: speeds in km/h (default 20 ± 5)."""
    import numpy as np

    t = np.arange(n) * 0.2
    v = 20.0 + 5.0 * np.sin(t / 5.0) if speed is None else np.asarray(speed, float)
    rows = []
    for i in range(n):
        s = f"{int(t[i]) // 60:02d}:{int(t[i]) % 60:02d}.{int(round(t[i] % 1 * 1000)):03d}"
        rows.append(f"2024-06-01,10:{s},{v[i]:.2f},{volt:.2f},2.00,{2 * volt:.1f},{battery:g},0,1000,30,0,0,0,0,")
    for i in range(repeat):                     # the app writes a row twice
        rows.insert(10 + 2 * i, rows[10 + 2 * i])
    path.write_text(HEADER + "\n" + "\n".join(rows) + "\n")
    return path


def _err(argv, capsys) -> tuple[int, list[str]]:
    code = main([str(a) for a in argv])
    return code, capsys.readouterr().err.strip().splitlines()


@pytest.mark.parametrize("command", ["ride", "rides"])
def test_all_negative_voltages_are_refused_by_ride_and_rides(command, tmp_path, capsys):
    log = _wheellog(tmp_path / "neg.csv", volt=-65.0)
    code, err = _err([command, log, "--quiet", "--json", tmp_path / "o.json"], capsys)
    assert code == 2 and len(err) == 1, err
    assert re.search(r"neg\.csv: column 'voltage', line 2: 300 of 300 values outside \[0, 200\] V", err[0]), err
    assert not (tmp_path / "o.json").exists()


@pytest.mark.parametrize("command", ["ride", "rides"])
def test_an_absurd_speed_is_refused_by_ride_and_rides(command, tmp_path, capsys):
    log = _wheellog(tmp_path / "far.csv", speed=[1e300] * 300)
    code, err = _err([command, log, "--quiet"], capsys)
    assert code == 2 and len(err) == 1, err
    assert re.search(r"far\.csv: column 'speed', line 2: .*outside \[-150, 150\] km/h", err[0]), err


def test_negative_speeds_are_named_as_such(tmp_path, capsys):
    log = _wheellog(tmp_path / "back.csv", speed=-(20.0 + __import__("numpy").zeros(300)))
    code, err = _err(["ride", log, "--no-simulate"], capsys)
    assert code == 2 and len(err) == 1 and "moving speeds are negative" in err[0], err
    assert "nothing was ridden" not in err[0]


def test_a_folder_given_as_the_log_is_named_a_folder(tmp_path, capsys):
    code, err = _err(["ride", tmp_path, "--no-simulate"], capsys)
    assert code == 2 and len(err) == 1 and "a folder, not a log file" in err[0], err


def test_two_speed_columns_are_refused(tmp_path, capsys):
    log = _wheellog(tmp_path / "two.csv")
    lines = log.read_text().splitlines()
    log.write_text("\n".join([lines[0] + ",speed"] + [ln + ",3" for ln in lines[1:]]) + "\n")
    code, err = _err(["ride", log, "--no-simulate"], capsys)
    assert code == 2 and len(err) == 1 and re.search(r"column 'speed', line 1: .*twice", err[0]), err


NOTE = "{}: note: rep.csv: repeated time stamps: 2 time stamp(s) shared by 4 rows; averaged into one row each (2 rows merged)"


def test_a_repair_is_one_line_on_stderr_before_the_work(tmp_path, capsys, monkeypatch):
    """Repeated stamps merged: said on the terminal once the inputs and outputs are checked
    (the work itself stubbed out here: it stops with an error)."""
    from euc_sim.errors import InputError
    from euc_sim.rides import pipeline

    def stop(*args, **kwargs):
        raise InputError("stopped before the work")
    monkeypatch.setattr(pipeline, "ride_pipeline", stop)
    log = _wheellog(tmp_path / "rep.csv", n=600, repeat=2)
    code, err = _err(["ride", log, "--no-simulate", "--quiet"], capsys)
    assert code == 2 and err == [NOTE.format("euc-sim ride"), "euc-sim ride: error: stopped before the work"], err


def test_rides_says_each_repair(tmp_path, capsys):
    log = _wheellog(tmp_path / "rep.csv", n=600, repeat=2)
    code, err = _err(["rides", log, "--quiet", "--n-boot", "10"], capsys)
    assert code == 0 and err == [NOTE.format("euc-sim rides")], err


def test_rides_refuses_logs_of_two_packs(tmp_path, capsys):
    a = _wheellog(tmp_path / "a64.csv", volt=64.0)
    b = _wheellog(tmp_path / "b84.csv", volt=84.0)
    code, err = _err(["rides", a, b, "--quiet", "--n-boot", "10"], capsys)
    assert code == 2 and len(err) == 1, err
    assert re.search(r"b84\.csv: a different wheel from .*a64\.csv: .*full charge of 86 V against 65 V", err[0]), err

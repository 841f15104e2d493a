"""``euc-sim ride`` as a new user meets it: progress on stderr, outputs that name no
machine path, interruption (SIGTERM, SIGINT, SIGKILL of the parent) that stops the
workers and leaves no temporary file, honest refusal of too little data, and a
hypothesis fuzz over malformed ride logs (exit 0 or 2, never a traceback, never a
partial output)."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
from pathlib import Path

import pytest
from ridesynth import synth_log

from euc_sim.cli import main
from euc_sim.io import is_temporary
from euc_sim.rides.balance.design import balance_design
from euc_sim.rides.balance.fit import MIN_BLOCKS, fit_balance
from euc_sim.rides.grids.signals import ride_signals
from euc_sim.rides.source.logs import read_log

#: 60 s logs give ~2.9 bootstrap blocks per half: the warning is tested once, below.
pytestmark = pytest.mark.filterwarnings("ignore:.*bootstrap blocks:UserWarning")


def run(argv, capsys):
    """Run the CLI in this process; (exit code, stdout, stderr lines)."""
    code = main([str(a) for a in argv])
    out = capsys.readouterr()
    return code, out.out, [ln for ln in out.err.splitlines() if ln.strip()]


@pytest.fixture(scope="module")
def log(tmp_path_factory):
    """A 60 s synthetic ride (known physics), long enough for the bootstrap."""
    return synth_log(tmp_path_factory.mktemp("robust") / "ride.csv", seed=21, duration=60.0,
                     gap_at=None)


# --- progress ------------------------------------------------------------------------------
def test_progress_on_stderr_without_asking(log, tmp_path, capsys):
    code, out, err = run(["ride", log, "--no-simulate", "--n-boot", "10"], capsys)
    assert code == 0, err
    steps = [ln for ln in err if ln.startswith("ride: ")]
    assert any("fitting the inertia-only balance" in ln and "(1/3" in ln for ln in steps), err
    assert any("(3/3" in ln for ln in steps) and any("locating" in ln for ln in steps)
    assert "held-out error" in out                      # results stay on stdout


def test_quiet_silences_progress(log, capsys):
    code, _, err = run(["ride", log, "--no-simulate", "--n-boot", "10", "--quiet"], capsys)
    assert code == 0
    assert not [ln for ln in err if ln.startswith("ride: ")]


# --- outputs name no machine path -------------------------------------------------------------
def test_outputs_record_no_absolute_path(log, tmp_path, capsys):
    out = tmp_path / "out"
    code, _, err = run(["ride", log.resolve(), "--no-simulate", "--n-boot", "10",
                        "--report", out / "rep", "--json", out / "ride.json"], capsys)
    assert code == 0, err
    text = (out / "ride.json").read_text()
    for machine in (str(tmp_path), str(log.resolve().parent)):
        assert machine not in text
        assert machine not in (out / "rep" / "index.md").read_text()
    rep = json.loads(text)
    assert rep["recording"] == log.name and rep["report_dir"] == "rep"
    base = out / rep["report_dir"]
    assert (base / rep["report"]).is_file() and (base / rep["table"]).is_file()
    for name in rep["figures"].values():
        assert (base / name).is_file()


# --- too little data --------------------------------------------------------------------------
def test_too_little_data_is_one_line_naming_the_file(tmp_path, capsys):
    short = synth_log(tmp_path / "short.csv", seed=3, duration=6.0, gap_at=None, repeats=1)
    code, _, err = run(["ride", short, "--no-simulate", "--json", tmp_path / "o.json",
                        "--report", tmp_path / "rep"], capsys)
    assert code == 2
    errors = [ln for ln in err if not ln.startswith("ride: ")]
    assert len(errors) == 1 and errors[0].startswith("euc-sim ride: error:"), err
    assert "short.csv" in errors[0] and "block" in errors[0] and "s of ride" in errors[0]
    assert not (tmp_path / "o.json").exists() and not (tmp_path / "rep").exists()


def test_one_block_never_gives_a_zero_width_interval(tmp_path):
    short = synth_log(tmp_path / "short.csv", seed=3, duration=12.0, gap_at=None, repeats=1)
    d = balance_design(ride_signals(read_log(short, emit_warnings=False)))
    with pytest.raises(ValueError, match=r"short\.csv: \d+ usable rows .* at least 2 blocks"):
        fit_balance(d, n_boot=20, block_s=10.0)
    fit = fit_balance(d, n_boot=20, block_s=len(d.P) * 0.1 / MIN_BLOCKS)    # exactly 2 blocks
    assert all(hi > lo for lo, hi in fit.ci95.values())


def test_few_blocks_warn(log, tmp_path, capsys):
    with pytest.warns(UserWarning, match=r"ride\.csv \(first half\) gives only 2\.\d bootstrap "
                                         r"blocks of 10 s: the 95 % intervals are rough"):
        code, _, err = run(["ride", log, "--no-simulate", "--n-boot", "10", "--json",
                            tmp_path / "o.json"], capsys)
    assert code == 0
    assert any("rough" in n for n in json.loads((tmp_path / "o.json").read_text())["notes"])


# --- interruption -----------------------------------------------------------------------------
def _children(pid: int) -> set[int]:
    """Live (not zombie) processes whose parent is ``pid``, from /proc."""
    out = set()
    for entry in Path("/proc").iterdir():
        if not entry.name.isdigit():
            continue
        try:
            stat = (entry / "stat").read_text()
        except OSError:
            continue
        fields = stat[stat.rindex(")") + 2:].split()
        if int(fields[1]) == pid and fields[0] != "Z":
            out.add(int(entry.name))
    return out


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="reads /proc")
@pytest.mark.parametrize("sig, code", [(signal.SIGTERM, 143), (signal.SIGINT, 130),
                                       (signal.SIGKILL, -signal.SIGKILL)])
def test_interrupt_stops_workers_and_leaves_nothing(log, tmp_path, sig, code):
    """A real ``euc-sim ride`` is signalled once its two simulation steps ride (on threads of
    its own: no process is left behind, and the steps end at their next rider block)."""
    argv = [sys.executable, "-c", "import sys; from euc_sim.cli import main; sys.exit(main())",
            "ride", str(log), "--n-boot", "10", "--workers", "2", "--report", str(tmp_path / "rep"),
            "--json", str(tmp_path / "o.json"), "--simulate"]
    # A shell starts a background job with SIGINT ignored, and Python keeps an ignored SIGINT:
    # run from such a job (nohup ... &, some CI runners) the command would never see the Ctrl-C
    # this test sends.  A user's terminal delivers it, so the child starts with the default.
    proc = subprocess.Popen(argv, stderr=subprocess.PIPE, text=True, cwd=tmp_path,
                            preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    lines = []
    try:
        for line in proc.stderr:                  # the steps print "riding ..." when they start
            lines.append(line)
            if sum("riding" in ln for ln in lines) == 2:
                break
        assert sum("riding" in ln for ln in lines) == 2, lines
        assert not _children(proc.pid)            # the steps are threads, not processes
        proc.send_signal(sig)
        assert proc.wait(timeout=20) == code
        rest = proc.stderr.read().splitlines()
    finally:
        if proc.poll() is None:
            proc.kill()
    assert not (tmp_path / "o.json").exists()
    assert not [p for p in tmp_path.rglob("*") if is_temporary(p)]
    assert not [p for p in (tmp_path / "rep").rglob("*") if p.is_file()]     # no partial report
    if sig != signal.SIGKILL:
        # the steps' progress bars (closed as each step is cancelled) aside, the one thing said
        # is the interruption
        said = [ln[ln.index("euc-sim ride:"):] for ln in rest if "euc-sim ride:" in ln]
        assert said == [f"euc-sim ride: interrupted{' (SIGTERM)' if sig == signal.SIGTERM else ''}"]
        others = [ln for ln in rest if "euc-sim ride:" not in ln and ln.strip() and not ln.startswith("ride: ")]
        assert all(ln.lstrip().startswith(("nominal ", "measured_law ", "drivetrain ")) for ln in others), others


def test_sigterm_during_a_write_removes_the_temporary_file(log, tmp_path, capsys, monkeypatch):
    """SIGTERM arriving while a figure is being written: exit 143, no temporary file, no JSON."""
    import euc_sim.io as io

    real = io.atomic_write

    def write_then_terminated(path, write):
        def w(p):
            write(p)
            assert Path(p).exists()
            os.kill(os.getpid(), signal.SIGTERM)
        return real(path, w)

    def unhandled(signum, frame):
        raise RuntimeError("SIGTERM reached the test: euc-sim did not handle it")

    monkeypatch.setattr(io, "atomic_write", write_then_terminated)
    previous = signal.signal(signal.SIGTERM, unhandled)
    try:
        code, _, err = run(["ride", log, "--no-simulate", "--n-boot", "10", "--quiet",
                            "--report", tmp_path / "rep", "--json", tmp_path / "o.json"], capsys)
    finally:
        signal.signal(signal.SIGTERM, previous)
    err = [ln for ln in err if not ln.startswith("euc-sim ride: note: ")]     # the reader's repairs
    assert code == 143 and err == ["euc-sim ride: interrupted (SIGTERM)"]
    assert not [p for p in tmp_path.rglob("*") if is_temporary(p)] and not (tmp_path / "o.json").exists()


# --- impossible readings ---------------------------------------------------------------------
@pytest.mark.parametrize("column, value, said", [
    (2, "1e308", "speed: 1 value(s) outside [-150, 150] km/h, first 1e+308 km/h at line 32; rows dropped"),
    (4, "-inf", "current: 1 value(s) outside [-500, 500] A, first -inf A at line 32; cells emptied (the rows kept)")])
def test_impossible_reading_is_dropped_and_said(log, tmp_path, capsys, column, value, said):
    """Found by the fuzz test: a huge speed ended in 'array must not contain infs or NaNs'; one
    such cell is now dropped (the speed's row) or emptied, and said on stderr."""
    header, *rows = log.read_text().splitlines()
    cells = rows[30].split(",")
    cells[column] = value
    bad = tmp_path / "bad.csv"
    bad.write_text("\n".join([header] + rows[:30] + [",".join(cells)] + rows[31:]) + "\n")
    code, _, err = run(["ride", bad, "--no-simulate", "--quiet", "--json", tmp_path / "o.json"], capsys)
    assert code == 0, err
    assert f"euc-sim ride: note: bad.csv: {said}" in err, err


def test_slow_part_of_a_trace_shorter_than_its_span():
    """Found by the fuzz test: a 25 s trace and a 30 s moving mean broke the residual figure."""
    import numpy as np

    from euc_sim.rides.balance.residual import moving_mean

    t = np.arange(250) * 0.1
    r = np.sin(t)
    slow = moving_mean(t, r, span=30.0)
    assert slow.shape == r.shape
    assert np.all(np.isfinite(slow)) and np.all((slow >= r.min()) & (slow <= r.max()))


# --- a log left recording through a long pause --------------------------------------------------
def test_halves_split_the_rows_not_the_clock_and_long_gaps_are_not_simulated(tmp_path, capsys):
    """Real case: wheellog_android_log_test1.csv has a 13 h pause; the clock's midpoint put
    every riding row in the fit half, and the simulation bridged 14.6 h (out of memory)."""
    import pandas as pd

    a = synth_log(tmp_path / "a.csv", seed=7, duration=60.0, gap_at=None, repeats=1)
    header, *rows = a.read_text().splitlines()
    later = []
    for row in rows[: len(rows) // 4]:            # 15 s more, 10 h later
        cells = row.split(",")
        stamp = pd.Timestamp(f"{cells[0]} {cells[1]}") + pd.Timedelta(hours=10)
        cells[0], cells[1] = f"{stamp:%Y-%m-%d}", f"{stamp:%H:%M:%S}.{stamp.microsecond // 1000:03d}"
        later.append(",".join(cells))
    log = tmp_path / "paused.csv"
    log.write_text("\n".join([header] + rows + later) + "\n")
    with pytest.warns(UserWarning, match=r"simulation skipped: paused\.csv has 1 gap\(s\) longer"):
        code, _, err = run(["ride", log, "--n-boot", "10", "--json", tmp_path / "o.json",
                            "--report", tmp_path / "rep", "--simulate"], capsys)
    assert code == 0, err
    rep = json.loads((tmp_path / "o.json").read_text())
    assert rep["simulation"] is None
    assert abs(rep["rows"]["fit"] - rep["rows"]["test"]) < 0.1 * rep["rows"]["fit"]
    assert "Simulation skipped" in (tmp_path / "rep" / "index.md").read_text()


def test_the_residuals_slow_part_is_its_moving_mean_over_the_samples_each_window_holds():
    import numpy as np
    import pytest

    from euc_sim.rides.balance.residual import moving_mean

    r = np.random.default_rng(0).normal(size=301) * 100.0
    t = np.arange(301) * 0.1
    for span in (0.1, 3.0, 30.0, 1e3):
        w = max(1, min(301, round(span / 0.1)))
        held = np.convolve(np.ones(301), np.ones(w), mode="same")          # samples in each window
        assert np.array_equal(moving_mean(t, r, span=span), np.convolve(r, np.ones(w), mode="same") / held)
    assert moving_mean(t, r, span=0.3)[0] == pytest.approx((r[0] + r[1]) / 2)          # an end: two samples
    assert moving_mean(t, r, span=0.3)[5] == pytest.approx((r[4] + r[5] + r[6]) / 3)

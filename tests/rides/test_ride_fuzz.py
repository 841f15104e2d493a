"""Hypothesis fuzz of ``euc-sim ride`` and the log reader over malformed ride logs.

A valid synthetic WheelLog (45 s, :mod:`ridesynth`) is damaged by one to three
mutations: a column dropped, cells emptied or set to NaN, text or huge values in
numbers, rows duplicated, timestamps running backwards or repeated, the file cut
anywhere, binary bytes, an empty file or a header alone.  Whatever comes out, the
command exits 0 or 2 (one line naming the problem), never with a traceback, and
leaves no partial output: with exit 2 neither the JSON nor any report file exists,
and no temporary file is left.  ``derandomize``: the same examples on every run.
"""

from __future__ import annotations

import contextlib
import io
import json
import math
import tempfile
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from ridesynth import synth_log

from euc_sim.cli import main
from euc_sim.io import is_temporary
from euc_sim.rides.source.logs import Ride, read_log

pytestmark = pytest.mark.filterwarnings("ignore::UserWarning")

_BASE_DIR = Path(tempfile.mkdtemp(prefix="ride-fuzz-base-"))
BASE = synth_log(_BASE_DIR / "base.csv", seed=5, duration=45.0, gap_at=None, repeats=1).read_bytes()
HEADER, *ROWS = BASE.decode().splitlines()
COLUMNS = HEADER.split(",")

_cell = st.tuples(st.integers(0, len(ROWS) - 1), st.integers(0, len(COLUMNS) - 1))
_bad_value = st.sampled_from(["", "nan", "NaN", "abc", "1e308", "-1e308", "inf", "1,5", "0x1F",
                              "１２", "--", "1e-320", "99999999999999999999"])
MUTATIONS = st.one_of(
    st.tuples(st.just("drop_column"), st.integers(0, len(COLUMNS) - 1)),
    st.tuples(st.just("set_cells"), st.lists(st.tuples(_cell, _bad_value), min_size=1, max_size=8)),
    st.tuples(st.just("set_column"), st.integers(0, len(COLUMNS) - 1), _bad_value),
    st.tuples(st.just("duplicate_rows"), st.lists(st.integers(0, len(ROWS) - 1), min_size=1,
                                                  max_size=20)),
    st.tuples(st.just("reverse_block"), st.integers(0, len(ROWS) - 1), st.integers(2, 200)),
    st.tuples(st.just("same_time"), st.integers(0, len(ROWS) - 1), st.integers(2, 200)),
    st.tuples(st.just("cut"), st.floats(0.0, 1.0)),
    st.tuples(st.just("binary"), st.floats(0.0, 1.0), st.binary(min_size=1, max_size=12)),
    st.tuples(st.just("keep_rows"), st.integers(0, 40)),
    st.tuples(st.just("empty"),),
)


def _mutate(data: bytes, mutation) -> bytes:
    kind, *arg = mutation
    try:
        header, *rows = data.decode().split("\n")
    except UnicodeDecodeError:
        header, rows = None, []
    if kind == "empty":
        return b""
    if kind == "cut":
        return data[: int(arg[0] * len(data))]
    if kind == "binary":
        i = int(arg[0] * len(data))
        return data[:i] + arg[1] + data[i:]
    if header is None:                 # already binary: only byte-level damage applies
        return data
    rows = [r for r in rows if r]
    table = [r.split(",") for r in rows]
    if kind == "drop_column":
        cut = lambda cells: [c for j, c in enumerate(cells) if j != arg[0]]  # noqa: E731
        header = ",".join(cut(header.split(",")))
        table = [cut(r) for r in table]
    elif kind == "set_cells":
        for (i, j), value in arg[0]:
            if i < len(table) and j < len(table[i]):
                table[i][j] = value
    elif kind == "set_column":
        for r in table:
            if arg[0] < len(r):
                r[arg[0]] = arg[1]
    elif kind == "duplicate_rows":
        for i in sorted(arg[0], reverse=True):
            if i < len(table):
                table.insert(i, list(table[i]))
    elif kind == "reverse_block":
        a, n = arg
        table[a:a + n] = table[a:a + n][::-1]
    elif kind == "same_time":
        a, n = arg
        for r in table[a:a + n]:
            if len(r) > 1 and a < len(table) and len(table[a]) > 1:
                r[0], r[1] = table[a][0], table[a][1]
    elif kind == "keep_rows":
        table = table[:arg[0]]
    return ("\n".join([header] + [",".join(r) for r in table]) + "\n").encode()


def _leftovers(folder: Path) -> list[Path]:
    return [p for p in folder.rglob("*") if is_temporary(p) or p.suffix == ".probe"]


@settings(max_examples=30, deadline=None, derandomize=True,
          suppress_health_check=[HealthCheck.too_slow])
@given(st.lists(MUTATIONS, min_size=1, max_size=3), st.sampled_from([False, False, True]))
def test_ride_on_malformed_logs_exits_0_or_2_and_leaves_no_partial_output(mutations, with_report):
    data = BASE
    for m in mutations:
        data = _mutate(data, m)
    with tempfile.TemporaryDirectory(prefix="ride-fuzz-") as tmp:
        tmp = Path(tmp)
        log = tmp / "ride.csv"
        log.write_bytes(data)
        try:
            parsed = read_log(log, emit_warnings=False)
        except (ValueError, OSError) as exc:
            assert str(log) in str(exc) or log.name in str(exc), exc
        else:
            assert isinstance(parsed, Ride)
            t = parsed.data["t"].to_numpy()
            assert len(t) >= 1 and all(b > a for a, b in zip(t, t[1:]))   # sorted, no repeats
        out, rep = tmp / "out" / "ride.json", tmp / "out" / "rep"
        err = io.StringIO()
        with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
            code = main(["ride", str(log), "--no-simulate", "--n-boot", "10", "--quiet",
                         "--json", str(out)] + (["--report", str(rep)] if with_report else []))
        lines = [ln for ln in err.getvalue().splitlines() if ln.strip()
                 and not ln.startswith("euc-sim: warning:")]
        assert code in (0, 2), lines
        assert not _leftovers(tmp)
        if code == 2:
            assert len(lines) == 1 and lines[0].startswith("euc-sim ride: error: "), lines
            assert "ride.csv" in lines[0] or "--" in lines[0], lines
            assert not out.exists()
            assert not (rep.exists() and any(p.is_file() for p in rep.rglob("*")))
        else:
            report = json.loads(out.read_text())
            assert (rep / "index.md").is_file() or not with_report
            assert math.isfinite(report["heldout_error_nominal"])
            for e in report["effects"]:
                assert e["ci95"][1] > e["ci95"][0]          # never a zero-width interval

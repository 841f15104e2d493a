"""Fuzz every command that reads a file: malformed recordings, sidecars and speed profiles.

Whatever the file holds, the command exits 0 or 2 (never a traceback: any other
exception fails the test) and leaves either its complete outputs or nothing, never
a temporary or partial file.
"""

from __future__ import annotations

import json
import shutil
import tempfile
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

hypothesis = pytest.importorskip("hypothesis")
from hypothesis import HealthCheck, given, settings, strategies as st  # noqa: E402

from euc_sim.cli import main  # noqa: E402
from euc_sim.io import is_temporary  # noqa: E402

SETTINGS = settings(max_examples=30, deadline=None, derandomize=True,
                    suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture])

COLUMNS = ["t", "x", "gamma", "phi", "M_d", "M_h", "psi", "theta"]
ODD = [np.nan, np.inf, -np.inf, 1e300, -1e300, 0.0, -0.0, 1e-300, 8.3, 1000.0, 57.3, -5.0]


def _valid(n: int, rng: np.random.Generator) -> pd.DataFrame:
    t = np.arange(n) / 120.0
    return pd.DataFrame({"t": t, "x": 2.0 * t - 0.2 * t**2,
                         "gamma": 0.02 * np.sin(3 * t) + 1e-3 * rng.standard_normal(n),
                         "phi": 0.05 * np.sin(2 * t), "M_d": 5.0 * np.sin(t), "M_h": np.cos(t)})


@st.composite
def recordings(draw):
    """A small recording, then a few mutations: cells, columns, rows, scale, text."""
    n = draw(st.sampled_from([0, 1, 2, 9, 500, 500, 500]) | st.integers(0, 500))
    df = _valid(n, np.random.default_rng(draw(st.integers(0, 9))))
    for _ in range(draw(st.integers(0, 4))):
        kind = draw(st.sampled_from(["cell", "drop", "scale", "text", "dup", "shuffle", "column"]))
        col = draw(st.sampled_from(COLUMNS))
        if kind == "cell" and n and col in df:
            df.loc[draw(st.integers(0, n - 1)), col] = draw(st.sampled_from(ODD))
        elif kind == "drop" and col in df:
            df = df.drop(columns=col)
        elif kind == "scale" and col in df and pd.api.types.is_numeric_dtype(df[col]):
            df[col] = df[col] * draw(st.sampled_from([1000.0, 57.3, -1.0, 0.0, 1e-6, 1e250]))
        elif kind == "text" and n and col in df:
            df[col] = df[col].astype(object)
            df.loc[draw(st.integers(0, n - 1)), col] = draw(st.text(max_size=5))
        elif kind == "dup" and n > 1:
            df = pd.concat([df, df.iloc[[draw(st.integers(0, n - 1))]]]).sort_index()
        elif kind == "shuffle" and n > 1:
            df = df.sample(frac=1.0, random_state=draw(st.integers(0, 9)))
        elif kind == "column":
            df[draw(st.text(min_size=1, max_size=4))] = draw(st.sampled_from(ODD))
    return df


json_values = st.recursive(
    st.none() | st.booleans() | st.floats(allow_nan=False) | st.integers() | st.text(max_size=6),
    lambda inner: st.lists(inner, max_size=3) | st.dictionaries(st.text(max_size=4), inner, max_size=3),
    max_leaves=8)
sidecars = st.one_of(
    st.none(),
    st.binary(max_size=40),
    json_values.map(lambda v: json.dumps(v).encode()),
    st.dictionaries(st.sampled_from(["params", "maneuver", "d_CE", "source", "maneuver_options"]),
                    json_values, max_size=3).map(lambda v: json.dumps(v).encode()),
    st.dictionaries(st.sampled_from(["m", "h", "R", "g", "J0", "zz"]),
                    st.floats(allow_nan=True, allow_infinity=True) | st.text(max_size=3),
                    max_size=3).map(lambda p: json.dumps({"params": p}).encode()),
)
raw_files = st.binary(max_size=200)


def _run(argv, folder: Path, outputs: list[str]) -> None:
    before = set(folder.iterdir())
    code = main([str(a) for a in argv])
    assert code in (0, 2), code
    after = set(folder.iterdir()) - before
    names = {p.name for p in after}
    assert not any(is_temporary(n) or n.endswith(".probe") or n.startswith(".") for n in names), names
    if code == 2:
        assert not after, names
    else:
        assert names <= set(outputs), names


def _write(folder: Path, df, raw: bytes | None, side: bytes | None, name="rec.csv") -> Path:
    path = folder / name
    if raw is not None:
        path.write_bytes(raw)
    else:
        df.to_csv(path, index=False)
    if side is not None:
        path.with_suffix(".json").write_bytes(side)
    return path


def _case(run):
    folder = Path(tempfile.mkdtemp(prefix="euc-fuzz-"))
    try:
        run(folder)
    finally:
        shutil.rmtree(folder, ignore_errors=True)


@SETTINGS
@given(df=recordings(), raw=st.none() | raw_files, side=sidecars)
def test_fuzz_torques(df, raw, side):
    _case(lambda d: _run(["torques", _write(d, df, raw, side), "--out", d / "T.csv"], d, ["T.csv"]))


@SETTINGS
@given(df=recordings(), raw=st.none() | raw_files, side=sidecars)
def test_fuzz_identify(df, raw, side):
    _case(lambda d: _run(["identify", _write(d, df, raw, side), "--n-boot", "0",
                          "--json", d / "o.json"], d, ["o.json"]))


@SETTINGS
@given(df=recordings(), raw=st.none() | raw_files, side=sidecars)
def test_fuzz_diagnose(df, raw, side):
    _case(lambda d: _run(["diagnose", _write(d, df, raw, side), "--no-resimulate",
                          "--json", d / "o.json"], d, ["o.json"]))


@st.composite
def profiles(draw):
    n = draw(st.integers(0, 6))
    t = draw(st.lists(st.sampled_from([0.0, 0.5, 1.0, 2.0, -1.0, np.nan, 1e300]), min_size=n,
                      max_size=n))
    v = draw(st.lists(st.sampled_from([0.0, 1.0, 3.0, -2.0, 50.0, np.inf, 1e300]), min_size=n,
                      max_size=n))
    cols = draw(st.sampled_from([("t", "v"), ("t",), ("v", "t"), ("time", "v")]))
    data = {c: (t if c != "v" else v) for c in cols}
    return pd.DataFrame(data)


@SETTINGS
@given(df=profiles(), raw=st.none() | raw_files)
def test_fuzz_simulate_profile(df, raw):
    def run(d):
        prof = _write(d, df, raw, None, "profile.csv")
        _run(["simulate", "--profile", prof, "--duration", "0.5", "--engine", "analytic",
              "--out", d / "r.csv"], d, ["r.csv", "r.json", "r.truth.json"])
    _case(run)

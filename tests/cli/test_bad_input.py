"""Bad input that used to escape: one line naming the culprit, exit 2, nothing left behind."""

from __future__ import annotations

import json
import re

import numpy as np
import pandas as pd
import pytest

from euc_sim.cli import main


def _frame(n: int = 360) -> pd.DataFrame:
    t = np.arange(n) / 120.0
    return pd.DataFrame({"t": t, "x": 2.0 * t - 0.3 * t**2, "gamma": 0.02 * np.sin(3 * t),
                         "phi": 0.05 * np.sin(2 * t)})


def _write(tmp_path, df=None, meta=None, name="rec.csv", raw_meta: bytes | None = None):
    path = tmp_path / name
    (df if df is not None else _frame()).to_csv(path, index=False) if name.endswith(".csv") \
        else (df if df is not None else _frame()).to_parquet(path)
    path.with_suffix(".json").unlink(missing_ok=True)
    if meta is not None:
        path.with_suffix(".json").write_text(json.dumps(meta))
    if raw_meta is not None:
        path.with_suffix(".json").write_bytes(raw_meta)
    return path


def _fails(argv, match, capsys, tmp_path):
    before = set(tmp_path.rglob("*"))
    assert main([str(a) for a in argv]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1, err
    assert re.search(match, err), err
    assert set(tmp_path.rglob("*")) == before         # nothing written, no temporary file
    return err


@pytest.mark.parametrize("command", ["torques", "identify"])
def test_sidecar_params_list_or_not_utf8(tmp_path, capsys, command):
    extra = ["--out", tmp_path / "T.csv"] if command == "torques" else ["--n-boot", "50"]
    rec = _write(tmp_path, meta={"params": [1, 2]})
    _fails([command, rec, *extra], r"rec\.json: \"params\" must be an object .* got list", capsys,
           tmp_path)
    rec = _write(tmp_path, raw_meta=b'{"params": {"m": 65}, "source": "\xff\xfe"}')
    _fails([command, rec, *extra], r"rec\.json: sidecar is not UTF-8", capsys, tmp_path)
    rec = _write(tmp_path, meta={"params": {"m": "heavy"}})
    _fails([command, rec, *extra], r"rec\.json: \"params\"\.m must be a number", capsys, tmp_path)


def test_implausible_values_and_units(tmp_path, capsys):
    out = ["--out", tmp_path / "T.csv"]
    df = _frame()
    df.loc[10, "x"] = 1e300
    _fails(["torques", _write(tmp_path, df), *out], r"column 'x' row 11: 1e\+300 is implausible",
           capsys, tmp_path)
    ms = _frame().assign(t=lambda d: d["t"] * 1000)
    _fails(["torques", _write(tmp_path, ms), *out], r"column 't'.*sample period 8\.333 \(milliseconds\?\)",
           capsys, tmp_path)
    idx = _frame().assign(t=lambda d: np.arange(len(d)))
    _fails(["torques", _write(tmp_path, idx), *out], r"column 't'.*sample period 1 \(sample indices\?\)",
           capsys, tmp_path)
    td = _frame().assign(t=lambda d: pd.to_timedelta(d["t"], unit="s"))
    _fails(["torques", _write(tmp_path, td, name="td.parquet"), *out],
           r"column 't' row 1: expected plain numbers .* got timedelta", capsys, tmp_path)
    deg = _frame().assign(gamma=lambda d: np.degrees(d["gamma"]))   # peak 1.15°, below 60
    _fails(["torques", _write(tmp_path, deg), *out], r"column 'gamma' .* looks like degrees",
           capsys, tmp_path)
    with pytest.raises(SystemExit) as exc:
        main(["torques", str(_write(tmp_path)), "--h", "1e6", *map(str, out)])
    assert exc.value.code == 2
    assert re.search(r"argument --h: expected a number in \[0\.05, 2\.5\] m, got 1e6", capsys.readouterr().err)
    _fails(["torques", _write(tmp_path, meta={"params": {"h": 40}}), *out],
           r"rec\.json.*parameter 'h' .* must lie in \[0\.05, 2\.5\] m .* got 40 m", capsys, tmp_path)
    _fails(["torques", _write(tmp_path), "--param", "m=1e300", *out],
           r"parameter 'm' \(rider's mass\) must lie in \[30, 200\] kg .* got 1e\+300 kg", capsys,
           tmp_path)


def test_culprits_are_named_before_the_work(tmp_path, capsys):
    rec = _write(tmp_path)
    blocker = tmp_path / "file"
    blocker.write_text("x")
    _fails(["identify", rec, "--report", blocker], r"cannot write .*file/identify\.png",
           capsys, tmp_path)
    with pytest.raises(SystemExit) as exc:
        main(["identify", str(rec), "--seed", "-5"])
    assert exc.value.code == 2
    assert "argument --seed: expected a non-negative integer, got -5" in capsys.readouterr().err


def test_little_data_is_not_called_identifiable(tmp_path, capsys):
    rec = tmp_path / "decel.csv"
    assert main(["simulate", "--maneuver", "deceleration", "--duration", "10", "--seed", "1",
                 "--out", str(rec)]) == 0
    assert main(["identify", str(rec), "--json", str(tmp_path / "o.json")]) == 0
    assert json.loads((tmp_path / "o.json").read_text())["models"]["3dof"]["identifiable"]
    for opt, why in ((["--block", "1000"], "block"), (["--n-boot", "0"], "too few")):
        assert main(["identify", str(rec), *opt, "--json", str(tmp_path / "o.json")]) == 0
        out = json.loads((tmp_path / "o.json").read_text())
        assert not out["models"]["3dof"]["identifiable"]
        assert why in out["models"]["3dof"]["reason"]


def test_torques_mark_the_filter_edges(tmp_path, capsys):
    rec = _write(tmp_path, _frame(600))
    assert main(["torques", str(rec), "--out", str(tmp_path / "T.csv")]) == 0
    T = pd.read_csv(tmp_path / "T.csv")
    assert {"t", "M_d1", "M_d2", "M_h", "M_d1_2dof", "M_d2_2dof", "valid"} <= set(T.columns)
    v = T["valid"].to_numpy()
    assert v[0] == 0 and v[-1] == 0 and v[len(v) // 2] == 1
    edge = int(np.argmax(v))
    assert edge > 10 and (v[edge:len(v) - edge] == 1).all() and (v[:edge] == 0).all()


def test_single_recording_figures_are_named_for_what_they_show(tmp_path, capsys):
    rec = _write(tmp_path, _frame(1800), name="decel.csv")
    rep = tmp_path / "rep"
    assert main(["identify", str(rec), "--n-boot", "50", "--report", str(rep)]) == 0
    fig8, figs67 = rep / "identify.png", rep / "identify-torques.png"
    assert fig8.exists() and figs67.exists()
    assert not (rep / "identify-decel.png").exists()
    # issue 19, item 14: every file written is announced, and the help says there are two
    printed = [ln.removeprefix("wrote ") for ln in capsys.readouterr().out.splitlines() if ln.startswith("wrote ")]
    on_disk = sorted(str(p) for p in rep.glob("*.png"))
    assert sorted(printed) == on_disk == [str(figs67), str(fig8)]
    from euc_sim.cli.app import build_parser
    with pytest.raises(SystemExit):
        build_parser().parse_args(["identify", "--help"])
    assert "ALSO writes Figs. 6/7 beside it" in " ".join(capsys.readouterr().out.split())


def test_version_and_help_texts(capsys):
    import argparse

    from euc_sim.cli.app import build_parser
    with pytest.raises(SystemExit) as exc:
        main(["--version"])
    assert exc.value.code == 0 and capsys.readouterr().out.startswith("euc-sim ")
    sub = next(a for a in build_parser()._actions if isinstance(a, argparse._SubParsersAction))
    for name, parser in sub.choices.items():
        for action in parser._actions:
            assert action.help, (name, action.option_strings or action.dest)
            assert "identification." not in action.help, (name, action.help)


def test_stability_eigenvalues_for_people():
    from euc_sim.cli.sim import format_eigenvalues
    text = format_eigenvalues([(-4.22, 0), (0, 0), (-0.0, 0), (4.44e-16, -5.86), (4.44e-16, 5.86)])
    assert text == "-4.22, 0, 0, ±5.86j"
    assert format_eigenvalues([(-30.1, -5.41), (-30.1, 5.41)]) == "-30.1 ± 5.41j"


def test_broken_pipe_exits_quietly(tmp_path):
    import subprocess
    import sys
    code = ("import sys; from euc_sim.cli import main\n"
            "sys.exit(main(['dynamics', '--q', '0,0.01,0.02']))")
    p = subprocess.Popen([sys.executable, "-c", code], stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    p.stdout.close()                                    # the reader leaves before any output
    err = p.stderr.read().decode()
    assert p.wait() == 141 and err == "", err

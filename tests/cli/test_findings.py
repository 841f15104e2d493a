"""Each finding of the fuzz campaign, answered: one line naming the culprit, exit 2, nothing written.

And the other side of the line: a bug is an internal error (exit 1, one line, the
traceback in a file), never reported as the user's mistake.
"""

from __future__ import annotations

import json
import re
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from euc_sim.cli import main


@pytest.fixture(scope="module")
def made(tmp_path_factory):
    """REC.csv (deceleration, 6 s, seed 1) with its sidecars, simulated once."""
    folder = tmp_path_factory.mktemp("rec")
    assert main(["simulate", "--maneuver", "deceleration", "--duration", "6", "--seed", "1",
                 "--out", str(folder / "REC.csv")]) == 0
    return folder


@pytest.fixture
def rec(made, tmp_path):
    """A fresh copy of REC.csv, REC.json, REC.truth.json in this test's folder."""
    for p in made.iterdir():
        shutil.copy(p, tmp_path / p.name)
    return tmp_path / "REC.csv"


def _snapshot(folder: Path) -> dict:
    return {p: p.read_bytes() for p in sorted(folder.rglob("*")) if p.is_file()} | {
        p: None for p in folder.rglob("*") if p.is_dir()}


def _without_progress(err: str) -> str:
    """stderr without the progress lines (``diagnose: 1/6 prepare: ... ...``), which end in "...",
    and without a deprecated option's one-line note (the refusal is the line that stays)."""
    return "\n".join(ln for ln in err.strip().splitlines()
                     if not ln.endswith("...") and " is deprecated; use " not in ln)


def _refused(argv, match, capsys, folder: Path) -> str:
    """Run ``argv``: exit 2, one line on stderr matching ``match``, every file and folder as before."""
    before = _snapshot(folder)
    try:
        code = main([str(a) for a in argv])
    except SystemExit as exc:           # argparse's own refusals
        code = exc.code
    err = _without_progress(capsys.readouterr().err)
    assert code == 2, (code, err)
    assert len(err.splitlines()) == 1, err
    assert re.search(match, err), err
    assert _snapshot(folder) == before        # nothing written, overwritten or left behind
    return err


def test_render_header_only_and_nan_rows(rec, capsys, tmp_path):
    df = pd.read_csv(rec)
    df.head(0).to_csv(tmp_path / "head.csv", index=False)
    _refused(["render", tmp_path / "head.csv", "--out", tmp_path / "h.png"],
             r"head\.csv: no data rows", capsys, tmp_path)
    df.loc[5:10, "gamma"] = np.nan
    df.to_csv(tmp_path / "nan.csv", index=False)
    _refused(["render", tmp_path / "nan.csv", "--out", tmp_path / "n.png"],
             r"nan\.csv: column 'gamma' row 6: nan is not a finite number", capsys, tmp_path)


@pytest.mark.parametrize("options", [[1], "fast", {"cycles": "many"}])
def test_sidecar_maneuver_options_of_the_wrong_kind(rec, capsys, tmp_path, options):
    meta = json.loads(rec.with_suffix(".json").read_text())
    meta.update(maneuver="stop_and_go", maneuver_options=options)
    rec.with_suffix(".json").write_text(json.dumps(meta))
    _refused(["diagnose", rec, "--json", tmp_path / "d.json"], r"REC\.json: \"maneuver_options\"",
             capsys, tmp_path)


def test_maneuver_options_have_upper_bounds():
    from euc_sim.simulation.errors import SimulationError
    from euc_sim.simulation.maneuvers import make_maneuver

    with pytest.raises(SimulationError, match=r"'cycles' must lie in \[1, 100\], got 1e\+09"):
        make_maneuver("stop_and_go", cycles=1e9)
    with pytest.raises(SimulationError, match=r"'v' must lie in \[-30, 30\]"):
        make_maneuver("constant_speed", v=1e6)


def test_a_recording_without_phi(rec, capsys, tmp_path):
    nophi = tmp_path / "NOPHI.csv"
    pd.read_csv(rec).drop(columns="phi").to_csv(nophi, index=False)
    for argv in (["torques", nophi, "--source", "state", "--out", tmp_path / "T.csv"],
                 ["identify", nophi, "--source", "state", "--n-boot", "0"]):
        _refused(argv, r"NOPHI\.csv: column 'phi' missing", capsys, tmp_path)


@pytest.mark.parametrize("argv, match", [
    (["identify", "{rec}", "--n-boot", "100000000"], r"argument --n-boot: expected an integer in \[0, 100000\], got 100000000"),
    (["identify", "{rec}", "--noise-replicates", "100000000"], r"argument --noise-replicates: .*got 100000000"),
    (["simulate", "--duration", "2", "--rider-delay", "1e6", "--out", "{dir}/s.csv"], r"argument --rider-delay: .*\[0, 1\] s, got 1e6"),
    (["stability", "--rider-delay", "10"], r"argument --rider-delay: .*got 10"),
    (["stability", "--speed", "nan"], r"argument --speed: expected a number in \[-30, 30\] m/s, got nan"),
    (["identify", "{rec}", "--order", "200"], r"argument --order: expected an integer in \[2, 12\], got 200"),
    (["torques", "{rec}", "--order", "200", "--out", "{dir}/T.csv"], r"argument --order: .*\[2, 12\], got 200"),
    (["simulate", "--no-such-option", "--out", "{dir}/s.csv"], r"^euc-sim: error: unrecognized arguments: --no-such-option \(see euc-sim --help\)$"),
    (["simulate", "--model", "3d", "--maneuver", "circle", "--duration", "1", "--out", "{dir}/s.csv"],
     r"--duration: the 3-D model needs at least 1\.001 s .* got 1$"),
    (["simulate", "--duration", "x", "--out", "{dir}/s.csv"], r"^euc-sim simulate: error: argument --duration: .* \(see euc-sim simulate --help\)$"),
])
def test_options_out_of_bounds(rec, capsys, tmp_path, argv, match):
    argv = [a.format(rec=rec, dir=tmp_path) for a in argv]
    _refused(argv, match, capsys, tmp_path)


def test_ride_mass_out_of_bounds_and_mph(capsys, tmp_path):
    log = _wheellog(tmp_path / "LOG.csv", speed_scale=1.0)
    _refused(["ride", log, "--mass", "1e300", "--json", tmp_path / "r.json"],
             r"--mass: expected a number in \[35, 350\] kg, got 1e\+300", capsys, tmp_path)
    mph = _wheellog(tmp_path / "MPH.csv", speed_scale=1 / 1.609344)
    _refused(["ride", mph, "--no-simulate", "--json", tmp_path / "r.json"],
             r"MPH\.csv: column 'speed': the speed integrates to 0\.62 × the distance", capsys, tmp_path)


def _wheellog(path: Path, speed_scale: float) -> Path:
    """A WheelLog-layout log, 2 min at 5 Hz, whose odometer counts what its speed says (× scale)."""
    rng = np.random.default_rng(0)
    n = 600
    t = np.arange(n) * 0.2
    v = 20.0 + 5.0 * np.sin(t / 10.0)                       # km/h
    dist = np.concatenate([[0.0], np.cumsum(0.5 * (v[1:] + v[:-1]) / 3.6 * 0.2)])
    stamp = pd.Timestamp("2020-05-16 08:02:10") + pd.to_timedelta(t, unit="s")
    current = 5.0 + 0.3 * np.diff(v, prepend=v[0]) / 0.2 + 0.2 * rng.standard_normal(n)
    pd.DataFrame({
        "date": stamp.strftime("%Y-%m-%d"), "time": stamp.strftime("%H:%M:%S.%f").str[:-3],
        "speed": np.round(v * speed_scale, 2), "voltage": 64.0, "current": np.round(current, 2),
        "power": np.round(64.0 * current, 2), "battery_level": 90, "distance": np.floor(dist),
        "totaldistance": 399713 + np.floor(dist), "system_temp": 27, "cpu_temp": 0, "tilt": 0.0,
        "roll": 0.0, "mode": 0, "alert": "",
    }).to_csv(path, index=False)
    return path


def test_an_output_that_is_an_input_is_refused(rec, capsys, tmp_path):
    _refused(["torques", rec, "--out", rec], r"--out .*REC\.csv: is the input recording .*REC\.csv; "
             r"refusing to overwrite it", capsys, tmp_path)
    for cmd in ("identify", "diagnose"):
        _refused([cmd, rec, "--json", rec], r"--json .*REC\.csv: is the input", capsys, tmp_path)
    _refused(["identify", rec, "--json", rec.with_suffix(".json")],
             r"--json .*REC\.json: is the sidecar of .*REC\.csv", capsys, tmp_path)
    _refused(["identify", rec, "--json", tmp_path / "REC.truth.json"], r"is the sidecar of", capsys, tmp_path)
    log = _wheellog(tmp_path / "LOG.csv", 1.0)
    _refused(["ride", log, "--json", log], r"--json .*LOG\.csv: is the input log", capsys, tmp_path)


def test_simulate_keeps_a_foreign_sidecar(capsys, tmp_path):
    (tmp_path / "ride.json").write_text('{"mine": "not euc-sim\'s"}\n')
    _refused(["simulate", "--duration", "1", "--out", tmp_path / "ride.csv"],
             r"--out .*ride\.csv: its sidecar .*ride\.json exists and is not one euc-sim wrote",
             capsys, tmp_path)
    (tmp_path / "ride.json").unlink()
    (tmp_path / "ride.truth.json").write_text("{}\n")
    _refused(["simulate", "--duration", "1", "--out", tmp_path / "ride.csv"],
             r"ride\.truth\.json exists without an euc-sim sidecar", capsys, tmp_path)


def test_simulate_replaces_its_own_sidecar(tmp_path):
    out = tmp_path / "ride.csv"
    assert main(["simulate", "--duration", "1", "--out", str(out)]) == 0
    first = out.with_suffix(".json").read_text()
    assert main(["simulate", "--duration", "1", "--seed", "3", "--out", str(out)]) == 0
    assert out.with_suffix(".json").read_text() != first         # a rerun of ours: replaced


def test_no_folder_is_made_for_a_refused_command(capsys, tmp_path):
    bad = tmp_path / "bad.csv"
    bad.write_text("t,x\n")
    _refused(["torques", bad, "--out", tmp_path / "new" / "deep" / "T.csv"], r"bad\.csv", capsys, tmp_path)
    _refused(["diagnose", bad, "--json", tmp_path / "new" / "d.json"], r"bad\.csv", capsys, tmp_path)
    assert not (tmp_path / "new").exists()


def test_a_file_in_the_way_of_a_folder_is_named(rec, capsys, tmp_path):
    _refused(["torques", rec, "--out", tmp_path / "REC.json" / "T.csv"],
             r"error: cannot write .*REC\.json/T\.csv: .*REC\.json is not a folder$", capsys, tmp_path)


def _unbounded_drag(monkeypatch):
    """``aerodynamic_drag`` without its catalog bound, so an absurd drag reaches MuJoCo."""
    import dataclasses

    from euc_sim.simulation import effects

    wide = dataclasses.replace(effects.CATALOG["aerodynamic_drag"], bounds=(0.0, float("inf")))
    monkeypatch.setitem(effects.CATALOG, "aerodynamic_drag", wide)


def test_an_effect_that_makes_mujoco_unstable(capsys, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    _unbounded_drag(monkeypatch)
    _refused(["simulate", "--effect", "aerodynamic_drag=1e300", "--duration", "1", "--out", "a.csv"],
             r"the simulation went unstable .* MuJoCo found NaN, infinite or huge values \(Q", capsys, tmp_path)
    assert not (tmp_path / "MUJOCO_LOG.TXT").exists()


def test_a_full_disk_names_the_file(rec, tmp_path):
    """"[Errno 27] File too large" with the path: a write past RLIMIT_FSIZE (Python ignores SIGXFSZ)."""
    resource = pytest.importorskip("resource")
    code = ("import resource, sys; from euc_sim.cli import main\n"
            "resource.setrlimit(resource.RLIMIT_FSIZE, (20000, 20000))\n"
            f"sys.exit(main(['torques', {str(rec)!r}, '--out', {str(tmp_path / 'T.csv')!r}]))")
    p = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    err = p.stderr.strip()
    assert p.returncode == 2, err
    assert len(err.splitlines()) == 1 and re.search(r"T\.csv: File too large", err), err
    assert sorted(f.name for f in tmp_path.iterdir()) == ["REC.csv", "REC.json", "REC.truth.json"]


def test_a_bug_is_an_internal_error_with_its_traceback_in_a_file(capsys, tmp_path, monkeypatch):
    from euc_sim.model import crosscheck

    def broken(*args, **kwargs):
        return np.empty(0)[1]          # an IndexError from inside numpy: not the user's doing

    monkeypatch.setattr(crosscheck, "run_all", broken)
    out = tmp_path / "out"
    out.mkdir()
    assert main(["crosscheck", "--samples", "1", "--json", str(out / "c.json")]) == 1
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1, err
    m = re.fullmatch(r"euc-sim crosscheck: internal error: IndexError: index 1 is out of bounds .*; "
                     r"the traceback is in (.+)", err)
    assert m, err
    report = Path(m.group(1))
    assert report.parent == out and "in broken" in report.read_text()
    assert [p.name for p in out.iterdir()] == [report.name]          # no c.json, no temporary
    # without an output folder: the temp dir
    import tempfile
    monkeypatch.setattr(tempfile, "tempdir", str(tmp_path / "tmp"))
    (tmp_path / "tmp").mkdir()
    assert main(["crosscheck", "--samples", "1"]) == 1
    err = capsys.readouterr().err.strip()
    assert re.search(rf"the traceback is in {re.escape(str(tmp_path / 'tmp'))}/euc-sim-crosscheck-"
                     r"internal-error-\w+\.txt$", err), err


def test_an_unstable_effect_in_a_dataset_is_named(capsys, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    _unbounded_drag(monkeypatch)
    code = main(["dataset", "--out-dir", "D", "--duration", "1", "--workers", "1", "--quiet",
                 "--effect", "aerodynamic_drag=1e300"])
    err = capsys.readouterr().err
    assert code == 2, err
    assert "Traceback" not in err and "RuntimeError" not in err, err
    assert err.count("UnstableError: the simulation went unstable") == 14, err
    assert not (tmp_path / "MUJOCO_LOG.TXT").exists()
    assert sorted(p.name for p in (tmp_path / "D").iterdir()) == ["dataset.json"]


@pytest.mark.parametrize("command", ["identify", "torques", "diagnose"])
def test_a_folder_given_as_a_recording(capsys, tmp_path, monkeypatch, command):
    monkeypatch.chdir(tmp_path)
    extra = ["--out", "T.csv"] if command == "torques" else ["--json", "o.json"]
    _refused([command, ".", *extra], r"error: \.: (is a folder|no such recording)", capsys, tmp_path)

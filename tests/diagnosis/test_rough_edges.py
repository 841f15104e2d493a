"""User-found rough edges of ``diagnose`` and its report (one test each)."""

from __future__ import annotations

import warnings

import pytest

from euc_sim.diagnosis import pipeline as diagnosis
from euc_sim.report.diagnosis import summary


def _recording(name, maneuver="stop_and_go", effects=(), hide=True, seed=8, duration=15.0, **opts):
    from euc_sim.simulation import dataset
    from euc_sim.simulation.maneuvers import make_maneuver
    spec = dataset.RecordingSpec(name, make_maneuver(maneuver, **opts), duration, seed, effects=effects,
                                 hide_torques=hide)
    rec, meta, _ = dataset.simulated_recording(spec)
    return rec, meta


@pytest.fixture(scope="module")
def concealed_friction():
    """Bearing friction without M_d: invisible to M_d,1 − M_d,2."""
    rec, meta = _recording("bf", effects=(("wheel_bearing_friction", 1.5),))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return diagnosis.diagnose(rec, meta=meta, resimulate=False)


def test_nothing_missing_says_what_the_recording_cannot_see(concealed_friction):
    res = concealed_friction
    assert res["effects"] == []
    assert res["verdict"] == "nothing missing that this recording can reveal"
    assert "wheel_bearing_friction" in res["cannot_see"]
    assert "M_d" in res["cannot_see"]["wheel_bearing_friction"]
    text = summary(res)
    assert "cannot see: wheel_bearing_friction" in text
    assert "with the accepted effects" not in text
    assert "mismatch concentrates" not in text
    assert "NOTES" not in text


@pytest.fixture(scope="module")
def recording_file(tmp_path_factory):
    """A short stop-and-go with rolling resistance, written with its sidecar."""
    import json
    out = tmp_path_factory.mktemp("rec")
    rec, meta = _recording("rr", effects=(("rolling_resistance", 0.03),), duration=12.0)
    rec.to_csv(out / "rr.csv", index=False)
    (out / "rr.json").write_text(json.dumps(meta))
    return out / "rr.csv"


def test_diagnose_shows_its_steps_on_stderr(recording_file, capsys):
    from euc_sim.cli import main
    assert main(["diagnose", str(recording_file), "--no-resimulate"]) == 0
    err = capsys.readouterr().err
    for step in ("1/6 prepare", "2/6 residual", "3/6 candidates", "4/6 refine", "5/6 verdict"):
        assert step in err
    assert main(["diagnose", str(recording_file), "--no-resimulate", "--quiet"]) == 0
    assert "1/6" not in capsys.readouterr().err


def test_a_motionless_recording_is_one_line_naming_the_file(recording_file, tmp_path, capsys):
    import json

    import pandas as pd

    from euc_sim.cli import main
    df = pd.read_csv(recording_file)
    for c in df.columns:
        if c != "t":
            df[c] = 0.0
    df.to_csv(tmp_path / "still.csv", index=False)
    (tmp_path / "still.json").write_text(recording_file.with_suffix(".json").read_text())
    assert main(["diagnose", str(tmp_path / "still.csv"), "--quiet"]) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and "Traceback" not in err
    assert "still.csv" in err and "too little excitation" in err
    assert json.loads((tmp_path / "still.json").read_text())      # the sidecar untouched


def test_an_unwritable_report_is_found_before_any_work(recording_file, tmp_path, capsys):
    from euc_sim.cli import main
    blocker = tmp_path / "blocker"
    blocker.write_text("a file where the report folder should go")
    code = main(["diagnose", str(recording_file), "--no-resimulate", "--json", str(tmp_path / "o.json"),
                 "--report", str(blocker / "rep")])
    err = capsys.readouterr().err
    assert code == 2
    assert "1/6" not in err                    # refused before the first step
    assert "blocker" in err
    assert not (tmp_path / "o.json").exists()


def test_a_failing_report_leaves_no_json(recording_file, tmp_path, capsys, monkeypatch):
    from euc_sim.cli import main
    from euc_sim.report import diagnosis as report

    def broken(result):
        raise ValueError("figure: cannot be drawn (simulated failure)")

    monkeypatch.setitem(report.FIGURES, "terms.png", (broken, 100))
    code = main(["diagnose", str(recording_file), "--no-resimulate", "--quiet",
                 "--json", str(tmp_path / "o.json"), "--report", str(tmp_path / "rep")])
    assert code == 1                    # a figure that cannot be drawn is the program's error
    assert "internal error" in capsys.readouterr().err
    assert not (tmp_path / "o.json").exists()
    assert not (tmp_path / "rep" / "index.md").exists()
    assert not list((tmp_path / "rep").glob("*.png")) if (tmp_path / "rep").exists() else True


def test_the_report_reads_as_text_for_people(tmp_path):
    """No raw Python dict, no broken table markup, ranges with units, no citation of a
    file users do not have, and the re-simulation's gain explained."""
    from euc_sim.report.diagnosis import write_report
    rec, meta = _recording("opt", effects=(("aerodynamic_drag", 0.5),), duration=12.0, v=3.0)
    assert meta.get("maneuver_options")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        res = diagnosis.diagnose(rec, meta=meta)
    page = write_report(res, tmp_path / "rep").read_text()
    assert "{'" not in page and "'}" not in page
    assert "/θ//se" not in page
    assert "NOTES" not in page
    assert "0.15 to 0.6 kg/m" in page                      # aerodynamic_drag's plausible range, with its unit
    assert "from the nominal 65 kg" in page                # rider_mass: a change, said so
    assert "not the test of the effect" in page            # the re-simulation's meaning
    assert "v = 3" in page


@pytest.mark.parametrize("m, says", [(1.0, "parameter 'm' (rider's mass) must lie in [30, 200] kg"),
                                     (-4.0, "must be positive")])
def test_a_wrong_sidecar_mass_is_an_error_naming_the_sidecar_and_field(recording_file, tmp_path, capsys, m, says):
    """A sidecar mass of 1 kg gave '-4.0 kg' (the rider-mass term's 5 kg finite step)
    with no file named; a negative one named the recording, not the sidecar."""
    import json
    import shutil

    from euc_sim.cli import main
    shutil.copy(recording_file, tmp_path / "light.csv")
    meta = json.loads(recording_file.with_suffix(".json").read_text())
    meta["params"]["m"] = m
    (tmp_path / "light.json").write_text(json.dumps(meta))
    assert main(["diagnose", str(tmp_path / "light.csv"), "--quiet", "--no-resimulate"]) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err
    assert "light.json (sidecar of light.csv)" in err and says in err
    assert "-4.0 kg" not in err or m == -4.0


@pytest.mark.parametrize("change, says, never", [
    (-80.0, "falls by 80 %", ("small", "modest", "hardly", "rises")),
    (-12.0, "falls by 12 %", ("much more closely", "hardly", "rises")),
    (-2.0, "hardly changes with the effects (-2 %)", ("falls", "rises", "much more closely")),
    (3.0, "hardly changes with the effects (+3 %)", ("falls", "rises")),
    (40.0, "rises by 40 %", ("falls", "small", "hardly", "much more closely")),
])
def test_the_resimulation_sentence_follows_its_number(change, says, never):
    """Issue 19, item 5: a −80 % change is not called small by nature."""
    from euc_sim.report.diagnosis import resimulation_change_text

    text = resimulation_change_text(change)
    assert says in text
    assert not any(w in text for w in never), text

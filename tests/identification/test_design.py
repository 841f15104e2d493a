"""euc-sim design: the paper's flat constant speed, Fisher beside Monte Carlo, the CLI."""

from __future__ import annotations

import json
import math

import pytest

from euc_sim.cli.app import main
from euc_sim.identification.design import design, recordings_for


@pytest.fixture(scope="module")
def result():
    return design(["constant_speed", "stop_and_go"], rides=4, duration=6.0, noise_scales=(1.0,),
                  workers=1, progress=False, seed=3)


def test_constant_speed_is_flat_and_stop_and_go_is_recommended(result):
    rows = {r["maneuver"]: r for r in result["maneuvers"]}
    cs, sg = rows["constant_speed"], rows["stop_and_go"]
    assert cs["h_sd"] > 3.0 * sg["h_sd"]                   # ≥ 10x the recordings: flat
    assert result["flat"] == ["constant_speed"] and result["best"] == "stop_and_go"
    assert "Record stop_and_go" in result["recommendation"]
    assert cs["recordings_for"]["0.01"] > sg["recordings_for"]["0.01"]


def test_fisher_prediction_is_within_a_factor_of_two_of_monte_carlo(result):
    for r in result["maneuvers"]:
        assert 0.5 < r["h_sd_fisher"] / r["h_sd"] < 2.0, r


def test_recordings_for_pools_as_one_over_root_n():
    assert recordings_for(0.03, [0.01, 0.05]) == {"0.01": 9, "0.05": 1}
    assert recordings_for(0.0101, [0.01]) == {"0.01": 2}


def test_cli_design_writes_the_contract_json(tmp_path, capsys):
    out = tmp_path / "d.json"
    code = main(["design", "--maneuvers", "constant_speed,deceleration", "--rides", "3", "--duration", "5",
                 "--noise-scales", "1", "--json", str(out), "--workers", "1", "--quiet"])
    assert code == 0
    data = json.loads(out.read_text())
    assert [m["maneuver"] for m in data["maneuvers"]] == ["constant_speed", "deceleration"]
    for m in data["maneuvers"]:
        assert math.isfinite(m["h_sd"]) and math.isfinite(m["h_sd_fisher"]) and m["h_sd"] > 0
        assert set(m["recordings_for"]) == {"0.05", "0.02", "0.01"}
    assert "Record deceleration" in capsys.readouterr().out


@pytest.mark.parametrize("argv, message", [
    (["--maneuvers", "constant_speed,wheelie"], "--maneuvers: unknown wheelie; valid: constant_speed"),
    (["--rides", "2"], "argument --rides: expected an integer in [3, 10000], got 2"),
    (["--noise-scales", "0.5,2"], "--noise-scales must lie in (0, 100] and include 1"),
    (["--noise-scales", "1,1e300"], "--noise-scales must lie in (0, 100] and include 1"),
    (["--targets", "1e300"], "--targets must be standard deviations in (0, 1] m"),
    (["--targets", "x"], "--targets expects comma-separated numbers, got 'x'"),
])
def test_cli_design_bad_input_is_one_line_exit_2(argv, message, capsys, tmp_path):
    try:
        code = main(["design", "--json", str(tmp_path / "d.json"), *argv])
    except SystemExit as exc:           # refused by argparse (a bounded option)
        code = exc.code
    assert code == 2
    err = capsys.readouterr().err
    assert message in err and "Traceback" not in err
    assert not (tmp_path / "d.json").exists()


def test_cli_design_with_effects_extends_the_contract_json(tmp_path, capsys):
    out, png = tmp_path / "d.json", tmp_path / "figs" / "design_effects.png"
    code = main(["design", "--maneuvers", "stop_and_go", "--rides", "3", "--duration", "6",
                 "--noise-scales", "1", "--effect", "aerodynamic_drag", "--effect", "wheel_bearing_friction",
                 "--effect-rides", "3", "--json", str(out), "--report", str(tmp_path / "figs"),
                 "--workers", "1", "--quiet"])
    assert code == 0
    data = json.loads(out.read_text())
    row = data["maneuvers"][0]
    assert math.isfinite(row["h_sd"])                                    # CONTRACT's fields stay
    drag = row["effects"]["aerodynamic_drag"]
    assert drag["rides"] == 3 and 0 < drag["sd"] < 0.3 and 0 < drag["sd_cov"] < 0.3
    assert set(drag["recordings_for"]) == {"0.25", "0.1"} and drag["recordings_to_detect"] >= 1
    assert "wheel_bearing_friction" not in row["effects"]                 # cancels without M_d
    assert not data["effects_design"]["effects"]["wheel_bearing_friction"]["visible"]
    assert png.stat().st_size > 10_000
    assert "aerodynamic_drag" in capsys.readouterr().out


def test_cli_design_refuses_unknown_effects_before_running(tmp_path, capsys):
    assert main(["design", "--effect", "aerodynamic_drag", "--effect", "gremlins", "--json", str(tmp_path / "d.json")]) == 2
    err = capsys.readouterr().err
    assert "--effect: unknown gremlins; valid: all, rolling_resistance" in err and "Traceback" not in err
    assert not (tmp_path / "d.json").exists()

"""``euc-sim ride`` and :func:`euc_sim.analyse_ride` build one request (:mod:`euc_sim.rides.request`):
a bad one is refused by both with the same line, and each option's rule is stated once."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest
from ridesynth import synth_log

import euc_sim
from euc_sim.cli.app import main
from euc_sim.rides import request

ROOT = Path(__file__).resolve().parents[2]

#: (command-line options, the API's keywords) of one bad request each.
BAD = {
    "n_boot below its bound": (["--n-boot", "5"], {"n_boot": 5}),
    "unknown domain": (["--domain", "speed"], {"domain": "speed"}),
    "rider weight beyond its bound": (["--rider-weight", "500"], {"rider_weight": 500.0}),
    "mass below its bound": (["--mass", "10"], {"mass": 10.0}),
    "efficiency beyond its bound": (["--efficiency", "1.5"], {"efficiency": 1.5}),
    "second rider without a second ride": (["--rider-weight", "70", "--rider-weight", "80"],
                                           {"rider_weight": (70.0, 80.0)}),
    "calibration without the replay": (["--calibrate-rider", "--no-simulate"],
                                       {"calibrate_rider": True, "simulate": False}),
    "unknown wheel": (["--wheel", "unicorn"], {"wheel": "unicorn"}),
}


def _cli_line(argv, capsys) -> str:
    assert main(["ride", *map(str, argv)]) == 2
    err = [ln for ln in capsys.readouterr().err.splitlines() if ln.strip()]
    assert len(err) == 1, err
    return err[0].removeprefix("euc-sim ride: error: ")


@pytest.mark.parametrize("case", sorted(BAD))
def test_the_cli_and_the_api_refuse_a_bad_request_with_the_same_line(case, tmp_path, capsys):
    options, keywords = BAD[case]
    log = tmp_path / "absent.csv"           # every option is checked before the log is read
    line = _cli_line([log, *options, "--json", tmp_path / "o.json"], capsys)
    with pytest.raises(ValueError) as exc:
        euc_sim.analyse_ride(log, **keywords)
    assert str(exc.value) == line
    assert not (tmp_path / "o.json").exists()


def test_a_missing_log_is_refused_with_the_same_line(tmp_path, capsys):
    line = _cli_line([tmp_path / "absent.csv"], capsys)
    with pytest.raises(OSError) as exc:
        euc_sim.analyse_ride(tmp_path / "absent.csv")
    assert str(exc.value) == line and "absent.csv" in line


def test_the_n_boot_rule_is_stated_once_and_both_faces_follow_it(tmp_path, capsys, monkeypatch):
    """MIN_BOOT is set in the request module alone and no face compares n_boot with a number;
    changing the bound changes what the commands, their --help and the API accept."""
    setters, compares = [], []
    for path in sorted((ROOT / "euc_sim").rglob("*.py")):
        if "identification" in path.parts:             # identify's own replicates, another rule
            continue
        faces = path.name in ("ride.py", "pipeline.py") or "api" in path.parts
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.Assign) and any(getattr(t, "id", None) == "MIN_BOOT" for t in node.targets):
                setters.append(path.name)
            if faces and isinstance(node, ast.Compare) and "n_boot " in ast.unparse(node):
                compares.append(f"{path.name}:{node.lineno}")
    assert setters == ["request.py"] and compares == []

    monkeypatch.setitem(request.BOUNDS, "n_boot", (30, 100_000, True, ""))
    log = synth_log(tmp_path / "fit.csv", seed=3)
    line = _cli_line([log, "--n-boot", "20", "--no-simulate"], capsys)
    assert line == "--n-boot: expected an integer in [30, 100000], got 20"
    with pytest.raises(ValueError, match=r"^--n-boot: expected an integer in \[30, 100000\], got 20$"):
        euc_sim.analyse_ride(log, n_boot=20)
    for command in ("ride", "rides"):       # the logbook's replicates take the same bound
        with pytest.raises(SystemExit):
            main([command, "--help"])
        assert "range [30, 100000]" in " ".join(capsys.readouterr().out.split()), command


def test_the_request_holds_the_rides_read_once_and_the_checked_options(tmp_path):
    fit, test = synth_log(tmp_path / "fit.csv", seed=3), synth_log(tmp_path / "test.csv", seed=4)
    req = request.ride_request(fit, test, wheel_mass=20, mass=95, rider_weight=[70, 80], n_boot=12)
    assert (req.log.name, req.compare.name, req.spec.wheel_mass) == ("fit.csv", "test.csv", 20.0)
    assert req.assumptions.source_of("total_mass") == "--mass" and req.assumptions.total_mass == 95
    assert (req.rider_weight, req.compare_rider_weight, req.n_boot) == (70.0, 80.0, 12)
    assert req.simulate                                 # with a compared ride the replay runs unless refused
    assert not request.ride_request(fit, test, simulate=False).simulate
    one = request.ride_request(fit, test, rider_weight=75)
    assert one.rider_weight == one.compare_rider_weight == 75.0
    with pytest.raises(AttributeError):
        req.n_boot = 5                                  # frozen

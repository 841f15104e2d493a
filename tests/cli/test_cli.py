"""The command line: exit codes and one-line messages for bad input."""

import json

import pytest

from euc_sim.cli import main
def test_crosscheck_json(tmp_path, capsys):
    out = tmp_path / "cc.json"
    code = main(["crosscheck", "--samples", "30", "--json", str(out)])
    assert code == 0
    data = json.loads(out.read_text())
    assert data["ok"] is True
    names = {c["name"] for c in data["checks"]}
    assert {"mass_matrix_eq6", "bias_forces_eq7_eq8", "inverse_dynamics", "energy_drift"} <= names
    for c in data["checks"]:
        assert set(c) >= {"name", "value", "bound", "ok"}
    assert "all bounds hold" in capsys.readouterr().out


@pytest.mark.parametrize("argv, message", [
    (["crosscheck", "--param", "m=-3"], r"parameter 'm' \(rider's mass\) must be positive, got -3.0 kg"),
    (["crosscheck", "--param", "h=nan"], r"parameter 'h' .* must be finite"),
    (["crosscheck", "--param", "h"], r"--param expects NAME=VALUE"),
    (["crosscheck", "--mjcf", "/no/such/model.xml"], r"MJCF file not found: /no/such/model.xml"),
    (["crosscheck", "--samples", "0"], r"argument --samples: expected an integer in \[1, 100000\], got 0"),
    (["dynamics", "--q", "0,nan,0"], r"--q \(x, gamma, phi\) must be finite"),
    (["dynamics", "--q", "0,0"], r"--q \(x, gamma, phi\) expects 3 comma-separated numbers"),
    (["dynamics", "--q", "0,0,0", "--torques", "1,inf"], r"--torques .* must be finite"),
])
def test_bad_input_is_one_line_exit_2(argv, message, capsys):
    try:
        code = main(argv)
    except SystemExit as exc:           # refused by argparse (a bounded option)
        code = exc.code
    assert code == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "Traceback" not in err
    import re
    assert re.search(message, err), err


def test_unwritable_output_fails_before_work(tmp_path, capsys):
    blocker = tmp_path / "file"
    blocker.write_text("x")
    assert main(["crosscheck", "--json", str(blocker / "out.json")]) == 2
    assert "cannot write" in capsys.readouterr().err
    assert not (blocker / "out.json").exists()


def test_dynamics_command(tmp_path, capsys):
    out = tmp_path / "d.json"
    assert main(["dynamics", "--q", "0,0.02,0.05", "--qd", "1,0,0", "--torques", "5,20",
                 "--json", str(out)]) == 0
    data = json.loads(out.read_text())
    assert data["M_d1"] == pytest.approx(5.0, abs=1e-9)
    assert data["M_d2"] == pytest.approx(5.0, abs=1e-9)
    assert data["generalized_force_mujoco_inverse"] == pytest.approx([25.0, 15.0, -20.0], abs=1e-9)

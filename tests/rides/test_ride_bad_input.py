"""Bad ride input at the command line beyond tests/rides/drive/test_drivetrain.py's four cases: a
current column that is empty or all zero, and a binary compare log: one line naming the
file and the column, exit 2, no output written."""

from __future__ import annotations

import pytest
from drivesynth import drive_log

from euc_sim.cli.app import main


def _rows(cell: str) -> str:
    return "datetime,speed,voltage,current\n" + "".join(
        f"2025-07-01T10:{k // 60:02d}:{k % 60:02d}.000+0200,{10 + k % 5},84,{cell}\n"
        for k in range(200))


@pytest.mark.parametrize("case", ["empty_current", "zero_current", "binary_compare"])
def test_one_line_naming_file_and_column(tmp_path, capsys, case):
    out = tmp_path / "out.json"
    if case == "binary_compare":
        log = drive_log(tmp_path / "ok.csv", seed=1, duration=60.0)
        other = tmp_path / "other.csv"
        other.write_bytes(bytes(range(256)) * 8)
        argv = ["ride", str(log), "--compare", str(other)]
        want = "other.csv: not a UTF-8 text CSV file"
    else:
        log = tmp_path / f"{case}.csv"
        log.write_text(_rows("" if case == "empty_current" else "0"))
        argv = ["ride", str(log)]
        want = f"{case}.csv: column 'current': absent, empty or all zero"
    code = main(argv + ["--no-simulate", "--n-boot", "10", "--json", str(out)])
    err = [ln for ln in capsys.readouterr().err.splitlines()
           if ln.strip() and not ln.startswith("ride: ")]
    assert code == 2
    assert len(err) == 1 and want in err[0], err
    assert not out.exists() and list(tmp_path.glob("*.tmp*")) == []

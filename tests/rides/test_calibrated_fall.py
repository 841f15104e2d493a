"""scripts/calibrated_fall.py: its pure helpers and its bad-input exits (the window itself is a study)."""

import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
if str(ROOT / "scripts") not in sys.path:
    sys.path.insert(0, str(ROOT / "scripts"))

import calibrated_fall  # noqa: E402


def test_distance_ahead_integrates_the_speed_error():
    t = np.linspace(0.0, 10.0, 1001)
    d = calibrated_fall.distance_ahead(t, 2.0 + 0.5 * t, np.full(t.size, 2.0))   # ẋ − v_ref = 0.5 t
    np.testing.assert_allclose(d, 0.25 * t ** 2, atol=1e-9)
    assert calibrated_fall.distance_ahead([0.0], [1.0], [0.0]).tolist() == [0.0]


def test_missing_input_exits_2(tmp_path, capsys):
    assert calibrated_fall.main([str(tmp_path), str(tmp_path / "h.csv"), str(tmp_path / "s.csv")]) == 2
    err = capsys.readouterr().err
    assert "ride.json" in err and len(err.strip().splitlines()) == 1


def test_unknown_variant_exits_2(tmp_path, capsys):
    for name in ("ride.json", "h.csv", "s.csv"):
        (tmp_path / name).write_text("{}")
    assert calibrated_fall.main([str(tmp_path), str(tmp_path / "h.csv"), str(tmp_path / "s.csv")]) == 2
    assert len(capsys.readouterr().err.strip().splitlines()) == 1

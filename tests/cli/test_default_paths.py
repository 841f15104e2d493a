"""Every command's default path, end to end through ``euc_sim.cli.main``.

A planar and a 3-D recording are simulated with ``simulate``'s defaults (a shorter
duration), and ``torques``, ``identify``, ``diagnose`` (re-simulation and calibration
included) and ``render`` run on each with their defaults; outputs are read back in
CONTRACT's form.  The small commands follow.  ``stability`` on its defaults is
``tests/controllers/test_controllers.py::test_stability_cli_writes_json``; ``demo`` is
``tests/cli/test_demo.py``; ``ride`` on each log layout is ``tests/rides/test_ride_layouts.py``.
"""

from __future__ import annotations

import json

import numpy as np
import pandas as pd
import pytest

from euc_sim.cli import main

DURATION = "6"              # s: simulate's default is 15; every step below scales with it
MODELS = ("planar", "3d")
NO_NATIVE = "native closed loop unavailable"


def run(argv, capsys):
    """Run the CLI in-process; (exit code, stdout, stderr)."""
    code = main([str(a) for a in argv])
    out = capsys.readouterr()
    return code, out.out, out.err


@pytest.fixture(scope="module")
def recordings(tmp_path_factory):
    """``simulate --out`` (its default maneuver) and ``simulate --model 3d --out``."""
    import contextlib
    import io

    d = tmp_path_factory.mktemp("defaults")
    made = {}
    for model in MODELS:
        out = d / f"{model}.csv"
        err = io.StringIO()
        with contextlib.redirect_stderr(err):
            code = main(["simulate", "--out", str(out), "--duration", DURATION,
                         *(["--model", "3d"] if model == "3d" else [])])
        assert code == 0, err.getvalue()
        made[model] = (out, err.getvalue())
    return made


@pytest.mark.parametrize("model", MODELS)
def test_simulate_defaults(recordings, model):
    path, err = recordings[model]
    assert NO_NATIVE not in err                     # the default closed loop is the compiled one
    rec = pd.read_csv(path)
    assert len(rec) == 6 * 120 + 1 and np.all(np.diff(rec["t"]) > 0)
    need = {"t", "x", "gamma", "phi", "M_d", "M_h"} if model == "planar" else \
        {"t", "psi", "theta", "gamma", "C_X", "C_Y", "C_Z", "E_X", "G_X", "M_d", "M_h"}
    assert need <= set(rec.columns)
    assert np.isfinite(rec[sorted(need)].to_numpy()).all()
    meta = json.loads(path.with_suffix(".json").read_text())
    assert meta["maneuver"] == ("constant_speed" if model == "planar" else "figure_eight")
    assert isinstance(meta["params"], dict)


@pytest.mark.parametrize("model", MODELS)
def test_torques_defaults(recordings, model, tmp_path, capsys):
    path, _ = recordings[model]
    out = tmp_path / "T.csv"
    code, _, err = run(["torques", path, "--out", out], capsys)
    assert code == 0, err
    table = pd.read_csv(out)
    assert {"t", "M_d1", "M_d2", "M_h", "M_d1_2dof", "M_d2_2dof"} <= set(table.columns)
    assert len(table) > 0.9 * len(pd.read_csv(path))
    assert np.isfinite(table[["M_d1", "M_d2", "M_h"]].to_numpy()).all()


@pytest.mark.parametrize("model", MODELS)
def test_identify_defaults(recordings, model, tmp_path, capsys):
    path, _ = recordings[model]
    out = tmp_path / "id.json"
    code, printed, err = run(["identify", path, "--json", out], capsys)
    assert code == 0, err
    res = json.loads(out.read_text())
    assert res["recordings"] == [path.name] or res["recordings"] == [str(path)]
    for name in ("3dof", "2dof"):
        m = res["models"][name]
        assert {"h", "h_ci95", "rmse", "identifiable"} <= set(m)
        lo, hi = m["h_ci95"]
        assert lo <= m["h"] <= hi and m["rmse"] >= 0
    assert len(res["per_recording"]) == 1 and "h" in printed


@pytest.mark.parametrize("model", MODELS)
def test_diagnose_defaults(recordings, model, tmp_path, capsys):
    """Re-simulation and calibration on, as a user runs it (the 3-D case is issue 31's first item)."""
    path, _ = recordings[model]
    out, rep = tmp_path / "dg.json", tmp_path / "rep"
    code, _, err = run(["diagnose", path, "--json", out, "--report", rep], capsys)
    assert code == 0, err
    assert NO_NATIVE not in err
    res = json.loads(out.read_text())
    assert res["recording"] == path.name
    assert res["nominal_rmse"] > 0 and isinstance(res["unexplained"], bool)
    for e in res["effects"]:
        assert {"name", "estimate", "unit", "ci95", "rmse_after", "aliases", "evidence"} <= set(e)
    for a, b in res["windows"]:
        assert 0 <= a < b <= float(DURATION) + 1e-9
    sim = res["resimulation"]
    assert sim["done"] is True
    for run_ in ("nominal", "augmented"):
        assert all(np.isfinite(v) and v >= 0 for v in sim[run_].values())
    page = (rep / "index.md").read_text()
    assert path.name in page
    for figure in ("residual.png", "resimulation.png"):
        assert (rep / figure).stat().st_size > 10_000


def _gl_available() -> bool:
    import mujoco

    from euc_sim.model.spatial import load_spatial_model
    try:
        mujoco.Renderer(load_spatial_model(), 32, 32).close()
    except Exception:
        return False
    return True


@pytest.mark.parametrize("model", MODELS)
def test_render_defaults(recordings, model, tmp_path, capsys):
    """An .mp4 at the default 30 frames/s and 640 x 480, of the recording's first 0.1 s
    (software OpenGL takes about a second a frame)."""
    if not _gl_available():
        pytest.skip("no OpenGL backend (MUJOCO_GL=egl needs libegl1 + libegl-mesa0)")
    import imageio.v3 as iio

    path, _ = recordings[model]
    short = tmp_path / "short.csv"
    rec = pd.read_csv(path)
    rec[rec["t"] <= 0.1 + 1e-9].to_csv(short, index=False)
    out = tmp_path / "ride.mp4"
    code, _, err = run(["render", short, "--out", out], capsys)
    assert code == 0, err
    video = iio.imread(out)
    assert video.shape == (3, 480, 640, 3) and video.std() > 5
    assert sorted(p.name for p in tmp_path.iterdir()) == ["ride.mp4", "short.csv"]


# --- the small commands ------------------------------------------------------------------
def test_dynamics_defaults(tmp_path, capsys):
    """Only the required --q: zero velocities and torques."""
    out = tmp_path / "d.json"
    code, printed, err = run(["dynamics", "--q", "0,0.02,0.05", "--json", out], capsys)
    assert code == 0, err
    data = json.loads(out.read_text())
    assert data["M_d"] == 0 and data["M_h"] == 0 and data["qd"] == [0, 0, 0]
    assert np.allclose(data["generalized_force_mujoco_inverse"], data["generalized_force_eq8"],
                       atol=1e-8)
    assert "q̈" in printed


def test_crosscheck_defaults(tmp_path, capsys):
    """The built-in four parameter sets at 2,500 random states each."""
    out = tmp_path / "cc.json"
    code, printed, err = run(["crosscheck", "--json", out], capsys)
    assert code == 0, err
    data = json.loads(out.read_text())
    assert data["ok"] is True and len(data["checks"]) >= 4
    for c in data["checks"]:
        assert {"name", "value", "bound", "ok"} <= set(c) and c["value"] <= c["bound"]
    assert "all bounds hold" in printed


def test_design_defaults_on_the_process_pool(tmp_path, capsys):
    """Default maneuvers, noise scales, targets and workers (a process per core); the fewest
    rides and the shortest recordings the command accepts."""
    out = tmp_path / "d.json"
    code, _, err = run(["design", "--rides", "3", "--duration", "5", "--json", out], capsys)
    assert code == 0, err
    data = json.loads(out.read_text())
    assert [m["maneuver"] for m in data["maneuvers"]] == ["constant_speed", "deceleration", "stop_and_go"]
    for m in data["maneuvers"]:
        assert m["h_sd"] > 0 and m["h_sd_fisher"] > 0 and m["fell"] == 0
        assert [b["noise_scale"] for b in m["by_noise"]] == [0.5, 1.0, 2.0]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["d.json"]

"""``euc-sim simulate --model 3d`` and ``euc-sim render``."""

import json

import pandas as pd
import pytest

from euc_sim.cli.app import main


@pytest.fixture(scope="module")
def eight(tmp_path_factory):
    out = tmp_path_factory.mktemp("s3") / "eight.csv"
    assert main(["simulate", "--model", "3d", "--maneuver", "figure_eight", "--duration", "3",
                 "--seed", "2", "--out", str(out)]) == 0
    return out


def test_simulate_3d_writes_a_mocap_recording(eight):
    rec = pd.read_csv(eight)
    assert {"psi", "theta", "gamma", "C_X", "E_X", "G_X", "M_d", "M_h"} <= set(rec.columns)
    assert "phi" not in rec.columns and len(rec) == 361
    meta = json.loads(eight.with_suffix(".json").read_text())
    truth = json.loads(eight.with_name("eight.truth.json").read_text())
    assert meta["maneuver"] == "figure_eight" and "h" not in meta["params"]
    assert truth["model"] == "3d" and truth["path_error"]["max_m"] < 1.0


def test_section_2_runs_on_a_3d_recording(eight, tmp_path, capsys):
    out = tmp_path / "id.json"
    assert main(["identify", str(eight), "--json", str(out), "--n-boot", "20"]) == 0
    res = json.loads(out.read_text())
    rider = res["per_recording"][0]["rider"]
    on_bound = min(abs(rider["delay"] - b) for b in rider["search"]) < 1e-9
    printed = capsys.readouterr().out
    # issue 19, item 3: a rider delay on the search's end is said, in print and in the JSON
    assert on_bound == ("per_recording[0].rider.delay" in res["at_bound"])
    assert on_bound == ("rider delay" in printed and "AT THE SEARCH BOUND" in printed)


def test_simulate_3d_bad_input_is_one_line(tmp_path, capsys):
    assert main(["simulate", "--model", "3d", "--maneuver", "deceleration",
                 "--out", str(tmp_path / "a.csv")]) == 2
    assert "--maneuver must be one of" in capsys.readouterr().err
    assert main(["simulate", "--model", "4d", "--out", str(tmp_path / "a.csv")]) == 2
    assert "--model" in capsys.readouterr().err
    assert not list(tmp_path.iterdir())


def _gl_available() -> bool:
    import mujoco

    from euc_sim.model.spatial import load_spatial_model
    try:
        mujoco.Renderer(load_spatial_model(), 32, 32).close()
    except Exception:
        return False
    return True


def test_render_a_frame_a_gif_and_an_mp4(eight, tmp_path, capsys):
    """Each format the README names, read back; the mp4 of a 3-D ride has its frames (issue 19)."""
    if not _gl_available():
        pytest.skip("no OpenGL backend (MUJOCO_GL=egl needs libegl1 + libegl-mesa0)")
    import imageio.v3 as iio

    png = tmp_path / "f.png"
    assert main(["render", str(eight), "--out", str(png), "--width", "96", "--height", "64"]) == 0
    frame = iio.imread(png)
    assert frame.shape == (64, 96, 3) and frame.std() > 5          # a picture, not a blank
    gif = tmp_path / "r.gif"
    assert main(["render", str(eight), "--out", str(gif), "--fps", "4", "--width", "64",
                 "--height", "48"]) == 0
    assert iio.imread(gif).shape[0] == 12                          # 3 s at 4 frames/s
    capsys.readouterr()
    mp4 = tmp_path / "ride.mp4"
    assert main(["render", str(eight), "--out", str(mp4), "--fps", "4", "--width", "64",
                 "--height", "48"]) == 0
    err = capsys.readouterr().err
    assert "12/12" in err and "frame" in err                       # progress on stderr
    video = iio.imread(mp4)                                        # imageio-ffmpeg decodes it
    assert video.shape == (12, 48, 64, 3) and video.std() > 5
    assert sorted(p.name for p in tmp_path.iterdir()) == ["f.png", "r.gif", "ride.mp4"]


def test_render_progress_can_be_switched_off(eight, tmp_path, capsys):
    if not _gl_available():
        pytest.skip("no OpenGL backend (MUJOCO_GL=egl needs libegl1 + libegl-mesa0)")
    assert main(["render", str(eight), "--out", str(tmp_path / "r.gif"), "--fps", "2", "--width", "32",
                 "--height", "32", "--quiet"]) == 0
    assert capsys.readouterr().err.splitlines() == [f"render: wrote {tmp_path / 'r.gif'} (6 frames)"]


def test_an_encoder_failure_is_one_line_and_leaves_nothing(eight, tmp_path, capsys, monkeypatch):
    """ffmpeg dying (a broken pipe) names the file; no temporary file stays behind."""
    if not _gl_available():
        pytest.skip("no OpenGL backend (MUJOCO_GL=egl needs libegl1 + libegl-mesa0)")
    import imageio.v3 as iio

    def broken(path, *a, **k):
        from pathlib import Path
        Path(path).write_bytes(b"half")
        raise BrokenPipeError(32, "Broken pipe")

    monkeypatch.setattr(iio, "imwrite", broken)
    out = tmp_path / "ride.mp4"
    assert main(["render", str(eight), "--out", str(out), "--fps", "2", "--width", "32",
                 "--height", "32", "--quiet"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and str(out) in err[0] and "encoder failed" in err[0]
    assert list(tmp_path.iterdir()) == []


def test_render_bad_input_is_one_line(eight, tmp_path, capsys):
    assert main(["render", str(tmp_path / "missing.csv"), "--out", str(tmp_path / "a.mp4")]) == 2
    assert "no such file" in capsys.readouterr().err
    bad = tmp_path / "bad.csv"
    pd.DataFrame({"t": [0.0, 0.1], "psi": [0.0, 0.0]}).to_csv(bad, index=False)
    assert main(["render", str(bad), "--out", str(tmp_path / "a.gif")]) == 2
    assert "column 'theta' missing" in capsys.readouterr().err
    assert main(["render", str(eight), "--out", str(tmp_path / "a.avi")]) == 2
    assert not (tmp_path / "a.gif").exists()

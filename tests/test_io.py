import json
import math

import numpy as np
import pytest

from euc_sim.io import atomic_write, check_writable, is_temporary, to_jsonable, write_json


def test_atomic_write_leaves_nothing_on_failure(tmp_path):
    target = tmp_path / "out.csv"

    def boom(path):
        path.write_text("half")
        raise RuntimeError("interrupted")

    with pytest.raises(RuntimeError):
        atomic_write(target, boom)
    assert not target.exists()
    assert list(tmp_path.iterdir()) == []


def test_the_temporary_name_keeps_the_extension(tmp_path):
    """ffmpeg and matplotlib choose their format from the extension (issue 19, item 2)."""
    seen = []
    atomic_write(tmp_path / "ride.mp4", lambda p: (seen.append(p), p.write_bytes(b"x")))
    (tmp,) = seen
    assert tmp.parent == tmp_path and tmp.suffix == ".mp4" and tmp.name.startswith(".ride.")
    assert is_temporary(tmp) and not is_temporary(tmp_path / "ride.mp4") and not tmp.exists()


def test_recording_temporaries_keep_their_extensions(tmp_path, monkeypatch):
    import pandas as pd

    import euc_sim.io as io

    made = []
    real = io.temporary_beside
    monkeypatch.setattr(io, "temporary_beside", lambda p: made.append(real(p)) or made[-1])
    io.write_recording(pd.DataFrame({"t": [0.0, 1.0]}), tmp_path / "r.parquet", {"source": "t"}, {"x": 1})
    assert sorted(p.suffix for p in made) == [".json", ".json", ".parquet"]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["r.json", "r.parquet", "r.truth.json"]


def test_atomic_write_replaces_and_creates_folders(tmp_path):
    target = tmp_path / "a" / "b" / "out.json"
    write_json(target, {"x": np.float64(1.5), "v": np.arange(3), "bad": math.nan})
    assert json.loads(target.read_text()) == {"x": 1.5, "v": [0, 1, 2], "bad": None}
    write_json(target, {"x": 2})
    assert json.loads(target.read_text()) == {"x": 2}


def test_check_writable_names_the_path(tmp_path):
    (tmp_path / "f").write_text("")
    with pytest.raises(OSError, match=r"cannot write .*f/x.json"):
        check_writable(tmp_path / "f" / "x.json")
    with pytest.raises(IsADirectoryError, match="is a directory"):
        check_writable(tmp_path)


def test_to_jsonable():
    assert to_jsonable((np.int64(2), [np.inf])) == [2, [None]]


def test_written_files_get_the_usual_mode(tmp_path):
    import os
    import stat
    target = write_json(tmp_path / "m.json", {})
    mask = os.umask(0)
    os.umask(mask)
    assert stat.S_IMODE(target.stat().st_mode) == 0o666 & ~mask


def test_recordings_get_the_usual_mode_too(tmp_path):
    import os
    import stat

    import pandas as pd

    from euc_sim.io import write_recording
    path = write_recording(pd.DataFrame({"t": [0.0, 1.0], "x": [0.0, 1.0]}), tmp_path / "r.csv",
                           {"params": {}}, {"effects": {}})
    mask = os.umask(0)
    os.umask(mask)
    for f in (path, tmp_path / "r.json", tmp_path / "r.truth.json"):
        assert stat.S_IMODE(f.stat().st_mode) == 0o666 & ~mask, f

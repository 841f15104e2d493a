"""The soak (scripts/soak.py) keeps working: a tiny soak, and its sorting of outcomes."""

from __future__ import annotations

from pathlib import Path

import pytest


@pytest.fixture(scope="module")
def soak():
    import soak as module

    return module


def test_sorting_of_outcomes(soak):
    run = soak.Run("malformed", ["torques", "a.csv", "--out", "T.csv"])
    run.code = 2
    assert soak.classify(run, "euc-sim torques: error: a.csv: column 'x' missing\n")[0] == "refused"
    assert soak.classify(run, "torques: 1/2 reading ...\neuc-sim torques: error: bad\n")[0] == "refused"
    assert soak.classify(run, "euc-sim torques: error: bad\nmore\n")[0] == "crash"
    assert soak.classify(run, "Traceback (most recent call last):\n  ...\nKeyError: 'x'\n")[0] == "crash"
    run.code = 1
    assert soak.classify(run, "euc-sim torques: internal error: KeyError: 'x'; the traceback is in "
                              "/tmp/e.txt\n")[0] == "internal"
    assert soak.classify(run, "NOT OK\n")[0] == "crash"
    run.code = -11
    assert soak.classify(run, "")[0] == "crash"
    run.code = None
    assert soak.classify(run, "")[0] == "crash"
    run.code = 0
    assert soak.classify(run, "torques: wrote T.csv\n")[0] == "finished"


def test_leftovers_are_found(soak, tmp_path):
    work, tmp = tmp_path / "work", tmp_path / "tmp"
    work.mkdir()
    tmp.mkdir()
    (work / "in.csv").write_text("t\n")
    before = {p.relative_to(work): p.stat().st_mtime_ns for p in work.rglob("*")}
    run = soak.Run("valid", ["torques"], outputs=["T.csv"])
    run.outcome = "finished"
    (work / "T.csv").write_text("x\n")
    assert soak.leftovers(run, work, tmp, before) == []
    (work / ".T.tmp-1234.csv").write_text("")
    (work / "MUJOCO_LOG.TXT").write_text("")
    (tmp / "stray").write_text("")
    assert soak.leftovers(run, work, tmp, before) == [".T.tmp-1234.csv", "MUJOCO_LOG.TXT", "TMPDIR/stray"]
    run.outcome = "refused"                      # after a refusal, not even the named outputs
    assert "T.csv" in soak.leftovers(run, work, tmp, before)


def test_a_tiny_soak_is_clean(soak):
    res = soak.soak(3, 3, seed=0, workers=2, progress=False)
    counts = res["counts"]["all"]
    assert sum(counts[k] for k in ("finished", "refused", "internal", "crash")) == 6
    assert counts["internal"] == counts["crash"] == counts["leftovers"] == 0, res["not_clean"]
    assert res["counts"]["valid"]["finished"] == 3, res["not_clean"]


def test_hostile_names_and_special_files_are_made(soak, tmp_path):
    import os
    import random
    import stat

    pool = tmp_path / "pool"
    pool.mkdir()
    for name in ("decel.csv", "decel.json", "stopgo.csv", "LOG.csv"):
        (pool / name).write_text(name)
    for i, (argv, inputs, edit) in enumerate(soak.SPECIAL):
        work = tmp_path / f"run-{i}" / "work"
        work.mkdir(parents=True)
        for name in inputs:
            for p in pool.glob(name.split(".")[0] + ".*"):
                (work / p.name).write_bytes(p.read_bytes())
        soak.spoil(work, edit)
        for name in edit.get("fifo", []):
            assert stat.S_ISFIFO(os.lstat(work / name).st_mode)
        for name, pool_name in edit.get("outside", {}).items():
            target = Path(os.readlink(work / name))
            assert work not in target.parents and target.read_text() == pool_name
        for src, name in edit.get("hard", {}).items():
            assert os.path.samefile(work / src, work / name)
    kinds = {soak.malformed_run(random.Random(s)).edit.get("rename") is not None for s in range(200)}
    assert kinds == {True, False}
    run = next(r for r in (soak._hostile_name(random.Random(s)) for s in range(200))
               if r.edit.get("rename") and "\n" in next(iter(r.edit["rename"].values())))
    work = tmp_path / "renamed" / "work"
    work.mkdir(parents=True)
    for name in ("decel.csv", "decel.json", "stopgo.csv", "LOG.csv"):
        (work / name).write_text(name)
    soak.spoil(work, run.edit)
    (old, new), = run.edit["rename"].items()
    assert (work / new).read_text() == old and not (work / old).exists()
    if old == "decel.csv":                             # its sidecar follows it
        assert (work / new.replace(".csv", ".json")).read_text() == "decel.json"

"""The run engine: serial, process pool and Dask give the same bytes; failures by name;
interrupted runs stop their workers and leave no temporary files."""

from __future__ import annotations

import hashlib
import json
import os
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import pytest

from euc_sim.io import is_temporary
from euc_sim.simulation.runner import check_backend, run_tasks

ROOT = Path(__file__).resolve().parents[2]


def _square_or_fail(x):
    if x == 3:
        raise ValueError("three is a bad number\nsecond line")
    if x == 5:
        os._exit(9)                       # the worker process dies
    return x * x


def _digests(folder: Path) -> dict:
    return {p.name: hashlib.sha256(p.read_bytes()).hexdigest()
            for p in sorted(folder.iterdir()) if p.name != "dataset.json"}


def test_failures_are_named_and_the_rest_finish_in_a_pool():
    tasks = [(f"t{i}", i) for i in range(7)]
    rep = run_tasks(_square_or_fail, tasks, workers=2, progress=False)
    assert rep.results == {f"t{i}": i * i for i in (0, 1, 2, 4, 6)}
    assert rep.failed["t3"] == "ValueError: three is a bad number"
    assert rep.failed["t5"].startswith("worker died")
    assert list(rep.failed) == ["t3", "t5"]
    assert "t5" in rep.table() and "t3" in rep.table()


def test_serial_run_reports_a_failure_by_name():
    rep = run_tasks(_square_or_fail, [("a", 2), ("b", 3)], workers=1, progress=False)
    assert rep.results == {"a": 4} and rep.failed == {"b": "ValueError: three is a bad number"}
    assert rep.backend == "serial"


def test_bad_backend_options_name_the_option():
    with pytest.raises(ValueError, match="--workers must be a positive integer, got 0"):
        check_backend(None, 0)
    with pytest.raises(ValueError, match="--scheduler must be 'local' or a Dask scheduler address"):
        check_backend("nowhere", None)
    with pytest.raises(ValueError, match="task names must be unique"):
        run_tasks(_square_or_fail, [("a", 1), ("a", 2)], workers=1, progress=False)


def test_same_seed_same_bytes_serial_pool_and_dask(tmp_path):
    """A two-worker Dask cluster (in-process workers, reached by its address as a remote
    one would be), a process pool and a serial run write identical recordings."""
    from distributed import LocalCluster

    from euc_sim.simulation.dataset import dataset_plan, run_dataset

    def plan():
        return dataset_plan(seed=4, duration=1.0, counts=(("constant_speed", 2), ("deceleration", 1)))
    run_dataset(tmp_path / "serial", plan(), workers=1, progress=False)
    run_dataset(tmp_path / "pool", plan(), workers=2, progress=False)
    with LocalCluster(n_workers=2, threads_per_worker=1, processes=False, protocol="tcp",
                      dashboard_address=None) as cl:
        rep = run_dataset(tmp_path / "dask", plan(), progress=False, scheduler=cl.scheduler_address)
    assert rep.backend.startswith("dask tcp://") and not rep.failed
    ref = _digests(tmp_path / "serial")
    assert len(ref) == 9
    assert _digests(tmp_path / "pool") == ref
    assert _digests(tmp_path / "dask") == ref


def test_dask_reports_a_fall_by_name_and_finishes_the_rest():
    from distributed import LocalCluster

    with LocalCluster(n_workers=2, threads_per_worker=1, processes=False, protocol="tcp",
                      dashboard_address=None) as cl:
        rep = run_tasks(_square_or_fail, [(f"t{i}", i) for i in range(5)], scheduler=cl.scheduler_address,
                        progress=False)
    assert rep.failed == {"t3": "ValueError: three is a bad number"}
    assert rep.ordered() == [0, 1, 4, 16]


@pytest.mark.parametrize("workers", ["1", "2"])
def test_dataset_fall_is_named_exit_2(tmp_path, capsys, workers):
    """Issue 11: a rider fall inside a parallel dataset broke the pool with a traceback;
    with one worker the run ended without saying which recording fell."""
    from euc_sim.cli.app import main

    out = tmp_path / "d"
    # a 200 kg rider on the steepest grade the catalog allows falls in every recording
    code = main(["dataset", "--out-dir", str(out), "--effect", "road_slope=0.3", "--effect", "rider_mass=200",
                 "--duration", "2",
                 "--workers", workers, "--quiet"])
    err = capsys.readouterr().err
    assert code == 2
    assert "Traceback" not in err
    assert "constant_speed_01  FallError: fall at t = " in err
    manifest = json.loads((out / "dataset.json").read_text())
    assert manifest["recordings"] == [] and len(manifest["failed"]) == 14
    assert not [p for p in out.iterdir() if is_temporary(p)]


def test_dataset_help_describes_out_and_seed(capsys):
    from euc_sim.cli.app import main

    with pytest.raises(SystemExit):
        main(["dataset", "--help"])
    text = " ".join(capsys.readouterr().out.split())
    assert "folder for the recordings" in text and "dataset seed" in text and "--scheduler" in text


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    try:                                    # a zombie is dead
        return Path(f"/proc/{pid}/stat").read_text().split()[2] != "Z"
    except FileNotFoundError:
        return False


def _wait(cond, timeout: float) -> bool:
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        if cond():
            return True
        time.sleep(0.05)
    return cond()


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="PR_SET_PDEATHSIG is Linux")
def test_pool_workers_die_with_a_killed_parent(tmp_path):
    """SIGKILL of the parent: its pool workers follow (they kept running before)."""
    pids = tmp_path / "pids"
    code = textwrap.dedent(f"""
        import os, time
        from euc_sim.simulation.runner import run_tasks
        def work(i):
            with open({str(pids)!r}, "a") as f:
                f.write(f"{{os.getpid()}}\\n")
            time.sleep(60)
        run_tasks(work, [("a", 1), ("b", 2)], workers=2, progress=False)
    """)
    script = tmp_path / "parent.py"
    script.write_text(code)
    parent = subprocess.Popen([sys.executable, str(script)], cwd=ROOT)
    try:
        assert _wait(lambda: pids.exists() and len(pids.read_text().split()) == 2, 30)
        workers = [int(p) for p in pids.read_text().split()]
        parent.kill()
        parent.wait()
        assert _wait(lambda: not any(_alive(p) for p in workers), 10)
    finally:
        parent.kill()


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="process table is Linux")
def test_sigterm_stops_a_dataset_at_once_and_leaves_no_temp_files(tmp_path):
    out = tmp_path / "d"
    proc = subprocess.Popen([sys.executable, "-c", "import sys; from euc_sim.cli import main; sys.exit(main())", "dataset", "--out-dir", str(out),
                             "--duration", "30", "--workers", "2", "--quiet"],
                            cwd=ROOT, stderr=subprocess.PIPE, text=True)
    children = Path(f"/proc/{proc.pid}/task/{proc.pid}/children")
    try:
        assert _wait(lambda: len(children.read_text().split()) >= 2, 60), "the pool never started"
        time.sleep(1.0)                       # the workers are simulating
        workers = [int(p) for p in children.read_text().split()]
        proc.send_signal(signal.SIGTERM)
        proc.wait(timeout=15)
        err = proc.stderr.read()
    finally:
        proc.kill()
    assert proc.returncode == 143, err          # 128 + SIGTERM, as the shell reports it
    assert "interrupted" in err and "Traceback" not in err
    assert _wait(lambda: not any(_alive(p) for p in workers), 10)
    assert not out.exists() or not [p for p in out.iterdir() if is_temporary(p)]


def test_a_local_dask_run_leaves_no_scratch_space_in_the_temp_dir(tmp_path):
    """Issue 19, item 14: the local cluster's dask-scratch-space goes to a folder removed after."""
    env = {**os.environ, "TMPDIR": str(tmp_path), "PYTHONPATH": str(ROOT)}
    code = textwrap.dedent("""
        from euc_sim.simulation.runner import run_tasks
        rep = run_tasks(abs, [("a", -2), ("b", 3)], scheduler="local", workers=1, progress=False)
        assert rep.ordered() == [2, 3], rep
        print("ok")
    """)
    proc = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0 and proc.stdout.strip() == "ok", proc.stderr[-2000:]
    assert list(tmp_path.iterdir()) == []


def test_a_dataset_that_cannot_start_leaves_no_folder_it_made(tmp_path, capsys, monkeypatch):
    """Issue 19, item 14: an unreachable scheduler fails in one line, and the --out folder
    this run created (with its parents) is gone; a folder that was there stays."""
    import euc_sim.simulation.runner as runner
    from euc_sim.cli import main

    def unreachable(*args, **kwargs):
        raise OSError("Timed out trying to connect to tcp://127.0.0.1:1 after 30 s")

    monkeypatch.setattr(runner, "run_tasks", unreachable)
    argv = ["dataset", "--scheduler", "tcp://127.0.0.1:1", "--duration", "1", "--quiet", "--out-dir"]
    assert main(argv + [str(tmp_path / "new" / "set")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "127.0.0.1:1" in err[0]
    assert list(tmp_path.iterdir()) == []
    (tmp_path / "old").mkdir()
    (tmp_path / "old" / "keep.txt").write_text("mine")
    assert main(argv + [str(tmp_path / "old")]) == 2
    assert [p.name for p in (tmp_path / "old").iterdir()] == ["keep.txt"]

"""The on-disk cache of the compiled kernels: only in a folder of this user's that nobody else
can write to, else no cache at all (numba unpickles its index files: whoever writes there runs
code in every simulation)."""

from __future__ import annotations

import os
import pickle
import stat
import subprocess
import sys
from pathlib import Path

import pytest
from numba import config
from numba.core.caching import FunctionCache

from euc_sim.simulation import native_kernels as nk

posix = pytest.mark.skipif(not hasattr(os, "getuid"), reason="owners and modes are POSIX")


def _probe(x):
    return x + 1


class _Planted:
    """A pickle that, when loaded, creates the file ``marker``."""

    def __init__(self, marker):
        self.marker = str(marker)

    def __reduce__(self):
        return open, (self.marker, "w")


def _plant(folder: Path, fn, marker: Path) -> Path:
    """Write a booby-trapped numba index for ``fn`` where numba looks for it in ``folder``."""
    saved, config.CACHE_DIR = config.CACHE_DIR, str(folder)
    try:
        index = Path(FunctionCache(fn)._cache_file._index_path)
    finally:
        config.CACHE_DIR = saved
    index.write_bytes(pickle.dumps(_Planted(marker)))
    return index


def _cache_of(tmp_path, monkeypatch, capsys) -> tuple[str | None, str]:
    """:func:`nk._cache_dir` with ``$XDG_CACHE_HOME`` = ``tmp_path/xdg``: (folder or None, stderr)."""
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "xdg"))
    monkeypatch.setattr(config, "CACHE_DIR", "")
    capsys.readouterr()
    folder = nk._cache_dir()
    return folder, capsys.readouterr().err


def _expected(tmp_path) -> Path:
    return tmp_path / "xdg" / "euc-sim" / "numba" / nk._source_hash()


def _assert_refused(tmp_path, monkeypatch, capsys, named: Path, why: str) -> None:
    """No cache: one warning line naming ``named`` and ``why``; the planted index is never read."""
    marker = tmp_path / "pwned"
    target = _expected(tmp_path)
    _plant(target, _probe, marker)
    folder, err = _cache_of(tmp_path, monkeypatch, capsys)
    assert folder is None
    lines = err.strip().splitlines()
    assert len(lines) == 1 and str(named) in lines[0] and why in lines[0], err
    monkeypatch.setattr(nk, "CACHE_DIR", folder)
    kernel = nk._jit(_probe)
    assert type(kernel._cache).__name__ == "NullCache"           # plain njit: no cache to read
    assert kernel(1) == 2
    assert not marker.exists()


@posix
def test_normal_cache_folders_are_private_and_used(tmp_path, monkeypatch, capsys):
    folder, err = _cache_of(tmp_path, monkeypatch, capsys)
    assert folder == str(_expected(tmp_path)) and err == ""
    for p in (tmp_path / "xdg", tmp_path / "xdg" / "euc-sim", tmp_path / "xdg" / "euc-sim" / "numba", Path(folder)):
        assert stat.S_IMODE(p.lstat().st_mode) == 0o700, p
    monkeypatch.setattr(nk, "CACHE_DIR", folder)
    kernel = nk._jit(_probe)
    assert kernel._cache.cache_path.startswith(folder + os.sep)
    assert kernel(1) == 2
    assert list(Path(folder).rglob("*.nbi"))                    # numba wrote its index there


@posix
@pytest.mark.skipif(not hasattr(os, "geteuid") or os.geteuid() != 0, reason="chown needs root")
def test_a_folder_of_another_user_is_not_used(tmp_path, monkeypatch, capsys):
    target = _expected(tmp_path)
    target.mkdir(parents=True, mode=0o700)
    os.chown(target, 65534, 65534)
    _assert_refused(tmp_path, monkeypatch, capsys, target, "belongs to uid 65534")


@posix
def test_a_world_writable_folder_is_not_used(tmp_path, monkeypatch, capsys):
    shared = tmp_path / "xdg" / "euc-sim"
    _expected(tmp_path).mkdir(parents=True, mode=0o700)
    shared.chmod(0o777)
    _assert_refused(tmp_path, monkeypatch, capsys, shared, "mode 777")


@posix
def test_a_symbolic_link_in_place_of_the_folder_is_not_used(tmp_path, monkeypatch, capsys):
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir(mode=0o700)
    _expected(tmp_path).parent.mkdir(parents=True, mode=0o700)
    _expected(tmp_path).symlink_to(elsewhere)
    _assert_refused(tmp_path, monkeypatch, capsys, _expected(tmp_path), "symbolic link")


@posix
def test_numba_cache_dir_is_checked_as_well(tmp_path, monkeypatch, capsys):
    mine, shared = tmp_path / "mine", tmp_path / "shared"
    shared.mkdir()
    shared.chmod(0o1777)
    for top, ok in ((mine, True), (shared, False)):
        monkeypatch.setattr(config, "CACHE_DIR", str(top))
        capsys.readouterr()
        folder = nk._cache_dir()
        err = capsys.readouterr().err
        if ok:
            assert folder == str(mine / nk._source_hash()) and err == ""
            assert stat.S_IMODE(mine.stat().st_mode) == 0o700
        else:
            assert folder is None and str(shared) in err and len(err.splitlines()) == 1, err


@posix
def test_a_planted_cache_runs_nothing_in_a_new_process(tmp_path):
    """A fresh process compiling a kernel with a world-writable cache folder full of planted
    indexes: they are not loaded, and the warning is said once."""
    xdg = tmp_path / "xdg"
    target = xdg / "euc-sim" / "numba" / nk._source_hash()
    target.mkdir(parents=True)
    (xdg / "euc-sim").chmod(0o777)
    marker = tmp_path / "pwned"
    _plant(target, nk._motor.py_func, marker)
    env = {**os.environ, "XDG_CACHE_HOME": str(xdg), "PYTHONPATH": os.pathsep.join(sys.path)}
    env.pop("NUMBA_CACHE_DIR", None)
    code = ("from euc_sim.simulation import native_kernels as nk\n"
            "print(nk._motor(*([0.1] * 14)))\n")
    run = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, timeout=300)
    assert run.returncode == 0, run.stderr
    assert not marker.exists()
    warnings = [line for line in run.stderr.splitlines() if "not caching" in line]
    assert len(warnings) == 1 and str(xdg / "euc-sim") in warnings[0], run.stderr

"""Nothing a user owns is lost: every command that writes refuses, before any work, an output
that is a device or FIFO, an input (by name, symbolic or hard link, or inside an input folder),
inside its own ``--report`` folder, or a ``--report`` folder holding files euc-sim did not
write; exit 2, one line naming the culprit, the user's files byte-identical afterwards.

The inputs are stubs: every refusal here comes before the input is read.
"""

from __future__ import annotations

import os
import stat
from pathlib import Path

import pytest

from euc_sim.cli import main

#: A command line per command that writes a file: ``IN`` its input, ``OUT`` the file it writes.
FILE_OUT = {
    "crosscheck": ["crosscheck", "--samples", "1", "--mjcf", "IN", "--json", "OUT"],
    "dynamics": ["dynamics", "--q", "0,0,0", "--mjcf", "IN", "--json", "OUT"],
    "simulate": ["simulate", "--duration", "1", "--profile", "IN", "--out", "OUT"],
    "stability": ["stability", "--json", "OUT"],
    "torques": ["torques", "IN", "--out", "OUT"],
    "identify": ["identify", "IN", "--json", "OUT"],
    "diagnose": ["diagnose", "IN", "--json", "OUT"],
    "ride": ["ride", "IN", "--json", "OUT"],
    "rides": ["rides", "IN", "--json", "OUT"],
    "render": ["render", "IN", "--out", "OUT"],
    "design": ["design", "--json", "OUT"],
}
#: A command line per command that writes a folder (``DIR``).
FOLDER_OUT = {
    "identify": ["identify", "IN", "--report", "DIR"],
    "diagnose": ["diagnose", "IN", "--report", "DIR"],
    "ride": ["ride", "IN", "--report", "DIR"],
    "rides": ["rides", "IN", "--report", "DIR"],
    "design": ["design", "--report", "DIR"],
    "demo": ["demo", "--out-dir", "DIR"],
}
WITH_INPUT = [c for c, argv in FILE_OUT.items() if "IN" in argv]
STUB = "t,x,gamma,phi\n0,0,0,0\n"


def _inputs(folder: Path) -> Path:
    """The stub input (``rec.csv``, or ``model.xml`` for the MJCF readers) in ``folder``."""
    (folder / "rec.csv").write_text(STUB)
    (folder / "model.xml").write_text("<mujoco/>\n")
    return folder


def _argv(template, folder: Path, out=None, dir=None, inp=None) -> list[str]:
    """``template`` with its placeholders filled (``IN`` defaults to the stub in ``folder``)."""
    if inp is None:
        inp = folder / ("model.xml" if "--mjcf" in template else "rec.csv")
    fill = {"IN": inp, "OUT": out, "DIR": dir}
    return [str(fill[a]) if a in fill else a for a in template]


def _tree(folder: Path) -> dict:
    """Everything under ``folder``: bytes and mode of files, targets of links, kinds of the rest."""
    out = {}
    for root, dirs, files in os.walk(folder):
        for name in dirs + files:
            p = Path(root) / name
            st = os.lstat(p)
            if stat.S_ISLNK(st.st_mode):
                out[p] = ("link", os.readlink(p))
            elif stat.S_ISREG(st.st_mode):
                out[p] = ("file", p.read_bytes(), stat.S_IMODE(st.st_mode))
            else:
                out[p] = (stat.S_IFMT(st.st_mode),)
    return out


def _refused(argv, culprits, capsys, folder: Path) -> str:
    """Exit 2, one line naming every one of ``culprits``, nothing under ``folder`` changed."""
    before = _tree(folder)
    capsys.readouterr()
    assert main([str(a) for a in argv]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1, err
    for c in culprits:
        assert str(c) in err, err
    assert _tree(folder) == before
    return err


# --- 1. devices, FIFOs, sockets --------------------------------------------------------------
@pytest.mark.parametrize("command", FILE_OUT)
def test_a_fifo_output_is_refused(command, tmp_path, capsys):
    fifo = tmp_path / "pipe"
    os.mkfifo(fifo)
    err = _refused(_argv(FILE_OUT[command], _inputs(tmp_path), out=fifo), [fifo, "FIFO"], capsys, tmp_path)
    assert stat.S_ISFIFO(os.lstat(fifo).st_mode)
    assert "not a regular file" in err


def test_a_socket_output_and_a_device_are_refused(tmp_path, capsys):
    import socket

    sock_path = tmp_path / "s"
    with socket.socket(socket.AF_UNIX) as s:
        s.bind(str(sock_path))
        _refused(["torques", _inputs(tmp_path) / "rec.csv", "--out", sock_path], [sock_path, "socket"],
                 capsys, tmp_path)
    dev = tmp_path / "zero"
    try:
        os.mknod(dev, stat.S_IFCHR | 0o600, os.makedev(1, 5))
    except (PermissionError, OSError):
        pytest.skip("no permission to make a device node")
    _refused(["dynamics", "--q", "0,0,0", "--json", dev], [dev, "character device"], capsys, tmp_path)
    assert stat.S_ISCHR(os.lstat(dev).st_mode)


@pytest.mark.parametrize("command", FOLDER_OUT)
def test_a_fifo_report_folder_is_refused(command, tmp_path, capsys):
    fifo = tmp_path / "pipe"
    os.mkfifo(fifo)
    _refused(_argv(FOLDER_OUT[command], _inputs(tmp_path), dir=fifo), [fifo, "not a folder"], capsys, tmp_path)


# --- 2. an output that is an input ------------------------------------------------------------
@pytest.mark.parametrize("how", ["same", "symlink", "hardlink"])
@pytest.mark.parametrize("command", WITH_INPUT)
def test_an_input_is_never_an_output(command, how, tmp_path, capsys):
    _inputs(tmp_path)
    inp = tmp_path / ("model.xml" if "--mjcf" in FILE_OUT[command] else "rec.csv")
    out = {"same": inp, "symlink": tmp_path / "link.csv", "hardlink": tmp_path / "hard.csv"}[how]
    if how == "symlink":
        out.symlink_to(inp.name)
    elif how == "hardlink":
        os.link(inp, out)
    _refused(_argv(FILE_OUT[command], tmp_path, out=out, inp=inp), [out, "input", inp.name], capsys, tmp_path)


def test_rides_protects_every_log_it_is_given(tmp_path, capsys):
    logs = tmp_path / "logs"
    logs.mkdir()
    for name in ("a.csv", "b.csv"):
        (logs / name).write_text(STUB)
    _refused(["rides", logs / "a.csv", logs / "b.csv", "--json", logs / "b.csv"], [logs / "b.csv", "input"],
             capsys, tmp_path)
    _refused(["rides", logs, "--json", logs / "a.csv"], [logs / "a.csv", "input"], capsys, tmp_path)
    os.link(logs / "a.csv", tmp_path / "elsewhere.csv")          # the same file by another name
    _refused(["rides", logs, "--json", tmp_path / "elsewhere.csv"], ["elsewhere.csv", "input"], capsys, tmp_path)


@pytest.mark.parametrize("command", ["ride", "rides", "torques", "identify", "diagnose", "render"])
def test_a_fifo_input_is_refused_not_read(command, tmp_path, capsys):
    fifo = tmp_path / "in.csv"
    os.mkfifo(fifo)
    _refused(_argv(FILE_OUT[command], tmp_path, out=tmp_path / "o.json", inp=fifo), [fifo, "FIFO"],
             capsys, tmp_path)


def test_rides_refuses_a_folder_holding_a_fifo_or_a_device(tmp_path, capsys):
    logs = tmp_path / "logs"
    logs.mkdir()
    os.mkfifo(logs / "stuck.csv")
    _refused(["rides", logs, "--json", tmp_path / "o.json"], [logs / "stuck.csv", "FIFO"], capsys, tmp_path)
    os.unlink(logs / "stuck.csv")
    try:
        os.mknod(logs / "zero.csv", stat.S_IFCHR | 0o600, os.makedev(1, 5))
    except (PermissionError, OSError):
        pytest.skip("no permission to make a device node")
    _refused(["rides", logs, "--json", tmp_path / "o.json"], [logs / "zero.csv", "character device"],
             capsys, tmp_path)


# --- 3. a report folder holding what euc-sim did not write ---------------------------------------
@pytest.mark.parametrize("command", FOLDER_OUT)
def test_a_report_folder_of_the_users_files_is_refused(command, tmp_path, capsys):
    rep = tmp_path / "rep"
    rep.mkdir()
    (rep / "index.md").write_text("# my notes\n")
    (rep / "ride_balance.png").write_bytes(b"\x89PNG mine")
    _refused(_argv(FOLDER_OUT[command], _inputs(tmp_path), dir=rep), [rep, "index.md", "not written by euc-sim"],
             capsys, tmp_path)


@pytest.mark.parametrize("command", [c for c in FOLDER_OUT if "IN" in FOLDER_OUT[c]])
def test_report_dot_in_the_logs_folder_is_refused(command, tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(_inputs(tmp_path))
    (tmp_path / "index.md").write_text("# mine\n")
    _refused(_argv(FOLDER_OUT[command], tmp_path, dir=".", inp="rec.csv"), ["--report .", "rec.csv"],
             capsys, tmp_path)


def _ours(folder: Path, names=("index.html", "index.md")) -> None:
    """``folder`` as euc-sim leaves it: the files and a manifest listing them."""
    from argparse import Namespace

    from euc_sim.cli.common import check_outputs, record_outputs

    args = Namespace(command="design", report=str(folder), json=None)
    states = check_outputs(args)
    folder.mkdir(exist_ok=True)
    for name in names:
        (folder / name).parent.mkdir(parents=True, exist_ok=True)
        (folder / name).write_text(f"{name} by euc-sim\n")
    record_outputs(states)


@pytest.mark.parametrize("command", FOLDER_OUT)
def test_a_file_changed_or_added_in_a_report_folder_is_foreign(command, tmp_path, capsys):
    from euc_sim.cli.common import MANIFEST, check_folder_is_ours

    rep = tmp_path / "rep"
    _ours(rep)
    assert (rep / MANIFEST).is_file()
    check_folder_is_ours(rep)                     # euc-sim's own folder: it may be written again
    (rep / "index.md").write_text("# edited by its owner\n")
    _refused(_argv(FOLDER_OUT[command], _inputs(tmp_path), dir=rep), ["index.md", "changed since"],
             capsys, tmp_path)
    _ours(tmp_path / "rep2")
    (tmp_path / "rep2" / "notes.txt").write_text("mine\n")
    _refused(_argv(FOLDER_OUT[command], tmp_path, dir=tmp_path / "rep2"), ["notes.txt", "not written"],
             capsys, tmp_path)


def test_the_manifest_follows_what_a_run_wrote(tmp_path):
    import json

    from euc_sim.cli.common import MANIFEST

    rep = tmp_path / "rep"
    _ours(rep, ("index.html", "a.png"))
    _ours(rep, ("index.html", "sub/b.png"))      # rewritten, added in a subfolder; a.png kept
    listed = json.loads((rep / MANIFEST).read_text())["files"]
    assert sorted(listed) == ["a.png", "index.html", "sub/b.png"]
    assert listed["a.png"]["size"] == len("a.png by euc-sim\n")


def test_a_refused_or_idle_run_leaves_no_manifest(tmp_path):
    from euc_sim.cli.common import MANIFEST

    rep = tmp_path / "rep"
    rep.mkdir()
    _ours(rep, ())
    assert not (rep / MANIFEST).exists() and list(rep.iterdir()) == []


# --- 4. --json / --out inside the --report folder ------------------------------------------------
@pytest.mark.parametrize("command", [c for c in FOLDER_OUT if c != "demo"])
@pytest.mark.parametrize("name", ["index.html", "index.md", "sub/x.json"])
def test_an_output_inside_the_report_folder_is_refused(command, name, tmp_path, capsys):
    rep = tmp_path / "rep"
    argv = _argv(FOLDER_OUT[command], _inputs(tmp_path), dir=rep) + ["--json", str(rep / name)]
    _refused(argv, [rep / name, f"--report {rep}"], capsys, tmp_path)


# --- 5. symbolic links and modes; 6. long names ---------------------------------------------------
def test_a_symlinked_output_is_written_through_and_keeps_its_mode(tmp_path, capsys):
    import json

    target = tmp_path / "kept" / "dyn.json"
    target.parent.mkdir()
    target.write_text("old\n")
    target.chmod(0o600)
    link = tmp_path / "dyn.json"
    link.symlink_to(target)
    assert main(["dynamics", "--q", "0,0,0", "--json", str(link)]) == 0
    assert link.is_symlink() and os.readlink(link) == str(target)
    assert "qdd_analytic" in json.loads(target.read_text())
    assert stat.S_IMODE(target.stat().st_mode) == 0o600
    assert sorted(p.name for p in target.parent.iterdir()) == ["dyn.json"]


def test_a_new_output_gets_the_umask_mode(tmp_path):
    from euc_sim.io import write_text

    old = os.umask(0o027)
    try:
        write_text(tmp_path / "new.txt", "x")
    finally:
        os.umask(old)
    assert stat.S_IMODE((tmp_path / "new.txt").stat().st_mode) == 0o640


def test_a_name_over_255_bytes_is_refused_naming_the_limit(tmp_path, capsys):
    long = tmp_path / ("é" * 130 + ".json")         # 264 bytes
    _refused(["dynamics", "--q", "0,0,0", "--json", long], ["255 bytes", "NAME_MAX", tmp_path], capsys, tmp_path)
    _refused(["design", "--report", tmp_path / ("r" * 256)], ["256 bytes", "NAME_MAX"], capsys, tmp_path)


def test_a_name_of_250_bytes_is_written(tmp_path):
    from euc_sim.io import write_text

    name = tmp_path / ("n" * 245 + ".json")
    write_text(name, "{}\n")
    assert name.read_text() == "{}\n" and sorted(tmp_path.iterdir()) == [name]


def test_an_input_name_over_255_bytes_is_named_with_the_limit(tmp_path, capsys):
    long = tmp_path / ("é" * 130 + ".csv")
    _refused(["torques", long, "--out", tmp_path / "T.csv"], ["input recording", "264 bytes", "NAME_MAX"],
             capsys, tmp_path)


def test_a_report_folder_is_written_again_until_its_owner_edits_it(tmp_path, capsys):
    """Through ``main``: the manifest lets a second run replace the first's figures, not an edited one."""
    import json

    import numpy as np
    import pandas as pd

    from euc_sim.cli.common import MANIFEST

    t = np.arange(1800) / 120.0
    rec = tmp_path / "decel.csv"
    pd.DataFrame({"t": t, "x": 2.0 * t - 0.3 * t**2, "gamma": 0.02 * np.sin(3 * t),
                  "phi": 0.05 * np.sin(2 * t)}).to_csv(rec, index=False)
    rep = tmp_path / "rep"
    argv = ["identify", str(rec), "--n-boot", "0", "--noise-replicates", "0", "--report", str(rep)]
    for _ in range(2):
        assert main(argv) == 0, capsys.readouterr().err
        listed = json.loads((rep / MANIFEST).read_text())["files"]
        assert sorted(listed) == ["identify-torques.png", "identify.png"]
    (rep / "identify.png").write_bytes(b"the owner's own figure")
    _refused(argv, ["identify.png", "changed since"], capsys, tmp_path)


def test_a_wheel_name_is_not_an_input_file(tmp_path, monkeypatch):
    """``--wheel z10`` names a shipped wheel: ``--report z10`` beside it is a new folder, not the input."""
    from argparse import Namespace

    from euc_sim.cli.common import check_outputs
    from euc_sim.errors import BadOutputPath

    monkeypatch.chdir(tmp_path)
    args = Namespace(command="ride", log=str(_inputs(tmp_path) / "rec.csv"), compare=None, wheel="z10",
                     report="z10", json=None)
    check_outputs(args)                                     # refused as 'holds the input --wheel z10' before
    (tmp_path / "z10").mkdir()
    (tmp_path / "z10" / "spec.csv").write_text("Field|Data\n")
    with pytest.raises(BadOutputPath, match="holds the input --wheel"):
        check_outputs(Namespace(**{**vars(args), "wheel": "z10/spec.csv"}))

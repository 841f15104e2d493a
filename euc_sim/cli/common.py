"""Helpers shared by the command modules: usage errors, messages to people, ``--param`` parsing, output checks."""

from __future__ import annotations

import argparse
import json
import os
import platform
import stat
import sys
import tempfile
import time
import traceback
from pathlib import Path
from typing import Sequence

from euc_sim import __version__
from euc_sim.errors import BadInputFile, BadOutputPath, InputError
from euc_sim.io import check_name, check_output, check_writable, file_kind, shown, sidecar_paths, write_json
from euc_sim.model.parameters import Params, check_plausible

EXIT_OK, EXIT_FAIL, EXIT_USAGE = 0, 1, 2


class UsageError(InputError):
    """A command-line argument that cannot be used; the message names it."""


def seed(text: str) -> int:
    """argparse type of ``--seed``: a non-negative integer (numpy's seeds), named in the error."""
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a non-negative integer, got {text!r}") from None
    if value < 0:
        raise argparse.ArgumentTypeError(f"expected a non-negative integer, got {value}")
    return value


def say(msg: str) -> None:
    print(msg, file=sys.stderr, flush=True)


def parse_params(items: Sequence[str] | None):
    """``--param NAME=VALUE`` pairs → Params (Table 3 for the rest), checked as plausible (UsageError,
    ParameterError)."""
    values = param_values(items)
    return check_plausible(Params.from_mapping(values), values)


def param_values(items: Sequence[str] | None) -> dict[str, float]:
    """``--param NAME=VALUE`` pairs → ``{name: value}`` (names are checked by Params)."""
    values = {}
    for item in items or ():
        name, sep, value = item.partition("=")
        if not sep:
            raise UsageError(f"--param expects NAME=VALUE, got {item!r}")
        try:
            values[name.strip()] = float(value)
        except ValueError:
            raise UsageError(f"--param {name.strip()}: expected a number, got {value!r}") from None
    return values


#: Options that name a file (or, for ``rides``, a folder of logs) the command reads.
INPUT_OPTIONS = ("recording", "recordings", "log", "logs", "compare", "profile", "drivetrain", "wheel", "mjcf")
#: Options that name a file the command writes.
OUTPUT_OPTIONS = ("out", "json")
#: Commands that write a recording and its sidecars (``NAME.json``, ``NAME.truth.json``).
WRITES_RECORDING = ("simulate",)
#: The file in a ``--report`` folder (and ``demo``'s) listing what euc-sim wrote there.
MANIFEST = ".euc-sim-manifest.json"
#: How the positional arguments are named in messages.
_POSITIONAL = {"recording": "recording", "recordings": "recording", "log": "log", "logs": "log"}


def _named(args, names) -> list[tuple[str, Path]]:
    """The paths given to the options ``names`` (argparse dests), as ``(option as typed, path)``."""
    out = []
    for name in names:
        value = getattr(args, name, None)
        for v in value if isinstance(value, (list, tuple)) else [value]:
            if v is not None and str(v) != "":
                out.append((_POSITIONAL.get(name) or "--" + name.replace("_", "-"), Path(v)))
    return out


def _identity(path: Path):
    """What makes two names one file: ``(st_dev, st_ino)`` when it exists (so hard and symbolic
    links count), else the absolute path with links resolved."""
    try:
        st = os.stat(path)
        return st.st_dev, st.st_ino
    except (OSError, ValueError):
        return os.path.realpath(path)


def _inside(path: Path, folder: Path) -> bool:
    p, f = os.path.realpath(path), os.path.realpath(folder)
    return p == f or p.startswith(f.rstrip(os.sep) + os.sep)


def report_folders(args) -> list[tuple[str, Path]]:
    """The folders a command writes as a whole, as ``(option, path)``: ``--report`` and ``demo``'s ``--out-dir``."""
    return _named(args, ("report",)) + (_named(args, ("out_dir",)) if args.command == "demo" else [])


def _guarded(args) -> dict:
    """Every file an output may not be, ``{identity: (what, path, named)}``: inputs, CSVs inside an input folder
    (``named`` False), input sidecars."""
    guarded = {}
    for opt, path in _named(args, INPUT_OPTIONS):
        if opt == "--wheel" and not path.is_file():     # a shipped wheel's name, not a file
            continue
        guarded.setdefault(_identity(path), (f"the input {opt} {shown(path)}", path, True))
        if path.is_dir() and args.command == "rides":      # the one command that reads a folder
            for root, dirs, files in os.walk(path):
                for inner in (Path(root) / n for n in files if n.lower().endswith(".csv")):
                    guarded.setdefault(_identity(inner), (f"the input {shown(inner)} (in the folder {shown(path)})",
                                                          inner, False))
        elif opt == "recording" and path.name and not path.is_dir():
            for side in sidecar_paths(path):
                guarded.setdefault(_identity(side), (f"the sidecar of {shown(path)}", side, True))
    return guarded


def check_outputs(args) -> list:
    """Refuse, before anything runs, an output that would destroy an input or another's file.

    An output may not be an input (by name or link), a file in an input folder, an input's
    sidecar, another output, nor lie inside a ``--report`` folder; it must pass
    :func:`euc_sim.io.check_output`.  A report folder must pass :func:`check_folder_is_ours`.
    ``simulate`` does not replace a ``NAME.json`` that is not an euc-sim sidecar; an existing input
    must be a regular file or a folder.
    Returns the report folders' states for :func:`record_outputs`; raises BadOutputPath.
    """
    _check_inputs_are_files(args)
    guarded = _guarded(args)
    outputs, folders = _named(args, OUTPUT_OPTIONS), report_folders(args)
    for i, (opt, path) in enumerate(outputs):
        check_output(path)
        what = guarded.get(_identity(path), (None,))[0]
        if what is not None:
            raise BadOutputPath(f"{opt} {shown(path)}: is {what}; refusing to overwrite it")
        for opt2, path2 in outputs[:i]:
            if _identity(path) == _identity(path2):
                raise BadOutputPath(f"{opt} {shown(path)}: {opt2} writes the same file")
        for fopt, folder in folders:
            if _inside(path, folder):
                raise BadOutputPath(f"{opt} {shown(path)} lies inside {fopt} {shown(folder)}, the folder "
                                    f"{fopt} writes; choose a path outside it")
    if args.command in WRITES_RECORDING and getattr(args, "out", None):
        _check_foreign_sidecars(Path(args.out))
    states = []
    for fopt, folder in folders:
        check_output(folder, folder=True)
        for what, path, named in guarded.values():
            if named and _inside(path, folder):
                raise BadOutputPath(f"{fopt} {shown(folder)}: holds {what}; refusing to write into it "
                                    "(choose a new or empty folder)")
        # a file the run writes is newer than this (less a second for the file system's coarse clock)
        states.append((folder, check_folder_is_ours(folder, fopt), time.time_ns() - 10**9))
    return states


def _check_inputs_are_files(args) -> None:
    """An input that exists is a regular file or a folder (a FIFO would hang the reader, a
    device be read without end); its name fits :data:`euc_sim.io.NAME_MAX`."""
    for opt, path in _named(args, INPUT_OPTIONS):
        check_name(path, f"input {opt}", BadInputFile)
        try:
            mode = os.stat(path).st_mode
        except (OSError, ValueError):
            continue                         # missing: the reader names it
        if not (stat.S_ISREG(mode) or stat.S_ISDIR(mode)):
            raise BadInputFile(f"{opt} {shown(path)} is a {file_kind(mode)}, not a regular file")


def _folder_files(folder: Path) -> dict:
    """``{relative posix path: (size, mtime_ns)}`` of everything under ``folder`` but the manifest
    (symbolic links and special files with size -1: they are never euc-sim's)."""
    out = {}
    for root, dirs, files in os.walk(folder):
        dirs.sort()
        for name in sorted(files) + [d for d in dirs if os.path.islink(os.path.join(root, d))]:
            path = Path(root) / name
            rel = path.relative_to(folder).as_posix()
            if rel == MANIFEST:
                continue
            st = os.lstat(path)
            out[rel] = (st.st_size, st.st_mtime_ns) if not path.is_symlink() and path.is_file() else (-1, -1)
    return out


def _manifest(folder: Path) -> dict:
    """The files the manifest of ``folder`` lists, ``{relative path: (size, mtime_ns)}`` (empty if none)."""
    try:
        doc = json.loads((folder / MANIFEST).read_text(encoding="utf-8"))
        return {str(k): (int(v["size"]), int(v["mtime_ns"])) for k, v in doc["files"].items()}
    except (OSError, ValueError, TypeError, KeyError, AttributeError):
        return {}


def check_folder_is_ours(folder: str | Path, option: str = "--report") -> dict:
    """Refuse (BadOutputPath) a folder holding a file not in its :data:`MANIFEST` with its current size and time;
    return its files now."""
    folder = Path(folder)
    if not folder.is_dir():
        return {}
    now, ours = _folder_files(folder), _manifest(folder)
    for rel, state in now.items():
        if ours.get(rel) != state:
            why = "was changed since euc-sim wrote it" if rel in ours else "was not written by euc-sim"
            raise BadOutputPath(f"{option} {shown(folder)}: {shown(rel)} {why}; refusing to overwrite the "
                                "folder (choose a new or empty folder)")
    return now


def record_outputs(states) -> None:
    """After a command: add to each report folder's manifest the files written during the run (atomically;
    unchanged folders are left alone)."""
    for folder, before, start in states:
        if not folder.is_dir():
            continue
        now = _folder_files(folder)
        if now == before:
            continue
        files = {rel: {"size": size, "mtime_ns": mtime} for rel, (size, mtime) in now.items()
                 if size >= 0 and (before.get(rel) == (size, mtime) or mtime >= start)}
        try:
            write_json(folder / MANIFEST, {"written_by": "euc-sim", "files": files})
        except OSError:
            pass                              # the next run will name the unlisted file


def _check_foreign_sidecars(out: Path) -> None:
    """``simulate --out NAME.csv`` replaces NAME.json only when it is a sidecar euc-sim wrote."""
    meta, truth = sidecar_paths(out)
    ours = False
    if meta.is_file():
        try:
            doc = json.loads(meta.read_text(encoding="utf-8"))
            ours = isinstance(doc, dict) and str(doc.get("source", "")).startswith("euc-sim")
        except (OSError, ValueError):
            ours = False
        if not ours:
            raise BadOutputPath(f"--out {shown(out)}: its sidecar {shown(meta)} exists and is not one euc-sim "
                                "wrote; refusing to overwrite it (move it or choose another name)")
    if truth.is_file() and not ours:
        raise BadOutputPath(f"--out {shown(out)}: {shown(truth)} exists without an euc-sim sidecar beside it; "
                            "refusing to overwrite it")


def internal_error_report(args, exc: BaseException) -> Path | None:
    """Write ``exc``'s traceback beside the command's first output (else in the temp folder); its path, or None."""
    folders = [path.parent for _, path in _named(args, OUTPUT_OPTIONS)]
    folders = [f for f in folders if f.is_dir()] + [Path(tempfile.gettempdir())]
    text = (f"euc-sim {__version__} {getattr(args, 'command', '')}: internal error\n"
            f"command line: {' '.join(sys.argv)}\npython {platform.python_version()} on "
            f"{platform.platform()}\n\n" + "".join(traceback.format_exception(exc)))
    for folder in folders:
        try:
            fd, name = tempfile.mkstemp(prefix=f"euc-sim-{getattr(args, 'command', 'x')}-internal-error-",
                                        suffix=".txt", dir=folder)
            with os.fdopen(fd, "w", encoding="utf-8") as f:
                f.write(text)
            return Path(name)
        except OSError:
            continue
    return None


def check_report_folder(folder, names: Sequence[str]):
    """``--report DIR`` before any work: a folder (or nothing yet) that can take ``names``; returns the folder."""
    out = Path(folder)
    if out.exists() and not out.is_dir():
        raise NotADirectoryError(f"--report {out}: exists and is not a folder")
    for name in names:
        check_writable(out / name)
    return out

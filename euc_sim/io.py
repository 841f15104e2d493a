"""Files in and out: atomic writes and JSON.

Every output goes to a temporary file beside its destination and is renamed into place,
so a failed command leaves no half-written file.  An output must be a regular file or
nothing yet (:func:`check_output`); a symbolic link is written through; an existing
file keeps its permission bits, a new one gets the umask's.
"""

from __future__ import annotations

import errno
import io
import json
import math
import os
import stat
import tempfile
from pathlib import Path
from typing import Any, Callable

import numpy as np

from euc_sim.errors import BadOutputPath, InputError

__all__ = ["atomic_write", "write_text", "write_json", "to_jsonable", "check_writable", "check_output",
           "check_name", "file_kind", "shown", "NAME_MAX",
           "write_recording", "sidecar_paths", "temporary_beside", "is_temporary", "FLOAT_FORMAT",
           "save_figure", "figure_png"]

#: What marks a temporary file of :func:`atomic_write`: ``.NAME.tmp-XXXXXXXX.EXT``.
_TEMP_MARK = ".tmp-"
#: The longest file name (one path component) Linux, macOS and Windows file systems take, in bytes.
NAME_MAX = 255


def shown(path: str | Path) -> str:
    """A path for a one-line message: as typed, or ``repr`` when it holds an unprintable character."""
    text = str(path)
    return text if text.isprintable() else repr(text)


def _cut(name: str, limit: int) -> str:
    """``name`` cut to at most ``limit`` bytes of UTF-8 (never inside a character)."""
    return os.fsencode(name)[:max(limit, 1)].decode("utf-8", "ignore") or "x"


def file_kind(mode: int) -> str:
    """What a ``st_mode`` is, for a message: ``FIFO``, ``character device``, ..."""
    for test, kind in ((stat.S_ISREG, "regular file"), (stat.S_ISDIR, "folder"), (stat.S_ISFIFO, "FIFO (named pipe)"),
                       (stat.S_ISCHR, "character device"), (stat.S_ISBLK, "block device"),
                       (stat.S_ISSOCK, "socket")):
        if test(mode):
            return kind
    return "special file"


def check_output(path: str | Path, folder: bool = False) -> Path:
    """Refuse (:class:`~euc_sim.errors.BadOutputPath`) an output whose name is too long or that exists and is not
    a regular file (with ``folder``: a folder)."""
    path = check_name(path, "output", BadOutputPath)
    try:
        mode = os.stat(path).st_mode
    except OSError:
        return path                      # nothing there yet (or unreadable: the write will say)
    if not (stat.S_ISDIR(mode) or stat.S_ISREG(mode)):     # a file for a folder: the writer says
        raise BadOutputPath(f"output {shown(path)} is a {file_kind(mode)}, not a "
                            f"{'folder' if folder else 'regular file'}; refusing to replace it")
    return path


def check_name(path: str | Path, role: str = "output", error: type = InputError) -> Path:
    """Refuse a path with a component over :data:`NAME_MAX` bytes, naming the path, its role and the limit."""
    path = Path(path)
    for part in path.parts:
        size = len(os.fsencode(part))
        if size > NAME_MAX:
            raise error(f"{role} {shown(path)}: the name {shown(_cut(part, 40) + '...')} is {size} "
                        f"bytes long, over the file-name limit of {NAME_MAX} bytes (NAME_MAX)")
    return path


def _target(path: Path) -> Path:
    """Where writing ``path`` lands: the final target of a symbolic link, else ``path``."""
    return Path(os.path.realpath(path)) if path.is_symlink() else path


def temporary_beside(path: str | Path) -> Path:
    """Create an empty temporary file (mode 0600) beside ``path`` keeping its extension: ``ride.mp4`` →
    ``.ride.tmp-XXXXXXXX.mp4``."""
    path = Path(path)
    suffix = _cut(path.suffix, 16) if len(path.suffix) > 16 else path.suffix
    stem = _cut(path.stem, NAME_MAX - 1 - len(_TEMP_MARK) - 8 - len(os.fsencode(suffix)))
    fd, tmp = tempfile.mkstemp(prefix=f".{stem}{_TEMP_MARK}", suffix=suffix, dir=path.parent)
    os.close(fd)
    return Path(tmp)


def is_temporary(path: str | Path) -> bool:
    """True for a name :func:`temporary_beside` makes (for checks that nothing was left behind)."""
    name = Path(path).name
    return name.startswith(".") and _TEMP_MARK in name


def check_writable(path: str | Path) -> Path:
    """Fail early, naming the path, when ``path``'s folder cannot take a new file.

    Nothing is created: a missing folder is checked through its nearest existing ancestor.

    Raises
    ------
    PermissionError, NotADirectoryError, IsADirectoryError
    """
    path = check_output(path)
    parent = path.parent if str(path.parent) else Path(".")
    if path.is_dir():
        raise IsADirectoryError(errno.EISDIR, f"output {path} is a directory, expected a file path", str(path))
    existing = next((d for d in (parent, *parent.parents) if d.exists() or d.is_symlink()), Path("."))
    if not existing.is_dir():
        raise NotADirectoryError(errno.ENOTDIR, f"cannot write {path}: {existing} is not a folder", str(path))
    if existing != parent:
        if not os.access(existing, os.W_OK | os.X_OK):
            raise PermissionError(errno.EACCES, f"cannot write {path}: no permission to create its "
                                                f"folder in {existing}", str(path))
        return path
    try:
        fd, probe = tempfile.mkstemp(prefix=f".{_cut(path.name, 200)}.", suffix=".probe", dir=parent)
        os.close(fd)
        os.unlink(probe)
    except OSError as exc:
        reason = exc.strerror or type(exc).__name__
        raise type(exc)(exc.errno, f"cannot write {path}: {reason} ({parent})", str(path)) from None
    return path


def _naming(exc: OSError, path: Path) -> OSError:
    """The same kind of OSError, naming ``path``."""
    if exc.filename is not None:
        return exc
    try:
        return type(exc)(exc.errno, exc.strerror or str(exc) or type(exc).__name__, str(path))
    except TypeError:
        return OSError(exc.errno, exc.strerror or str(exc), str(path))


def atomic_write(path: str | Path, write: Callable[[Path], None]) -> Path:
    """Call ``write(tmp_path)`` then rename the temporary file onto ``path``; return ``path``.

    ``tmp_path`` keeps ``path``'s extension; the folder is created when missing; on any error
    the temporary file is removed and nothing appears at ``path``.
    """
    path = check_writable(path)
    dest = _target(path)
    try:
        dest.parent.mkdir(parents=True, exist_ok=True)
        tmp_path = temporary_beside(dest)
    except OSError as exc:
        raise _naming(exc, path) from None
    try:
        write(tmp_path)
        _replace(tmp_path, dest)
    except OSError as exc:
        tmp_path.unlink(missing_ok=True)
        raise _naming(exc, path) from exc
    except BaseException:
        tmp_path.unlink(missing_ok=True)
        raise
    return path


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


def _replace(tmp: Path, dest: Path) -> None:
    """Rename ``tmp`` onto ``dest`` (checked again) with ``dest``'s permission bits, else a new file's."""
    check_output(dest)
    try:
        mode = stat.S_IMODE(os.stat(dest).st_mode)
    except FileNotFoundError:
        mode = 0o666 & ~_umask()
    os.chmod(tmp, mode)
    os.replace(tmp, dest)


def write_text(path: str | Path, text: str) -> Path:
    """Write text atomically (UTF-8)."""
    return atomic_write(path, lambda p: p.write_text(text, encoding="utf-8"))


def save_figure(fig, path: str | Path, dpi: int = 110) -> Path:
    """Write a matplotlib Figure atomically in the format its suffix names (default PNG), ``dpi`` dots per inch."""
    kind = Path(path).suffix.lstrip(".").lower() or "png"
    return atomic_write(path, lambda p: fig.savefig(p, dpi=dpi, format=kind))


def figure_png(fig, dpi: int = 110) -> bytes:
    """A matplotlib Figure as PNG bytes (for pages written only once all is made)."""
    buf = io.BytesIO()
    fig.savefig(buf, dpi=dpi, format="png")
    return buf.getvalue()


def to_jsonable(obj: Any) -> Any:
    """numpy scalars and arrays, tuples and paths to plain JSON types; NaN/inf to None."""
    if isinstance(obj, dict):
        return {str(k): to_jsonable(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [to_jsonable(v) for v in obj]
    if isinstance(obj, Path):
        return str(obj)
    if hasattr(obj, "tolist"):  # numpy array or scalar
        return to_jsonable(obj.tolist())
    if isinstance(obj, float) and not math.isfinite(obj):
        return None
    return obj


def _json_text(obj: Any) -> str:
    return json.dumps(to_jsonable(obj), indent=2, ensure_ascii=False) + "\n"


def write_json(path: str | Path, obj: Any) -> Path:
    """Write one JSON object atomically, indented, with a final newline."""
    return write_text(path, _json_text(obj))


#: printf format of floats in recording CSVs: 10 significant digits, the same bytes every run.
FLOAT_FORMAT = "%.10g"


def sidecar_paths(path: str | Path) -> tuple[Path, Path]:
    """``NAME.json`` and ``NAME.truth.json`` beside ``NAME.csv`` / ``NAME.parquet``."""
    path = Path(path)
    stem = path.with_suffix("")
    return stem.with_name(stem.name + ".json"), stem.with_name(stem.name + ".truth.json")


def write_recording(df, path: str | Path, meta: dict, truth: dict | None = None) -> Path:
    """Write a recording (CONTRACT) with its sidecar ``NAME.json`` and optional ``NAME.truth.json``.

    All files go to temporary names first and are renamed only once all are written, the
    recording last; floats use :data:`FLOAT_FORMAT`.

    Parameters
    ----------
    df : pandas.DataFrame
        The recording's columns (``t`` first, SI units, radians).
    path : path
        ``NAME.csv`` or ``NAME.parquet``.
    meta : dict
        The sidecar.
    truth : dict, optional
        What the analysis must not see (injected effects, true parameters).

    Raises
    ------
    euc_sim.errors.InputError
        for another extension or non-finite values in the table.
    """
    path = Path(path)
    ext = path.suffix.lower()
    if ext not in (".csv", ".parquet"):
        raise InputError(f"recording path must end in .csv or .parquet, got {path.name!r}")
    values = df.select_dtypes(include="number").to_numpy(dtype=float)
    if not np.all(np.isfinite(values)):
        raise InputError(f"recording for {path} holds non-finite values; refusing to write it")
    meta_path, truth_path = sidecar_paths(path)
    check_writable(path)

    def write_table(tmp: Path) -> None:
        if ext == ".csv":
            df.to_csv(tmp, index=False, float_format=FLOAT_FORMAT, lineterminator="\n")
        else:
            df.to_parquet(tmp, index=False)

    jobs = [(meta_path, lambda p: p.write_text(_json_text(meta), encoding="utf-8"))]
    if truth is not None:
        jobs.append((truth_path, lambda p: p.write_text(_json_text(truth), encoding="utf-8")))
    jobs.append((path, write_table))
    temps: list[tuple[Path, Path]] = []
    dest = path
    try:
        for dest, write in jobs:
            check_output(dest)
            target = _target(dest)
            target.parent.mkdir(parents=True, exist_ok=True)
            tmp = temporary_beside(target)
            temps.append((tmp, target))
            write(tmp)
        for tmp, dest in temps:
            _replace(tmp, dest)
    except BaseException as exc:
        for tmp, _ in temps:
            tmp.unlink(missing_ok=True)
        if isinstance(exc, OSError):
            raise _naming(exc, dest) from exc
        raise
    if truth is None:
        truth_path.unlink(missing_ok=True)    # no stale truth from an earlier run
    return path

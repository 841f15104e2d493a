"""Helpers shared by the command modules: usage errors, messages to people, ``--param`` parsing."""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Sequence

from euc_sim.errors import InputError

EXIT_OK, EXIT_FAIL, EXIT_USAGE = 0, 1, 2


class UsageError(InputError):
    """A command-line argument that cannot be used; the message names it."""


def seed(text: str) -> int:
    """argparse type of ``--seed``: a non-negative integer (numpy's seeds), named in the error."""
    import argparse

    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a non-negative integer, got {text!r}") from None
    if value < 0:
        raise argparse.ArgumentTypeError(f"expected a non-negative integer, got {value}")
    return value


def format_eigenvalues(ev, digits: int = 3) -> str:
    """Eigenvalues for people: ``-4.22, 0, ±5.86j, -30.1 ± 5.41j`` (1/s).

    Parts below ``1e-9`` times the largest magnitude are round-off and print as 0
    (never ``-0`` or ``4.44e-16-5.86j``); a conjugate pair prints once, with ±.

    Parameters
    ----------
    ev : iterable of (float, float) or complex
        Real and imaginary parts.
    digits : int
        Significant digits.
    """
    import numpy as np

    z = np.array([complex(*e) if isinstance(e, (tuple, list)) else complex(e) for e in ev])
    tol = 1e-9 * max(1.0, float(np.abs(z).max(initial=0.0)))
    re = np.where(np.abs(z.real) < tol, 0.0, z.real) + 0.0     # + 0.0 turns -0.0 into 0.0
    im = np.where(np.abs(z.imag) < tol, 0.0, z.imag) + 0.0
    out, used = [], np.zeros(len(z), bool)
    for i in np.argsort(re, kind="stable"):
        if used[i] or im[i] < 0 and any(not used[j] and im[j] == -im[i] and re[j] == re[i]
                                        for j in range(len(z)) if j != i):
            continue
        used[i] = True
        r = f"{re[i]:.{digits}g}"
        if im[i] == 0:
            out.append(r)
            continue
        pair = [j for j in range(len(z)) if not used[j] and re[j] == re[i] and im[j] == -im[i]]
        sign = "±" if pair else ("+" if im[i] > 0 else "−")
        for j in pair[:1]:
            used[j] = True
        mag = f"{abs(im[i]):.{digits}g}j"
        out.append(f"{sign}{mag}" if re[i] == 0 else f"{r} {sign} {mag}")
    return ", ".join(out)


def say(msg: str) -> None:
    print(msg, file=sys.stderr, flush=True)


def parse_params(items: Sequence[str] | None):
    """``--param NAME=VALUE`` pairs → Params (Table 3 for the rest), checked as plausible.

    Raises
    ------
    UsageError, euc_sim.model.parameters.ParameterError
        naming the parameter, expected and actual value.
    """
    from euc_sim.model.parameters import Params, check_plausible

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


#: Options that name a file the command reads.
INPUT_OPTIONS = ("recording", "recordings", "log", "compare", "profile", "drivetrain", "wheel", "mjcf")
#: Options that name a file the command writes (``--out`` of ``dataset`` and ``demo`` is a folder).
OUTPUT_OPTIONS = ("out", "json", "plot", "effects_plot")
#: Commands whose ``--out`` is a folder.
FOLDER_OUT = ("dataset", "demo")
#: Commands that write a recording and its sidecars (``NAME.json``, ``NAME.truth.json``).
WRITES_RECORDING = ("simulate",)


def _option(name: str) -> str:
    return name if name in ("recording", "recordings", "log") else "--" + name.replace("_", "-")


def _named(args, names) -> list[tuple[str, Path]]:
    out = []
    for name in names:
        value = getattr(args, name, None)
        for v in value if isinstance(value, (list, tuple)) else [value]:
            if v is not None and str(v) != "":
                out.append((_option(name), Path(v)))
    return out


def _same(a: Path, b: Path) -> bool:
    import os

    if a.exists() and b.exists():
        return os.path.samefile(a, b)
    return os.path.abspath(a) == os.path.abspath(b)


def output_files(args) -> list[tuple[str, Path]]:
    """The files a command will write, as ``(option, path)``."""
    names = [n for n in OUTPUT_OPTIONS if not (n == "out" and args.command in FOLDER_OUT)]
    return _named(args, names)


def check_outputs(args) -> None:
    """Refuse, before anything runs, an output that would destroy an input or another's file.

    An output may not be an input, nor the sidecar of an input recording (a sidecar is
    touched only by the command that writes its recording), nor another output of
    the same command; ``simulate`` does not replace a ``NAME.json`` that is not an
    euc-sim sidecar.  Figures must have a format matplotlib writes.

    Raises
    ------
    euc_sim.errors.BadOutputPath
        naming the option and the path.
    """
    from euc_sim.errors import BadOutputPath
    from euc_sim.io import sidecar_paths

    inputs = _named(args, INPUT_OPTIONS)
    guarded = list(inputs)
    for opt, path in _named(args, ("recording", "recordings")):
        if path.name and not path.is_dir():        # a folder given as a recording is its reader's to refuse
            guarded += [(f"the sidecar of {path}", side) for side in sidecar_paths(path)]
    outputs = output_files(args)
    for i, (opt, path) in enumerate(outputs):
        for what, other in guarded:
            if _same(path, other):
                culprit = what if what.startswith("the sidecar") else f"the input {what} {other}"
                raise BadOutputPath(f"{opt} {path}: is {culprit}; refusing to overwrite it")
        for opt2, path2 in outputs[:i]:
            if _same(path, path2):
                raise BadOutputPath(f"{opt} {path}: {opt2} writes the same file")
        if opt in ("--plot", "--effects-plot"):
            from euc_sim.identification.plots import check_figure_path

            check_figure_path(path)
    if args.command in WRITES_RECORDING and getattr(args, "out", None):
        _check_foreign_sidecars(Path(args.out))


def _check_foreign_sidecars(out: Path) -> None:
    """``simulate --out NAME.csv`` replaces NAME.json only when it is a sidecar euc-sim wrote."""
    import json

    from euc_sim.errors import BadOutputPath
    from euc_sim.io import sidecar_paths

    meta, truth = sidecar_paths(out)
    ours = False
    if meta.is_file():
        try:
            doc = json.loads(meta.read_text(encoding="utf-8"))
            ours = isinstance(doc, dict) and str(doc.get("source", "")).startswith("euc-sim")
        except (OSError, ValueError):
            ours = False
        if not ours:
            raise BadOutputPath(f"--out {out}: its sidecar {meta} exists and is not one euc-sim wrote; "
                                "refusing to overwrite it (move it or choose another name)")
    if truth.is_file() and not ours:
        raise BadOutputPath(f"--out {out}: {truth} exists without an euc-sim sidecar beside it; "
                            "refusing to overwrite it")


def internal_error_report(args, exc: BaseException) -> Path | None:
    """Write ``exc``'s traceback to a file; return its path (None when no file could be written).

    The file goes to the folder of the command's first output when that folder exists,
    else to :func:`tempfile.gettempdir`.
    """
    import os
    import platform
    import tempfile
    import traceback

    from euc_sim import __version__

    folders = []
    for _, path in output_files(args) if hasattr(args, "command") else []:
        folders.append(path.parent if str(path.parent) else Path("."))
    if getattr(args, "command", None) in FOLDER_OUT and getattr(args, "out", None):
        folders.append(Path(args.out))
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
    """``--report DIR`` before any work: a folder (or nothing yet) that can take ``names``.

    Returns
    -------
    pathlib.Path
        The folder.

    Raises
    ------
    NotADirectoryError, OSError
        naming the path.
    """
    from pathlib import Path

    from euc_sim.io import check_writable

    out = Path(folder)
    if out.exists() and not out.is_dir():
        raise NotADirectoryError(f"--report {out}: exists and is not a folder")
    for name in names:
        check_writable(out / name)
    return out

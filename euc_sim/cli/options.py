"""One option name per idea across the commands, and the old names kept for one release.

The names: ``--workers N`` (processes), ``--quiet`` (no progress on stderr), ``--n-boot N``
(bootstrap replicates), ``--report DIR`` (the folder a command writes its figures or page
into), ``--out FILE`` (always a file) and ``--out-dir DIR`` (always a folder), ``--effect``
(repeatable).  Every numeric option is declared with :func:`bounded` (a finite number in a
stated range, the range shown in ``--help`` by :class:`BoundsHelpFormatter`); ``--workers``
with :func:`workers`, bounded by this machine's cores.  An old name is registered by :func:`deprecated`: hidden from ``--help``, and
using it prints one line on stderr (``euc-sim: --jobs is deprecated; use --workers``).
tests/cli/test_option_names.py reads every parser and holds the commands to these names.
"""

from __future__ import annotations

import argparse
import math
import os
import sys
from typing import Callable, Iterable

__all__ = ["DeprecatedOption", "deprecated", "one_of", "bounded", "workers", "max_workers",
           "BoundsHelpFormatter"]


def bounded(lo: float, hi: float, integer: bool = False, unit: str = "", checked: bool = True):
    """An argparse type: a finite number (an integer with ``integer``) in ``[lo, hi]``.

    The error (one line, exit 2) names the option, the range and the value; the range is
    kept as ``parse.bounds`` and ``parse.span`` (e.g. ``[0, 1] s``) for ``--help``
    (:class:`BoundsHelpFormatter`).  With ``checked=False`` only the number is parsed: the
    command checks the range where the API checks it too (``euc-sim ride``'s request).
    """
    what = "an integer" if integer else "a number"
    span = f"[{lo:g}, {hi:g}]{' ' + unit if unit else ''}"

    def parse(text: str):
        try:
            value = int(text) if integer else float(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"expected {what} in {span}, got {text!r}") from None
        if checked and not (math.isfinite(value) and lo <= value <= hi):
            raise argparse.ArgumentTypeError(f"expected {what} in {span}, got {text}")
        return value

    parse.__name__ = "integer" if integer else "number"
    parse.bounds = (lo, hi)
    parse.span = span
    return parse


def max_workers() -> int:
    """Most worker processes or threads a command starts: this machine's cores (at least 2).

    More CPU-bound workers than cores only multiply memory (each holds its own model and
    data) without finishing sooner.
    """
    try:
        cores = len(os.sched_getaffinity(0))
    except AttributeError:          # not on Linux
        cores = os.cpu_count() or 1
    return max(2, cores)


def workers():
    """argparse type of ``--workers``: an integer from 1 to :func:`max_workers`."""
    return bounded(1, max_workers(), integer=True, unit="(this machine's cores)")


class BoundsHelpFormatter(argparse.HelpFormatter):
    """``--help`` that states the range of every :func:`bounded` option after its text."""

    def _get_help_string(self, action):
        text = action.help or ""
        span = getattr(action.type, "span", None)
        if span and text != argparse.SUPPRESS and span not in text:
            text = f"{text}; range {span}" if text else f"range {span}"
        return text


class DeprecatedOption(argparse.Action):
    """An old option name, hidden from ``--help``: prints the deprecation note, then acts.

    With a ``target`` (the replacement's action) each value is handed to it, so the old
    name does exactly what the new one does; without, the value is stored under the old
    option's own ``dest`` (an old option whose meaning the new one does not keep, such as
    ``--plot FILE`` beside ``--report DIR``).
    """

    def __init__(self, option_strings, dest, replacement: str, target: argparse.Action | None = None,
                 convert: Callable[[object], Iterable] | None = None, note: str | None = None, **kwargs):
        kwargs["help"] = argparse.SUPPRESS
        super().__init__(option_strings, dest, **kwargs)
        self.replacement = replacement
        self.target = target
        self.convert = convert
        self.note = note or f"use {replacement}"

    def __call__(self, parser, namespace, values, option_string=None):
        print(f"euc-sim: {option_string} is deprecated; {self.note}", file=sys.stderr)
        if self.target is None:
            setattr(namespace, self.dest, True if self.nargs == 0 else values)
            return
        for value in (self.convert(values) if self.convert else [values]):
            self.target(parser, namespace, value, self.replacement)


def deprecated(p, old: str, replacement: str, *, convert: Callable[[object], Iterable] | None = None,
               **own) -> argparse.Action:
    """Register ``old`` on ``p`` (a parser or one of its groups) as a deprecated name.

    Parameters
    ----------
    p : argparse.ArgumentParser or argument group
        Where ``replacement`` is registered.
    old, replacement : str
        Option strings, e.g. ``"--jobs"`` and ``"--workers"``.
    convert : callable, optional
        Old value → the values handed one by one to the replacement (``--effects A,B`` →
        ``--effect A``, ``--effect B``).
    **own
        ``add_argument`` keywords (``dest``, ``metavar``, ``type``, ``nargs=0`` for a flag, and
        ``note``, the text after "is deprecated;") of an old option that keeps its own value
        instead of forwarding it.

    Returns
    -------
    argparse.Action
        The registered :class:`DeprecatedOption`.
    """
    if own:
        return p.add_argument(old, action=DeprecatedOption, replacement=replacement, **own)
    target = p._option_string_actions[replacement]
    return p.add_argument(old, action=DeprecatedOption, replacement=replacement, target=target,
                          convert=convert, dest=target.dest, nargs=target.nargs, type=target.type,
                          metavar=target.metavar, default=argparse.SUPPRESS)


def one_of(values: Iterable[str]) -> str:
    """Metavar that shows a fixed set of values in ``--help``, as argparse shows ``choices``.

    For options whose value the command checks itself (one line naming the option, exit 2),
    so ``--help`` never shows a bare placeholder such as ``NOISE``: ``{paper,none}``.
    """
    return "{" + ",".join(values) + "}"

"""One option name per idea across the commands, and old names kept for one release.

``--workers N``, ``--quiet``, ``--n-boot N``, ``--report DIR``, ``--out FILE``, ``--out-dir DIR``,
``--effect`` (repeatable).  Numeric options use :func:`bounded` (range shown in ``--help`` by
:class:`BoundsHelpFormatter`); an old name is registered by :func:`deprecated`.
tests/cli/test_option_names.py holds the commands to these names.
"""

from __future__ import annotations

import argparse
import math
import os
import sys
from typing import Iterable

__all__ = ["DeprecatedOption", "deprecated", "one_of", "bounded", "workers", "max_workers",
           "BoundsHelpFormatter"]


def bounded(lo: float, hi: float, integer: bool = False, unit: str = "", checked: bool = True):
    """An argparse type: a finite number (an integer with ``integer``) in ``[lo, hi]``.

    The error names the range and the value; ``parse.bounds`` and ``parse.span`` feed ``--help``.
    With ``checked=False`` only the number is parsed (the command checks the range, as the API does).
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
    """Most worker processes or threads a command starts: this machine's cores (at least 2)."""
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
    """An old option name, hidden from ``--help``: prints the deprecation note, then hands its value to ``target``
    (the replacement's action)."""

    def __init__(self, option_strings, dest, replacement: str, target: argparse.Action, **kwargs):
        kwargs["help"] = argparse.SUPPRESS
        super().__init__(option_strings, dest, **kwargs)
        self.replacement = replacement
        self.target = target

    def __call__(self, parser, namespace, values, option_string=None):
        print(f"euc-sim: {option_string} is deprecated; use {self.replacement}", file=sys.stderr)
        self.target(parser, namespace, values, self.replacement)


def deprecated(p, old: str, replacement: str) -> argparse.Action:
    """Register ``old`` on ``p`` (a parser or argument group) as a deprecated name of ``replacement``.

    Parameters
    ----------
    p : argparse.ArgumentParser or argument group
    old, replacement : str
        Option strings, e.g. ``"--out"`` and ``"--out-dir"``.
    """
    target = p._option_string_actions[replacement]
    return p.add_argument(old, action=DeprecatedOption, replacement=replacement, target=target,
                          dest=target.dest, nargs=target.nargs, type=target.type,
                          metavar=target.metavar, default=argparse.SUPPRESS)


def one_of(values: Iterable[str]) -> str:
    """Metavar showing a fixed set of values, ``{paper,none}``, for an option the command checks itself."""
    return "{" + ",".join(values) + "}"

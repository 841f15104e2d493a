"""One option name per idea across the commands, and the old names kept for one release.

The names: ``--workers N`` (processes), ``--quiet`` (no progress on stderr), ``--n-boot N``
(bootstrap replicates), ``--report DIR`` (the folder a command writes its figures or page
into), ``--out FILE`` (always a file) and ``--out-dir DIR`` (always a folder), ``--effect``
(repeatable).  An old name is registered by :func:`deprecated`: hidden from ``--help``, and
using it prints one line on stderr (``euc-sim: --jobs is deprecated; use --workers``).
tests/cli/test_option_names.py reads every parser and holds the commands to these names.
"""

from __future__ import annotations

import argparse
import sys
from typing import Callable, Iterable

__all__ = ["DeprecatedOption", "deprecated", "one_of"]


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

"""Helpers shared by the command modules: usage errors, messages to people, ``--param`` parsing."""

from __future__ import annotations

import sys
from typing import Sequence

EXIT_OK, EXIT_FAIL, EXIT_USAGE = 0, 1, 2


class UsageError(ValueError):
    """A command-line argument that cannot be used; the message names it."""


def say(msg: str) -> None:
    print(msg, file=sys.stderr, flush=True)


def parse_params(items: Sequence[str] | None):
    """``--param NAME=VALUE`` pairs → Params (Table 3 for the rest)."""
    from euc_sim.model.parameters import Params

    return Params.from_mapping(param_values(items))


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

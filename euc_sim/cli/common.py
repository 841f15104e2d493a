"""Helpers shared by the command modules: usage errors, messages to people, ``--param`` parsing."""

from __future__ import annotations

import sys
from typing import Sequence

EXIT_OK, EXIT_FAIL, EXIT_USAGE = 0, 1, 2


class UsageError(ValueError):
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

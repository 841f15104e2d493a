"""The project's exceptions: a user's mistake, told apart from the program's.

Every check on what a user gave (a command-line option, a parameter, a recording, a
log, a sidecar, an output path) raises one of these.  The command line turns them
into one line naming the culprit and exit code 2; any other exception is a bug in
euc-sim and becomes an internal error (exit 1, the traceback in a file).

They subclass :class:`ValueError` and :class:`TypeError` (as python-control's
``ControlArgument`` and ``ControlDimension`` do), so code that catches those keeps
working.
"""

from __future__ import annotations

from pathlib import Path

__all__ = ["InputError", "InputTypeError", "BadInputFile", "BadOutputPath", "describe"]


def describe(value, limit: int = 40) -> str:
    """A short ``repr`` of an actual value for a message (long ones are cut)."""
    text = repr(value)
    return text if len(text) <= limit else text[: limit - 3] + "..."


class InputError(ValueError):
    """A value the user gave cannot be used; the message names it, what was expected and what came.

    Parameters
    ----------
    message : str
        The whole message, or (with ``expected``) the name of the argument.
    expected : str, optional
        What the argument should be; with it the message reads
        ``"NAME: expected EXPECTED, got ACTUAL"``.
    actual : object, optional
        What the argument was.
    """

    def __init__(self, message: str, expected: str | None = None, actual=None):
        self.argument, self.expected, self.actual = message, expected, actual
        if expected is not None:
            message = f"{message}: expected {expected}, got {describe(actual)}"
        super().__init__(message)


class InputTypeError(InputError, TypeError):
    """An argument of the wrong kind (a list where an object was expected, text for a number)."""


class BadInputFile(InputError):
    """A file the user gave cannot be read as what it should be.

    Parameters
    ----------
    path : path or str
        The file; alone, the whole message (which then names the file itself).
    problem : str, optional
        What is wrong, naming the column, row or field.
    """

    path = None

    def __init__(self, path, problem: str | None = None):
        if problem is not None:
            self.path = Path(path)
        super().__init__(str(path) if problem is None else f"{self.path}: {problem}")


class BadOutputPath(InputError):
    """An output path that must not be written: it is an input, a folder, or another run's file."""

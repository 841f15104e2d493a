"""The project's exceptions: a user's mistake, told apart from the program's.

Every check on what a user gave raises one of these; the command line turns them into one
line naming the culprit and exit code 2 (any other exception is an internal error, exit 1).
They subclass :class:`ValueError` (and :class:`TypeError`), so callers catching those keep
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
    """A value the user gave cannot be used; the message names it.

    With ``expected``, ``message`` is the argument's name and the message reads
    ``"NAME: expected EXPECTED, got ACTUAL"``.
    """

    def __init__(self, message: str, expected: str | None = None, actual=None):
        self.argument, self.expected, self.actual = message, expected, actual
        if expected is not None:
            message = f"{message}: expected {expected}, got {describe(actual)}"
        super().__init__(message)


class InputTypeError(InputError, TypeError):
    """An argument of the wrong kind (a list where an object was expected, text for a number)."""


class BadInputFile(InputError):
    """A file the user gave cannot be read as what it should be: ``path`` alone is the whole
    message, else ``problem`` names the column, row or field.
    """

    path = None

    def __init__(self, path, problem: str | None = None):
        if problem is not None:
            self.path = Path(path)
        super().__init__(str(path) if problem is None else f"{self.path}: {problem}")


class BadOutputPath(InputError):
    """An output path that must not be written: it is an input, a folder, or another run's file."""

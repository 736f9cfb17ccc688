"""The two kinds of failure a user can see.

* ``InputError``  — the scenario or the command line is wrong (exit code 2).
* ``RunFailure``  — the numbers went wrong during a run (exit code 1); what was valid is kept.
"""

from __future__ import annotations


class InputError(Exception):
    """Bad input: ``where`` names the TOML key (or line, or option); the message says the fix."""

    exit_code = 2

    def __init__(self, where: str, message: str) -> None:
        super().__init__(f"{where}: {message}" if where else message)
        self.where = where
        self.message = message

    def __reduce__(self):  # picklable across worker processes
        return (type(self), (self.where, self.message))


class RunFailure(Exception):
    """A run stopped (non-finite state, step budget exhausted): the valid samples are kept, in
    ``trajectory`` where the Python API raised it."""

    exit_code = 1

    def __init__(self, message: str, trajectory: object | None = None) -> None:
        super().__init__(message)
        self.trajectory = trajectory

    def __reduce__(self):  # picklable across worker processes (the trajectory stays behind)
        return (type(self), (str(self),))


def first_line(exc: BaseException, typed: bool = False) -> str:
    """The first line of ``exc``'s message (libraries raise long help texts), or its type's name
    when it has none; ``typed``: "Type: line"."""
    text = str(exc).strip()
    line = text.splitlines()[0] if text else ""
    if typed:
        return f"{type(exc).__name__}: {line}" if line else type(exc).__name__
    return line or type(exc).__name__


def valid_samples(count: int, where: object) -> str:
    """"the N valid samples are in WHERE" (a stopped run's message), "sample is" for one."""
    return f"the {count:,} valid sample{'s are' if count != 1 else ' is'} in {where}"


class Interrupted(RunFailure):
    """The user stopped the run (Ctrl-C); what was computed is kept."""

    exit_code = 130

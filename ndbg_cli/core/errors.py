"""Errors and exit codes.

Every error a user can cause is an :class:`InputError` whose message is one line naming the
file, the part and the problem. The CLI maps exceptions to the exit codes below.
"""

from __future__ import annotations

#: Success.
EXIT_OK = 0
#: The analysis ran and found a violation a CI gate asked about (``--fail-on``); an
#: interference with ``--interference error`` is an input error instead.
EXIT_VIOLATION = 1
#: Usage or input error: bad command line, unreadable or invalid input.
EXIT_INPUT = 2
#: Internal error (a bug in ndbg: please report it with ``--debug``).
EXIT_INTERNAL = 3


class NdbgError(Exception):
    """Base class of the errors ndbg raises on purpose."""

    exit_code = EXIT_INTERNAL

    def __init__(self, problem: str, *, file: str | None = None, part: str | None = None,
                 line: int | None = None):
        self.problem = problem
        self.file = file
        self.part = part
        self.line = line
        super().__init__(self.message)

    @property
    def message(self) -> str:
        """The one-line message: ``FILE[:LINE]: part 'ID': PROBLEM``."""
        where = []
        if self.file:
            where.append(f"{self.file}:{self.line}" if self.line else self.file)
        if self.part:
            where.append(f"part '{self.part}'")
        text = " ".join(self.problem.split())  # one line, whatever the cause said
        return ": ".join(where + [text])

    def record(self) -> dict:
        """The error as a JSON-ready record (used in batch reports)."""
        return {"code": self.exit_code, "kind": type(self).__name__, "message": self.message,
                "file": self.file, "part": self.part, "line": self.line}


class InputError(NdbgError):
    """The input (a file, a manifest, a mesh, an option) is invalid."""

    exit_code = EXIT_INPUT


class InterferenceError(InputError):
    """Parts interpenetrate and the policy says that is an error."""

"""Errors and exit codes.

Every error a user can cause is an :class:`InputError` whose message is one line naming the
file, the part and the problem. The CLI maps exceptions to the exit codes below.
"""

from __future__ import annotations

from collections.abc import Callable

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
        return self._located(self.file)

    def _located(self, file: str | None) -> str:
        """The one-line message naming ``file``."""
        where = []
        if file:
            where.append(f"{file}:{self.line}" if self.line else file)
        if self.part:
            where.append(f"part '{self.part}'")
        text = " ".join(self.problem.split())  # one line, whatever the cause said
        return ": ".join(where + [text])

    def record(self, path: Callable[[str], str | None] | None = None) -> dict:
        """The error as a JSON-ready record (used in batch reports).

        Parameters
        ----------
        path : callable, optional
            How the record writes the file, in ``file`` and in the message (e.g.
            :func:`ndbg_cli.core.paths.portable`); as raised when not given.

        Returns
        -------
        dict
            ``code``, ``kind``, ``message``, ``file``, ``part``, ``line``.
        """
        file = path(self.file) if path is not None and self.file else self.file
        return {"code": self.exit_code, "kind": type(self).__name__,
                "message": self._located(file), "file": file, "part": self.part,
                "line": self.line}


class InputError(NdbgError):
    """The input (a file, a manifest, a mesh, an option) is invalid."""

    exit_code = EXIT_INPUT


class InterferenceError(InputError):
    """Parts interpenetrate and the policy says that is an error."""

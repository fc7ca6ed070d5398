"""The size limit of one assembly: triangles read, counted as the loader reads them.

An assembly above :data:`~ndbg_cli.core.constants.MAX_TRIANGLES` (``--max-triangles``) fails
with a one-line :class:`~ndbg_cli.core.errors.InputError` as soon as the files read so far
pass it, before the rest is read and long before the contact stage, whose memory grows with
the triangles: rather than driving the machine into swap or being killed.
"""

from __future__ import annotations

from numbers import Integral

from ..core.errors import InputError


class TriangleBudget:
    """The triangles read for one assembly so far, against ``limit`` (``None``: no limit).

    Parameters
    ----------
    limit : int or None
        The most triangles the assembly may have.
    file : str
        The assembly's file, as the error names it.
    parts : int
        How many parts (mesh files or bodies) the assembly has, to say how far the reading
        got when it stops early.

    Examples
    --------
    >>> budget = TriangleBudget(100, "a.yaml", parts=2)
    >>> budget.add(60, done=1)
    >>> try:
    ...     budget.add(60, done=2)
    ... except InputError as exc:
    ...     print(exc)
    a.yaml: 120 triangles exceed the limit of 100 (raise it with --max-triangles)
    """

    def __init__(self, limit: int | None, file: str, parts: int) -> None:
        self.limit = limit
        self.file = file
        self.parts = parts
        self.count = 0

    def add(self, triangles: int, done: int) -> None:
        """Count ``triangles`` more, read with the ``done``-th part; raise the input error
        if the count is now above the limit.

        Parameters
        ----------
        triangles : int
            The triangles of the part (or parts) just read.
        done : int
            How many of the assembly's parts are read, these included.
        """
        self.count += int(triangles)
        if self.limit is None or self.count <= self.limit:
            return
        early = f" in its first {done:,} of {self.parts:,} parts" if done < self.parts else ""
        raise InputError(f"{self.count:,} triangles{early} exceed the limit of "
                         f"{self.limit:,} (raise it with --max-triangles)", file=self.file)


def check_max_triangles(value: object, file: str) -> None:
    """An input error unless ``value`` is ``None`` or an integer of at least 1.

    Parameters
    ----------
    value : object
        The ``max_triangles`` argument of :func:`ndbg_cli.io.loaders.load`.
    file : str
        The file being loaded, as the error names it.
    """
    if value is None:
        return
    if isinstance(value, bool) or not isinstance(value, Integral) or value < 1:
        raise InputError(f"max triangles must be an integer >= 1, got {value!r}", file=file)


__all__ = ["TriangleBudget", "check_max_triangles"]

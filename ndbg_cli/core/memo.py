"""A value computed once per object and kept on it (:func:`kept`), for the frozen dataclasses
the stages pass along (an assembly, an NDBG), whose fields cannot be assigned."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any, TypeVar

__all__ = ["kept"]

T = TypeVar("T")


def kept(obj: Any, name: str, make: Callable[[], T]) -> T:
    """``make()``, computed the first time and kept on ``obj`` as the attribute ``name``
    (beside its fields, frozen or not: not one of them, so not compared, hashed or printed).
    ``make`` must not return None.

    >>> from dataclasses import dataclass
    >>> @dataclass(frozen=True)
    ... class Box:
    ...     side: float
    >>> b = Box(2.0)
    >>> kept(b, "_area", lambda: b.side ** 2), kept(b, "_area", lambda: 0.0)
    (4.0, 4.0)
    """
    got = obj.__dict__.get(name)
    if got is None:
        got = make()
        object.__setattr__(obj, name, got)
    return got

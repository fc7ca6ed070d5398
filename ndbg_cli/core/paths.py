"""Paths as reports write them: relative to a root folder, with ``/`` separators.

A report names the files it was made from (the assembly's ``source``, each part's, the
``file`` of warnings and errors). Written as they were given or resolved, they hold the
folder the checkout happens to be in, so the same checkout analysed from two folders gives
two reports. :func:`portable` writes each path relative to a *root*, the current working
folder unless told otherwise (``ndbg analyze --root DIR``, :attr:`Options.root
<ndbg_cli.core.options.Options.root>`): the same checkout copied anywhere and analysed from
its root gives byte-identical reports. A path outside the root stays absolute (there is no
portable way to name it), also with ``/`` separators.
"""

from __future__ import annotations

import os
from pathlib import Path


def report_root(root: str | os.PathLike[str] | None = None) -> Path:
    """The folder report paths are written relative to: ``root`` made absolute (symbolic
    links resolved), else the current working folder.

    Parameters
    ----------
    root : str or PathLike, optional
        The folder; ``None`` for the current working folder.

    Returns
    -------
    Path
        An absolute path.
    """
    return Path(root).resolve() if root is not None else Path.cwd()


def portable(path: str | os.PathLike[str] | None, root: str | os.PathLike[str] | None = None
             ) -> str | None:
    """``path`` as a report writes it: relative to ``root`` (:func:`report_root`) with
    ``/`` separators when it lies inside it, else absolute (with ``/`` separators).

    A relative ``path`` is taken from the current working folder, as the file system takes
    it. Both the path as written and the file it resolves to (symbolic links followed) are
    tried, so a root or a checkout reached through a link still gives relative paths.

    Parameters
    ----------
    path : str or PathLike, optional
        A file or folder; ``None`` or ``""`` is returned as it is (no file).
    root : str or PathLike, optional
        The folder paths are relative to; ``None`` for the current working folder.

    Returns
    -------
    str or None
        The path to write.

    Examples
    --------
    >>> portable("/work/ndbg/assemblies/bell.yaml", "/work/ndbg")
    'assemblies/bell.yaml'
    >>> portable("/elsewhere/bell.yaml", "/work/ndbg")
    '/elsewhere/bell.yaml'
    """
    if path is None or str(path) == "":
        return None if path is None else ""
    given = Path(os.path.abspath(path))
    base = report_root(root)
    roots = (base, Path(os.path.abspath(root))) if root is not None else (base,)
    for candidate in (given, _resolved(given)):
        for r in roots:
            if candidate.is_relative_to(r):
                return candidate.relative_to(r).as_posix()
    return given.as_posix()


def portable_source(source: str | None, model: str, root: str | os.PathLike[str] | None = None
                    ) -> str | None:
    """A part's ``source`` (or a warning's ``file``) as a report writes it: :func:`portable`,
    of the file part only of a ``FILE#NODE`` source read from the model file ``model`` (the
    node name, which may hold a ``/``, is kept as it is).

    Examples
    --------
    >>> portable_source("/w/m/arm.glb#hand/left", "/w/m/arm.glb", "/w")
    'm/arm.glb#hand/left'
    """
    if source and model and source.startswith(model + "#"):
        return f"{portable(model, root)}{source[len(model):]}"
    return portable(source, root)


def _resolved(path: Path) -> Path:
    """``path`` with symbolic links resolved, or as it is if that fails (a link loop)."""
    try:
        return path.resolve()
    except (OSError, RuntimeError):
        return path


__all__ = ["report_root", "portable", "portable_source"]

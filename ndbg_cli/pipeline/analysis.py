"""The pipeline as a library: load -> contacts -> blocking graphs -> planning -> report.

``analyze(assembly)`` returns the report as a plain dict (JSON-ready after
:func:`ndbg_cli.report.document.clean`); ``analyze_path(path)`` loads first and turns an input error
into an error record, which is what a batch needs.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from pathlib import Path

from .._version import __version__
from ..core.assembly import Assembly
from ..core.errors import NdbgError
from ..core.options import Options
from ..core.paths import portable, portable_source, report_root
from ..core.stack import allow_deep_trees
from ..io.loaders import load
from ..report.consistency import contradictions
from ..report.consistency import warnings as consistency_warnings
from ..report.document import REPORT_SCHEMA
from ..report.tolerance import warnings as tolerance_warnings


def assembly_section(asm: Assembly, root: str | Path | None = None) -> dict:
    """The report's ``assembly`` section: name, source, units, tolerance, parts.

    Parameters
    ----------
    asm : Assembly
        The assembly.
    root : str or Path, optional
        The folder the sources are written relative to (:func:`ndbg_cli.core.paths.portable`;
        default: the current working folder).

    Returns
    -------
    dict
        The section.
    """
    parts = []
    for p in asm.parts:
        c = p.check
        parts.append({
            "id": p.id, "source": portable_source(p.source, asm.source, root), "hash": p.hash,
            "fixed": p.fixed,
            "triangles": c.triangles, "vertices": c.vertices, "watertight": c.watertight,
            "winding_consistent": c.winding_consistent, "volume": c.volume, "area": c.area,
            "bounds": [list(c.bounds[0]), list(c.bounds[1])],
        })
    joints = [{"type": j.type, "parts": list(j.parts), "axis": list(j.axis),
               "point": list(j.point), "pitch": j.pitch} for j in asm.joints]
    return {"name": asm.name, "source": portable(asm.source, root), "units": asm.units,
            "dimension": asm.dimension, "tolerance": asm.length_tolerance,
            "tolerance_source": "explicit" if asm.tolerance is not None else "default",
            "base": asm.base, "parts": parts, "joints": joints,
            "triangles": sum(p.check.triangles for p in asm.parts)}


def analyze(asm: Assembly, options: Options = Options()) -> dict:
    """Run every stage selected by ``options`` on ``asm``; return the report dict.

    Parameters
    ----------
    asm : Assembly
        A loaded assembly (:func:`ndbg_cli.load`).
    options : Options
        What to compute; the CLI's defaults. Its ``root`` is the folder the report's paths
        are written relative to (default: the current working folder; a path outside it
        stays absolute).

    Returns
    -------
    dict
        The report (JSON-ready after :func:`ndbg_cli.report.document.clean`; schema:
        ``ndbg schema``).

    Examples
    --------
    >>> import ndbg_cli
    >>> report = ndbg_cli.analyze(ndbg_cli.load("assemblies/hover.yaml"))
    >>> [(s["moved"], s["direction"]) for s in report["plan"]["sequence"]]
    [(['puck'], [0.0, 0.0, -1.0]), (['bridge'], [0.0, 0.0, -1.0])]
    >>> report["plan"]["verified"]["value"]  # each step leaves by one translation
    True
    """
    timings: dict[str, float] = {}
    # a product coming apart one part at a time has trees as deep as its parts
    allow_deep_trees(len(asm.parts))
    root = report_root(options.root)
    report: dict = {
        "schema": REPORT_SCHEMA,
        "tool": {"name": "ndbg", "version": __version__},
        "assembly": assembly_section(asm, root),
        "options": {"motion": options.motion, "interference": options.interference,
                    "strategy": options.strategy,
                    "threads_as_cylinders": options.threads_as_cylinders,
                    "connected": options.connected, "max_partitions": options.max_partitions},
        "warnings": [d.record() for d in asm.diagnostics],
    }
    from .stages import run_stages

    sections, more = run_stages(asm, options, timings)
    report.update(sections)
    report["warnings"] += [d.record() for d in more]
    report["timings"] = timings if options.timings else {}
    # answers that contradict each other are said so (ndbg check --self lists the same)
    report["warnings"] += consistency_warnings(contradictions(report), asm.source or None)
    # answers a turn or another export may change within the tolerances are said to be so
    report["warnings"] += tolerance_warnings(report, asm.source or None)
    for w in report["warnings"]:
        w["file"] = portable_source(w.get("file"), asm.source, root)
    return report


def analyze_path(path: str | Path, options: Options = Options(),
                 on_loaded: Callable[[Path, Assembly], None] | None = None) -> dict:
    """Load ``path`` and analyse it. An input error becomes an error record (never raised),
    so one bad assembly in a batch does not stop the others. ``on_loaded(path, assembly)``
    is called with the loaded assembly (the pictures of ``ndbg analyze --html`` draw its
    meshes without reading the model again)."""
    from .stages import load_kernels

    t0 = time.perf_counter()
    try:
        asm = load(path, units=options.units, tolerance=options.tolerance,
                   allow_outside_paths=options.allow_outside_paths,
                   mesh_tolerance=options.mesh_tolerance, load_timeout=options.load_timeout,
                   load_memory=options.load_memory, progress=options.progress,
                   max_triangles=options.max_triangles,
                   # with a second core, the kernels' load (numba's start, when not built
                   # ahead of time) and the stages' imports while a native reader reads
                   meanwhile=load_kernels if options.workers > 1 else None)
    except NdbgError as exc:
        return error_record(path, exc, options.root)
    t_load = time.perf_counter() - t0
    if on_loaded is not None:
        on_loaded(Path(path), asm)
    try:
        report = analyze(asm, options)
    except NdbgError as exc:
        return error_record(path, exc, options.root)
    if options.timings:
        report["timings"]["load_s"] = t_load
    return report


def error_record(path: str | Path, exc: NdbgError, root: str | Path | None = None) -> dict:
    """A report standing for an assembly that could not be analysed.

    Parameters
    ----------
    path : str or Path
        The input.
    exc : NdbgError
        Why it could not be analysed.
    root : str or Path, optional
        The folder the paths (``source``, the error's ``file`` and message) are written
        relative to, as in a report (default: the current working folder).

    Returns
    -------
    dict
        ``schema``, ``tool``, ``source`` and ``error``.
    """
    base = report_root(root)
    return {"schema": REPORT_SCHEMA, "tool": {"name": "ndbg", "version": __version__},
            "source": portable(path, base),
            "error": exc.record(path=lambda f: portable_source(f, str(path), base))}

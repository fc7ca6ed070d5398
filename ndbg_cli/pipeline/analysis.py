"""The pipeline as a library: load -> contacts -> blocking graphs -> planning -> report.

``analyze(assembly)`` returns the report as a plain dict (JSON-ready after
:func:`ndbg_cli.report.document.clean`); ``analyze_path(path)`` loads first and turns an input error
into an error record, which is what a batch needs.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from pathlib import Path

from .._version import __version__
from ..core.assembly import Assembly
from ..core.errors import NdbgError
from ..io.loaders import load
from ..planning.andor import WORK_LIMIT
from ..report.document import REPORT_SCHEMA

MOTIONS = ("all", "translation", "infinite", "generalized")
STRATEGIES = ("shortest", "linear", "fewest-directions", "balanced")
INTERFERENCE = ("error", "warn", "ignore")


@dataclass(frozen=True)
class Options:
    """What to compute and how; every field has the CLI's default."""

    motion: str = "all"
    units: str | None = None
    tolerance: float | None = None
    allow_outside_paths: bool = False
    interference: str = "warn"  # error | warn | ignore
    timings: bool = False
    strategy: str = "shortest"  # shortest | linear | fewest-directions | balanced
    threads_as_cylinders: bool = False
    connected: bool = False  # partitionings: both sides connected in the contact graph
    max_partitions: int = 1000  # partitionings listed per family (the report says truncated)
    region_limit: int | None = 2000  # regions listed per family (counts stay complete)
    max_nodes: int = 2_000  # AND/OR graph budget: subassemblies per search
    max_work: int = WORK_LIMIT  # AND/OR graph budget: work units per search (andor.WORK_LIMIT)
    time_limit: float | None = None  # AND/OR graph budget: seconds per search (None: none)
    infinite_budget: int = 1_000_000  # facing triangle pairs beyond which `infinite` is skipped
    cache: str | None = None  # per-part-pair result cache directory (None: no cache)
    workers: int = 1  # processes for one assembly's infinite NDBG (results do not depend on it)
    progress: bool = False  # a bar on stderr (a TTY) over the infinite NDBG's part pairs


#: What each setting of a config file must be, with the types and ranges of the CLI's options:
#: ``(kind, low, low_excluded)``, kind ``bool``, ``int``, ``float`` (finite), ``str`` or a
#: tuple of choices, ``low`` the smallest value allowed. A field typed ``... | None`` may also
#: be ``null``.
SETTINGS: dict[str, tuple] = {
    "motion": (MOTIONS,), "interference": (INTERFERENCE,), "strategy": (STRATEGIES,),
    "units": (str,), "cache": (str,), "tolerance": (float, 0, True),
    "time_limit": (float, 0, True), "max_partitions": (int, 1), "region_limit": (int, 1),
    "max_nodes": (int, 1), "max_work": (int, 1), "infinite_budget": (int, 0),
    "allow_outside_paths": (bool,),
    "timings": (bool,), "threads_as_cylinders": (bool,), "connected": (bool,),
}


def setting_problem(name: str, value: object, *, null: bool = True) -> str | None:
    """Why ``value`` cannot be the setting ``name`` (``expected ..., got ...``), or ``None``
    if it can. YAML types are taken as they are: ``'5'`` is not an integer, ``maybe`` is not
    a boolean, ``.nan`` is not a number. ``null``: whether ``None`` may be offered (a config
    file's ``null``; a command-line flag has no such spelling)."""
    import dataclasses
    import math

    kind, low, excluded = (SETTINGS[name] + (None, False))[:3]
    nullable = null and "None" in str({f.name: f.type for f in dataclasses.fields(Options)}[name])
    if value is None and nullable:
        return None
    if isinstance(kind, tuple):
        ok, what = value in kind, "one of " + ", ".join(kind)
    elif kind is bool:
        ok, what = isinstance(value, bool), "true or false"
    elif kind is str:
        ok, what = isinstance(value, str) and value != "", "a non-empty string"
    else:
        number = (int,) if kind is int else (int, float)
        what = "an integer" if kind is int else "a finite number"
        ok = isinstance(value, number) and not isinstance(value, bool) and math.isfinite(value)
        if low is not None:
            what += f" {'>' if excluded else '>='} {low}"
            ok = ok and (value > low if excluded else value >= low)
    if nullable:
        what += " or null"
    return None if ok else f"expected {what}, got {value!r}"


def read_config(path: str | Path) -> dict:
    """Settings from a YAML config file (see ``configs/default.yaml``): a mapping whose keys
    are :class:`Options` fields. Unknown keys and bad values are input errors."""
    import dataclasses

    from ..core.errors import InputError
    from ..io.manifest import read_located

    doc = read_located(path, "config", "a config must be a YAML mapping", empty_ok=True)
    data = doc.data
    # ``workers`` comes from --jobs only (one assembly; a batch spreads its assemblies), and
    # ``progress`` from --quiet (one assembly; a batch shows its own bar)
    fields = {f.name for f in dataclasses.fields(Options)} - {"workers", "progress"}
    unknown = sorted(set(map(str, data)) - fields)
    if unknown:
        raise InputError(f"unknown setting '{unknown[0]}' (known: {', '.join(sorted(fields))})",
                         file=str(path), line=doc.line((unknown[0],)))
    for name, value in data.items():
        problem = setting_problem(name, value)
        if problem:
            raise doc.error((name,), problem)
    if data.get("units") is not None:
        from ..core.units import canonical_unit

        try:
            data["units"] = canonical_unit(data["units"], file=str(path))
        except InputError as exc:
            raise doc.error(("units",), exc.problem) from None
    return data


def assembly_section(asm: Assembly) -> dict:
    """The report's ``assembly`` section: name, source, units, tolerance, parts."""
    parts = []
    for p in asm.parts:
        c = p.check
        parts.append({
            "id": p.id, "source": p.source, "hash": p.hash, "fixed": p.fixed,
            "triangles": c.triangles, "vertices": c.vertices, "watertight": c.watertight,
            "winding_consistent": c.winding_consistent, "volume": c.volume, "area": c.area,
            "bounds": [list(c.bounds[0]), list(c.bounds[1])],
        })
    joints = [{"type": j.type, "parts": list(j.parts), "axis": list(j.axis),
               "point": list(j.point), "pitch": j.pitch} for j in asm.joints]
    return {"name": asm.name, "source": asm.source, "units": asm.units,
            "dimension": asm.dimension, "tolerance": asm.length_tolerance,
            "tolerance_source": "explicit" if asm.tolerance is not None else "default",
            "base": asm.base, "parts": parts, "joints": joints,
            "triangles": sum(p.check.triangles for p in asm.parts)}


def analyze(asm: Assembly, options: Options = Options()) -> dict:
    """Run every stage selected by ``options`` on ``asm``; return the report dict."""
    timings: dict[str, float] = {}
    report: dict = {
        "schema": REPORT_SCHEMA,
        "tool": {"name": "ndbg", "version": __version__},
        "assembly": assembly_section(asm),
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
    return report


def analyze_path(path: str | Path, options: Options = Options()) -> dict:
    """Load ``path`` and analyse it. An input error becomes an error record (never raised),
    so one bad assembly in a batch does not stop the others."""
    t0 = time.perf_counter()
    try:
        asm = load(path, units=options.units, tolerance=options.tolerance,
                   allow_outside_paths=options.allow_outside_paths)
    except NdbgError as exc:
        return error_record(path, exc)
    t_load = time.perf_counter() - t0
    try:
        report = analyze(asm, options)
    except NdbgError as exc:
        return error_record(path, exc)
    if options.timings:
        report["timings"]["load_s"] = t_load
    return report


def error_record(path: str | Path, exc: NdbgError) -> dict:
    """A report standing for an assembly that could not be analysed."""
    return {"schema": REPORT_SCHEMA, "tool": {"name": "ndbg", "version": __version__},
            "source": str(path), "error": exc.record()}

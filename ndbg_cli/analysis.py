"""The pipeline as a library: load -> contacts -> blocking graphs -> planning -> report.

``analyze(assembly)`` returns the report as a plain dict (JSON-ready after
:func:`ndbg_cli.report.clean`); ``analyze_path(path)`` loads first and turns an input error
into an error record, which is what a batch needs.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from pathlib import Path

from . import __version__
from .assembly import Assembly
from .errors import NdbgError
from .loaders import load
from .report import REPORT_SCHEMA

MOTIONS = ("all", "translation", "infinite", "generalized")
STRATEGIES = ("shortest", "linear", "fewest-directions", "balanced")


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
    time_limit: float = 2.0  # AND/OR graph budget: seconds per search
    infinite_budget: int = 1_000_000  # facing triangle pairs beyond which `infinite` is skipped
    cache: str | None = None  # per-part-pair result cache directory (None: no cache)
    workers: int = 1  # processes for one assembly's infinite NDBG (results do not depend on it)
    progress: bool = False  # a bar on stderr (a TTY) over the infinite NDBG's part pairs


def read_config(path: str | Path) -> dict:
    """Settings from a YAML config file (see ``configs/default.yaml``): a mapping whose keys
    are :class:`Options` fields. Unknown keys and bad values are input errors."""
    import dataclasses

    import yaml

    from .errors import InputError

    try:
        data = yaml.safe_load(Path(path).read_text(encoding="utf-8")) or {}
    except (OSError, yaml.YAMLError) as exc:
        raise InputError(f"cannot read config: {exc}".splitlines()[0], file=str(path)) from None
    if not isinstance(data, dict):
        raise InputError("a config must be a YAML mapping", file=str(path))
    # ``workers`` comes from --jobs only (one assembly; a batch spreads its assemblies), and
    # ``progress`` from --quiet (one assembly; a batch shows its own bar)
    fields = {f.name for f in dataclasses.fields(Options)} - {"workers", "progress"}
    unknown = sorted(set(data) - fields)
    if unknown:
        raise InputError(f"unknown setting '{unknown[0]}' (known: {', '.join(sorted(fields))})",
                         file=str(path))
    if data.get("motion", "all") not in MOTIONS:
        raise InputError(f"motion must be one of {', '.join(MOTIONS)}", file=str(path))
    if data.get("interference", "warn") not in ("error", "warn", "ignore"):
        raise InputError("interference must be error, warn or ignore", file=str(path))
    if data.get("strategy", "shortest") not in STRATEGIES:
        raise InputError(f"strategy must be one of {', '.join(STRATEGIES)}", file=str(path))
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
    from .pipeline import run_stages

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

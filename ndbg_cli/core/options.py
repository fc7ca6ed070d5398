"""What to compute and how: the :class:`Options` of every stage, with the CLI's defaults, and
the type and range of each setting (checked alike for a config file and the command line)."""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

from .constants import LOAD_MEMORY_GIB, LOAD_TIMEOUT_S, MAX_TRIANGLES, WORK_LIMIT

if TYPE_CHECKING:  # the pools are imported by the stages that use them
    from .pools import Mapper

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
    mesh_tolerance: float | None = None  # STEP/IGES deflection, assembly unit (None: default)
    load_timeout: float | None = LOAD_TIMEOUT_S  # seconds a native reader may take (None: any)
    load_memory: float | None = LOAD_MEMORY_GIB  # GiB a native reader may use (None: any)
    max_triangles: int | None = MAX_TRIANGLES  # triangles of one assembly (None: any)
    interference: str = "warn"  # error | warn | ignore
    timings: bool = False
    strategy: str = "shortest"  # shortest | linear | fewest-directions | balanced
    threads_as_cylinders: bool = False
    connected: bool = False  # partitionings: both sides connected in the contact graph
    max_partitions: int = 1000  # partitionings listed per family (the report says truncated)
    region_limit: int | None = 2000  # regions listed per family (counts stay complete)
    max_nodes: int = 2_000  # AND/OR graph budget: subassemblies per search
    max_work: int = WORK_LIMIT  # AND/OR graph budget: work units per search
    time_limit: float | None = None  # AND/OR graph budget: seconds per search (None: none)
    infinite_budget: int = 1_000_000  # facing triangle pairs beyond which `infinite` is skipped
    cache: str | None = None  # per-part-pair result cache directory (None: no cache)
    workers: int = 1  # processes and threads for one assembly (results do not depend on it)
    # where one assembly's per-pair work runs (contacts, the infinite NDBG's blocked sets): None,
    # ``workers`` forked processes here; a dask cluster (pipeline.cluster.ClusterMapper) for
    # ``analyze --scheduler`` on one assembly. Results do not depend on it
    mapper: Mapper | None = None
    progress: bool = False  # a bar on stderr (a TTY) over the infinite NDBG's part pairs
    # each contact record holds its points and their normals (``--detail summary`` writes
    # their count alone: without pictures the CLI does not build them)
    contact_points: bool = True
    # the folder the report's paths (sources, files) are written relative to (None: the
    # current working folder; ndbg_cli.core.paths.portable)
    root: str | None = None


#: What each setting of a config file must be, with the types and ranges of the CLI's options:
#: ``(kind, low, low_excluded)``, kind ``bool``, ``int``, ``float`` (finite), ``str`` or a
#: tuple of choices, ``low`` the smallest value allowed. A field typed ``... | None`` may also
#: be ``null``.
SETTINGS: dict[str, tuple] = {
    "motion": (MOTIONS,), "interference": (INTERFERENCE,), "strategy": (STRATEGIES,),
    "units": (str,), "cache": (str,), "tolerance": (float, 0, True),
    "mesh_tolerance": (float, 0, True), "load_timeout": (float, 0, True),
    "load_memory": (float, 0, True), "max_triangles": (int, 1),
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



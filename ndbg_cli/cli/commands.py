"""The ``ndbg`` commands besides ``analyze`` and ``check``: one assembly's contacts, one
direction's DBGs, the parts to withdraw to free some, model conversion, report diffs, the
schemas and the cache. Registered on the :func:`ndbg_cli.cli.main.cli` group when that module
is imported; each a thin layer over the library, as there."""

from __future__ import annotations

import json
import sys
from pathlib import Path

import click

from .._version import __version__
from ..core.constants import GENERALIZED, INFINITE, INFINITESIMAL
from ..core.errors import EXIT_INPUT, EXIT_OK, EXIT_VIOLATION
from ._app import (
    CONTEXT,
    STATE,
    cannot_write,
    check_writable,
    cli,
    common_load_options,
    fail,
    global_options,
    load_settings,
)


@cli.command(context_settings=CONTEXT)
@click.argument("model", type=click.Path())
@click.option("--out", required=True, type=click.Path(), help="Folder to write into.")
@click.option("--force", is_flag=True, help="Overwrite an existing manifest.")
@common_load_options
def convert(model, out, force, units, tolerance, allow_outside_paths, mesh_tolerance,
            load_timeout, load_memory, max_triangles) -> None:
    """Write a model's parts as meshes plus a manifest (an editable project).

    \b
    Example:
      ndbg convert ../shared/data/as1/as1-oc-214.stp --out as1/
    """
    from ..io.formats import prestart_reader

    prestart_reader(model)  # its start-up overlaps the imports below
    from ..io.convert import convert_assembly
    from ..io.loaders import load

    # as analyze --out: a folder that cannot be written is an input error (exit 2) naming
    # it, found before the model is read (a STEP file can take minutes)
    check_writable(out, Path(out))
    asm = load(model, units=units, tolerance=tolerance, allow_outside_paths=allow_outside_paths,
               **load_settings(mesh_tolerance, load_timeout, load_memory, max_triangles))
    try:
        manifest = convert_assembly(asm, Path(out), force=force)
    except OSError as exc:  # e.g. out/meshes is a file, or the disk is full
        raise cannot_write(out, exc) from None
    if not STATE.quiet:
        click.echo(f"wrote {manifest} ({len(asm)} parts, units {asm.units})", err=True)
    click.echo(str(manifest))


@cli.command(context_settings=CONTEXT)
@click.argument("assembly", type=click.Path())
@click.option("--format", "fmt", type=click.Choice(["text", "json"]), default="text",
              show_default=True)
@click.option("--interference", type=click.Choice(["error", "warn", "ignore"]), default="warn",
              show_default=True, help="What interpenetrating parts are.")
@common_load_options
def contacts(assembly, fmt, interference, units, tolerance, allow_outside_paths, mesh_tolerance,
             load_timeout, load_memory, max_triangles) -> None:
    """Print the contact table: touching pairs, kind, area, normals, and interferences.

    Normals point out of part A into part B, in the assembly frame and unit.

    \b
    Example:
      ndbg contacts ../shared/data/as1/as1-oc-214.stp --format json
    """
    from ..io.formats import prestart_reader

    prestart_reader(assembly)  # its start-up overlaps the imports below
    from ..contacts.contacts3d import analyze_contacts
    from ..contacts.interference import check_interference_policy
    from ..io.loaders import load
    from ..report.contacts import contacts_section, contacts_text
    from ..report.document import CONTACTS_SCHEMA, dumps

    asm = load(assembly, units=units, tolerance=tolerance,
               allow_outside_paths=allow_outside_paths,
               **load_settings(mesh_tolerance, load_timeout, load_memory, max_triangles))
    if asm.dimension != 3:
        fail(f"{assembly}: contacts of 2D assemblies are listed by `ndbg analyze`", EXIT_INPUT)
    result = analyze_contacts(asm, tolerance=tolerance)
    warnings = check_interference_policy(asm, result, interference)
    if fmt == "json":  # paths relative to the current folder, as in a report
        from ..core.paths import portable, portable_source

        doc = {"schema": CONTACTS_SCHEMA, "tool": {"name": "ndbg", "version": __version__},
               "assembly": {"name": asm.name, "source": portable(asm.source),
                            "units": asm.units},
               **contacts_section(asm, result),
               "warnings": [{**d.record(), "file": portable_source(d.file, asm.source)}
                            for d in list(asm.diagnostics) + warnings]}
        doc["contact_stats"].pop("timings_s", None)
        click.echo(dumps(doc), nl=False)
    else:
        click.echo("\n".join(contacts_text(asm, result)))
    if not STATE.quiet:  # on stderr for JSON too, as analyze does
        for w in warnings:
            click.echo(f"ndbg: warning: {w.message}", err=True)


@cli.command(context_settings=CONTEXT)
@click.argument("assembly", type=click.Path())
@click.option("--direction", "direction", required=True,
              help="Translation direction as x,y,z (x,y in 2D); need not be unit length.")
@click.option("--motion", type=click.Choice(["all", "translation", "infinite"]), default="all",
              show_default=True)
@click.option("--format", "fmt", type=click.Choice(["text", "json"]), default="text",
              show_default=True)
@common_load_options
def query(assembly, direction, motion, fmt, units, tolerance, allow_outside_paths,
          mesh_tolerance, load_timeout, load_memory, max_triangles) -> None:
    """Print the DBG for one translation direction, computed directly from the geometry.

    translation: from the contacts (local blocking); infinite: a sweep test of every part
    pair (part j blocks i if i's sweep to infinity along d meets j's interior).

    \b
    Example:
      ndbg query assemblies/hover.yaml --direction 0,0,1
    """
    from ..io.formats import prestart_reader

    prestart_reader(assembly)  # its start-up overlaps the imports below
    import numpy as np

    from ..io.loaders import load
    from ..report.document import QUERY_SCHEMA, dumps

    asm = load(assembly, units=units, tolerance=tolerance,
               allow_outside_paths=allow_outside_paths,
               **load_settings(mesh_tolerance, load_timeout, load_memory, max_triangles))
    try:
        d = np.array([float(x) for x in direction.split(",")])
    except ValueError:
        d = np.zeros(0)
    if len(d) != asm.dimension or not np.all(np.isfinite(d)) or np.linalg.norm(d) == 0:
        fail(f"--direction must be {asm.dimension} comma-separated numbers, not all zero "
             f"(got '{direction}')", EXIT_INPUT)
    d = d / np.linalg.norm(d)
    doc: dict = {"schema": QUERY_SCHEMA, "assembly": asm.name, "direction": d.tolist(),
                 "dbgs": {}}
    if motion in ("all", "translation"):
        from ..core.constants import ANGLE_TOL_RAD
        from ..ndbg.infinitesimal.build import contact_pairs, dbg_at

        if asm.dimension == 3:
            from ..contacts.contacts3d import analyze_contacts

            ca = analyze_contacts(asm, tolerance=tolerance)
            g = dbg_at(len(asm), contact_pairs(asm, ca), d, ca.angle_tolerance)
        else:
            g = dbg_at(len(asm), contact_pairs(asm), d, ANGLE_TOL_RAD)
        doc["dbgs"][INFINITESIMAL] = _dbg_record(asm, g)
    if motion in ("all", "infinite"):
        from ..ndbg.infinite.sweep import dbg_at as sweep_dbg

        doc["dbgs"][INFINITE] = _dbg_record(asm, sweep_dbg(asm, d))
    if fmt == "json":
        click.echo(dumps(doc), nl=False)
        return
    click.echo(f"{asm.name}: direction ({', '.join(f'{x:+.4f}' for x in d)})")
    for fam, rec in doc["dbgs"].items():
        click.echo(f"  {fam.replace('_', ' ')}: {len(rec['arcs'])} arcs "
                   "(i -> j: j blocks i)")
        for i, j in rec["arcs"]:
            click.echo(f"    {i} -> {j}")
        free = ", ".join("{" + ", ".join(s) + "}" for s in rec["free_sets"][:10])
        click.echo(f"    free along d: {free or 'nothing'}"
                   + (" ..." if len(rec["free_sets"]) > 10 else ""))


def _dbg_record(asm, g) -> dict:
    from ..ndbg.dbg import bits, minimal_free_subsets

    full = (1 << len(asm)) - 1
    return {"arcs": [[asm.ids[i], asm.ids[j]] for i, j in g.arcs()],
            "free_sets": [[asm.ids[i] for i in bits(s)]
                          for s in minimal_free_subsets(g, full) if s != full]}


@cli.command(context_settings=CONTEXT)
@click.argument("assembly", type=click.Path())
@click.argument("parts", nargs=-1, required=True)
@click.option("--motion", type=click.Choice(["auto", "translation", "infinite"]),
              default="auto", show_default=True, help="Blocking graphs to plan with: auto = "
              "infinite translations when within --infinite-budget, else infinitesimal.")
@click.option("--format", "fmt", type=click.Choice(["text", "json"]), default="text",
              show_default=True)
@click.option("--max-nodes", type=click.IntRange(1), default=20_000, show_default=True,
              help="Exact search budget (remaining assemblies explored).")
@click.option("--infinite-budget", type=click.IntRange(0), default=1_000_000,
              show_default=True)
@common_load_options
def remove(assembly, parts, motion, fmt, max_nodes, infinite_budget, units, tolerance,
           allow_outside_paths, mesh_tolerance, load_timeout, load_memory, max_triangles) -> None:
    """Which parts must be withdrawn, and in what order, before PARTS can be removed.

    Exact (fewest parts withdrawn; steps merged greedily) when the search fits --max-nodes;
    otherwise a goal-directed heuristic, with a lower bound on the minimum.

    \b
    Example:
      ndbg remove assemblies/bell.yaml gong_post
    """
    from ..io.formats import prestart_reader

    prestart_reader(assembly)  # its start-up overlaps the imports below
    from ..io.loaders import load
    from ..ndbg.infinite.blocked_sets import triangle_pairs
    from ..ndbg.infinite.build import build_infinite
    from ..ndbg.infinite.sweep import SweepChecker
    from ..ndbg.infinitesimal.build import infinitesimal_ndbg
    from ..planning.andor import Budget
    from ..planning.removal import remove as remove_parts
    from ..report.document import REMOVE_SCHEMA, dumps

    asm = load(assembly, units=units, tolerance=tolerance,
               allow_outside_paths=allow_outside_paths,
               **load_settings(mesh_tolerance, load_timeout, load_memory, max_triangles))
    unknown = [p for p in parts if p not in asm.ids]
    if unknown:
        fail(f"{assembly}: no part '{unknown[0]}' (parts: {', '.join(asm.ids[:12])}"
             + (" ..." if len(asm) > 12 else "") + ")", EXIT_INPUT)
    if motion == "auto":
        motion = ("infinite" if asm.dimension == 2 or triangle_pairs(asm) <= infinite_budget
                  else "translation")
    nd = build_infinite(asm) if motion == "infinite" else infinitesimal_ndbg(asm)
    target = nd.mask(parts)
    base = asm.index(asm.base) if asm.base is not None and asm.base not in parts else None
    res = remove_parts(nd, target, base=base, budget=Budget(max_nodes=max_nodes))
    # steps the direct sweep test frees along a nearby coordinate axis state that axis
    sweep = SweepChecker(asm) if nd.family != GENERALIZED else None
    sec = {"schema": REMOVE_SCHEMA, "assembly": asm.name, "family": nd.family,
           **res.section(nd, None if sweep is None else sweep.frees)}
    if fmt == "json":
        click.echo(dumps(sec), nl=False)
    else:
        click.echo(_removal_text(sec))
    sys.exit(EXIT_OK if res.found else EXIT_VIOLATION)


def _removal_text(sec: dict) -> str:
    def along(s: dict) -> str:
        d = s.get("removal_direction")
        return "along (" + ", ".join(f"{x:+.3g}" for x in d) + ")" if d else "by its motion"

    target = ", ".join(sec["target"])
    kind = "minimum" if sec["exact"] else f"heuristic; at least {sec['lower_bound']}"
    lines = [f"{sec['assembly']}: to remove {{{target}}} ({sec['family'].replace('_', ' ')})"]
    if not sec["found"]:
        lines.append("  no withdrawal sequence frees it")
        return "\n".join(lines)
    lines.append(f"  withdraw {sec['count']} part(s) first ({kind}):")
    for s in sec["steps"]:
        lines.append(f"  {s['step']}. remove {{{', '.join(s['withdraw'])}}} {along(s)}")
    lines.append(f"  then remove {{{target}}} {along(sec['final'])}")
    return "\n".join(lines)


@cli.command("diff", context_settings=CONTEXT)
@click.argument("old", type=click.Path())
@click.argument("new", type=click.Path())
@click.option("--fail-on", type=click.Choice(["worse", "any", "never"]), default="worse",
              show_default=True, help="Exit 1 when something got worse, changed at all, "
              "or never.")
@click.option("--format", "fmt", type=click.Choice(["text", "json"]), default="text",
              show_default=True)
@global_options
def diff_cmd(old, new, fail_on, fmt) -> None:
    """What changed between two analyses that a designer cares about.

    OLD and NEW are reports from `ndbg analyze` (a JSON report, a batch JSON, a JSON Lines
    stream or an --out-dir folder). Classes lost or gained, measures that got worse, parts
    added, removed or modified, new interferences.

    \b
    Example:
      ndbg diff main/bell.json branch/bell.json --fail-on worse
    """
    from ..report.diff import diff_sets, fails, read_reports
    from ..report.document import dumps

    changes = diff_sets(read_reports(old), read_reports(new))
    if fmt == "json":
        click.echo(dumps({"schema": "ndbg.diff/1", "old": old, "new": new,
                          "worse": sum(c.grade == "worse" for c in changes),
                          "changes": [c.record() for c in changes]}), nl=False)
    else:
        for c in changes:
            click.echo(c.line())
        if not changes:
            click.echo("no change a designer cares about")
    sys.exit(EXIT_VIOLATION if fails(changes, fail_on) else EXIT_OK)


@cli.command(context_settings=CONTEXT)
@click.argument("which", type=click.Choice(["report", "manifest"]), default="report")
@global_options
def schema(which) -> None:
    """Print the JSON Schema of the report (default) or of the manifest.

    \b
    Example:
      ndbg schema report > report.schema.json
    """
    from ..core.schemas import manifest_schema, report_schema

    doc = report_schema() if which == "report" else manifest_schema()
    click.echo(json.dumps(doc, indent=2, sort_keys=True))


@cli.group(context_settings=CONTEXT)
def cache() -> None:
    """The per-part-pair result cache: its size, or empty it.

    \b
    Its size is bounded: after each analyze / check run the least recently used entries go
    once it holds more than $NDBG_CACHE_MAX_MB megabytes (default 2048; 0: no limit).
    """


def _cache_dir_option(f):
    """``--cache DIR`` of the ``cache`` commands, passed as ``directory`` (the default cache
    directory when not given)."""
    def resolve(ctx, param, value):
        from ..core.cache import default_dir

        return value or str(default_dir())

    return click.option("--cache", "directory", type=click.Path(file_okay=False),
                        default=None, callback=resolve,
                        help="Cache directory (default: $NDBG_CACHE_DIR, else ~/.cache/ndbg)."
                        )(f)


@cache.command("info", context_settings=CONTEXT)
@_cache_dir_option
@global_options
def cache_info(directory) -> None:
    """Print the cache's directory, entries and size per stage (JSON)."""
    from ..core.cache import max_bytes, usage

    try:
        limit = max_bytes()
    except ValueError as exc:
        fail(str(exc), EXIT_INPUT)
    doc = {"directory": directory, "limit_bytes": limit, **usage(directory)}
    click.echo(json.dumps(doc, indent=2, sort_keys=True))


@cache.command("clear", context_settings=CONTEXT)
@_cache_dir_option
@global_options
def cache_clear(directory) -> None:
    """Remove every entry of the cache."""
    from ..core.cache import clear

    removed, freed = clear(directory)
    if not STATE.quiet:
        click.echo(f"ndbg: {removed} cache entries ({freed / 2**20:.1f} MB) removed from "
                   f"{directory}", err=True)

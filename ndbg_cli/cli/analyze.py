"""``ndbg analyze`` and ``ndbg check``: a thin layer over :mod:`ndbg_cli.pipeline`. The
stages are imported when a command runs, not when the CLI starts."""

from __future__ import annotations

import dataclasses
import json
import os
import re
import sys
from pathlib import Path

import click

from .._version import __version__
from ..core.errors import EXIT_INPUT, EXIT_OK, EXIT_VIOLATION, InputError
from ..core.files import one_line, write_atomic
from ..core.options import MOTIONS, STRATEGIES, Options, setting_problem
from ..report.detail import DETAILS, summarize
from ._app import (
    CONTEXT,
    DEFAULTS,
    STATE,
    cache_options,
    cannot_write,
    check_writable,
    cli,
    common_load_options,
    fail,
    range_type,
    root_option,
    with_root,
)
from ._pictures import Pictures


@cli.command(context_settings=CONTEXT)
@click.argument("paths", nargs=-1, required=True, type=click.Path())
@click.option("--format", "fmt", type=click.Choice(["text", "json", "jsonl"]), default="text",
              show_default=True, help="Report format on stdout; jsonl: one compact report per "
              "line, streamed in input order.")
@click.option("--out", type=click.Path(), help="Write reports here instead of stdout: a file "
              "for one assembly (in JSON or JSONL when it ends with .json or .jsonl and no "
              "--format is given), a directory (one NAME.json each, as --out-dir) for several "
              "or when it ends with a slash or names an existing directory.")
@click.option("--out-dir", type=click.Path(file_okay=False), help="Write one NAME.json per "
              "assembly (atomically, as each completes) plus index.json into this folder. "
              "index.json is removed when the run starts and written when it ends: it exists "
              "only after a complete run and lists that run's reports (each entry's 'report' "
              "is its file).")
@click.option("-j", "--jobs", type=click.IntRange(1), default=None,
              help="Worker processes: one assembly each in a batch; for a single assembly, "
              "its part pairs (contacts, infinite-translation NDBG) and its AND/OR graph "
              "(default: the number of cores; with --scheduler local, the cluster's "
              "workers). Same reports.")
@click.option("--scheduler", metavar="ADDRESS", help="Run on a dask.distributed cluster: "
              "a batch one assembly per task; a single assembly here, with its part pairs "
              "(contacts, infinite-translation NDBG) on the cluster. tcp://HOST:PORT of a "
              "running scheduler (its workers must see the input files at the same paths), or "
              "'local' to start one on this machine with --jobs worker processes. Same "
              "reports, same order. Needs pip install 'ndbg-cli[dask]'.")
@click.option("--motion", type=click.Choice(MOTIONS), default="all", show_default=True,
              help="Motion family of the blocking graphs.")
@click.option("--interference", type=click.Choice(["error", "warn", "ignore"]), default="warn",
              show_default=True, help="What interpenetrating parts are.")
@click.option("--timings", is_flag=True, help="Record wall-clock timings in the report "
              "(makes it differ from run to run).")
@click.option("--detail", type=click.Choice(DETAILS), default=DETAILS[0],
              show_default=True, help="What a JSON report holds: every answer, the counts and "
              "the first 20 entries of long lists (summary), or also every contact point, "
              "every region and DBG of each NDBG and every partitioning listed (full). Text "
              "reports and pictures are the same either way.")
@click.option("--config", "config", type=click.Path(), help="YAML settings file (see "
              "configs/default.yaml); options given on the command line win.")
@click.option("--strategy", type=click.Choice(STRATEGIES), default="shortest",
              show_default=True, help="How the reported assembly tree is chosen.")
@click.option("--threads-as-cylinders", is_flag=True,
              help="Read declared screw joints as plain cylinders (threads ignored).")
@click.option("--connected", is_flag=True, help="Only partitionings whose two sides are each "
              "connected in the contact graph in the lists (the plan always prefers them; "
              "classes keep the paper's definitions).")
@click.option("--max-partitions", type=range_type("max_partitions"),
              default=DEFAULTS.max_partitions, show_default=True,
              help="Partitionings listed per motion family (the report says when it cut).")
@click.option("--max-nodes", type=range_type("max_nodes"), default=DEFAULTS.max_nodes,
              show_default=True,
              help="AND/OR graph budget: subassemblies per search (a graph with more is "
              "cut at once; the measures then come from anytime searches).")
@click.option("--max-work", type=range_type("max_work"), default=DEFAULTS.max_work,
              show_default=True,
              help="AND/OR graph budget: work units per search (DBGs induced on the "
              "subassemblies expanded and regions listed; counted, so reports stay "
              "reproducible).")
@click.option("--time-limit", type=range_type("time_limit"), default=DEFAULTS.time_limit,
              help="AND/OR graph budget: seconds per search (off by default: a search cut "
              "by the clock makes the report depend on the machine's speed and load).")
@click.option("--infinite-budget", type=range_type("infinite_budget"),
              default=DEFAULTS.infinite_budget,
              show_default=True, help="Facing triangle pairs beyond which the infinite-"
              "translation NDBG is skipped (with a warning).")
@click.option("--html", type=click.Path(), help="Also write the HTML report: one "
              "self-contained page (opens offline) with the 3D view, the plan played as a "
              "disassembly, the direction spheres, the tree and the tables. A file for one "
              "assembly; in a batch (several assemblies or --out-dir) a folder: NAME.html "
              "each (NAME as the report's JSON file) plus index.html listing the verdicts.")
@click.option("--glb", type=click.Path(), help="Also write the exploded assembly as glTF "
              "binary: one node per part, the plan as animations (the whole disassembly, "
              "and each step's pose). A file for one assembly, a folder (NAME.glb) in a "
              "batch.")
@click.option("--png", type=click.Path(file_okay=False), help="Also write images into this "
              "folder: plan.png (exploded-view strip), sphere-FAMILY.png, tree.png; in a "
              "batch one subfolder NAME/ each.")
@click.option("--svg", type=click.Path(file_okay=False), help="As --png, as SVG.")
@root_option
@common_load_options
@cache_options
@click.pass_context
def analyze(ctx, paths, fmt, out, out_dir, jobs, scheduler, motion, interference, timings, detail,
            config, strategy, threads_as_cylinders, connected, max_partitions, max_nodes, max_work,
            time_limit, infinite_budget, html, glb, png, svg, root, units, tolerance,
            allow_outside_paths, mesh_tolerance, load_timeout, load_memory, max_triangles) -> None:
    """Analyse assemblies: manifests, model files (STEP, GLB, ...) or folders.

    A folder holding manifests is a batch (one report each); a folder holding only meshes is
    one assembly. One bad assembly in a batch gives an error record; the others complete.

    \b
    Examples:
      ndbg analyze assemblies/bell.yaml --format json
      ndbg analyze assemblies/bell.yaml --html bell.html --glb bell.glb --png pictures/
      ndbg analyze assemblies/ --out-dir reports/ --html reports/
      ndbg analyze assemblies/ --format jsonl --scheduler tcp://10.0.0.5:8786
    """
    from ..io.formats import prestart_reader

    if len(paths) == 1:  # a native reader's start-up overlaps the imports below
        prestart_reader(paths[0])
    from ..core.progress import progress
    from ..io.formats import discover
    from ..pipeline.batch import Interrupted, default_jobs, run_batch, run_batch_dask
    from ..report.document import dumps
    from ..report.text import render

    options = _options(ctx, config, motion=motion, units=units, tolerance=tolerance,
                       allow_outside_paths=allow_outside_paths, interference=interference,
                       timings=timings, strategy=strategy,
                       threads_as_cylinders=threads_as_cylinders, connected=connected,
                       max_partitions=max_partitions, max_nodes=max_nodes, max_work=max_work,
                       time_limit=time_limit, infinite_budget=infinite_budget,
                       mesh_tolerance=mesh_tolerance, load_timeout=load_timeout,
                       load_memory=load_memory, max_triangles=max_triangles)
    options = dataclasses.replace(with_root(options, root), progress=not STATE.quiet)
    targets: list[Path] = []
    for p in paths:
        if not Path(p).exists():
            fail(f"{p}: no such file or directory", EXIT_INPUT)
        targets.extend(discover(p))
    batch = len(targets) > 1 or any(Path(p).is_dir() and discover(p) != [Path(p)] for p in paths)
    out_dir, out_file, where = _outputs(out, out_dir, batch)
    pictures = Pictures(html, glb, png, svg, batch=batch or out_dir is not None)
    # a summary holds the contacts' point counts alone; the pictures draw the points
    options = dataclasses.replace(options, contact_points=detail == "full" or pictures.wanted)
    pictures.check()
    if out_file is not None and ctx.get_parameter_source("fmt").name == "DEFAULT":
        # --out report.json means JSON (a text report under that name was a trap)
        fmt = {".json": "json", ".jsonl": "jsonl"}.get(out_file.suffix.lower(), fmt)
    inputs = _input_files(targets)
    if out_file is not None:
        _refuse_input(where, out_file, inputs)
    jobs = jobs or default_jobs()
    reports: list[dict] = []
    names: set[str] = set()
    code = EXIT_OK
    faults = CacheFaults()
    if scheduler:
        stream = run_batch_dask(targets, options, scheduler, jobs, debug=STATE.debug,
                                on_loaded=pictures.keep if pictures.wanted else None)
    else:
        stream = run_batch(targets, options, jobs, debug=STATE.debug,
                           on_loaded=pictures.keep if pictures.wanted else None)
    # the warnings are in a text report on stdout; elsewhere a human would not see them
    summary = not STATE.quiet and (out_dir is not None or out_file is not None or fmt != "text")
    try:
        if out_dir is not None:  # once the run can start (a dask scheduler was reached)
            _drop_index(where, out_dir, inputs)
        for k, r in enumerate(progress(stream, len(targets), "analyzing", quiet=STATE.quiet)):
            faults.add(r)
            code = max(code, _exit_code(r))
            stem = _report_name(r, names)
            pictures.write(r, targets[k], stem, options)  # from the full report
            written = summarize(r) if detail == "summary" else r  # what JSON holds
            if "error" in r:
                _note(f"ndbg: error: {one_line(r['error']['message'])}")
            elif summary:
                for line in _warning_lines(r):
                    _note(line)
            if out_dir is not None:
                path = out_dir / f"{stem}.json"
                _refuse_input(where, path, inputs | _part_files(r, options.root))
                _write(where, path, dumps(written))
                reports.append(_index_entry(written, path.name))
            elif fmt == "jsonl" and out_file is None:
                click.echo(_jsonl_line(written), nl=False)
            else:
                reports.append(r if fmt == "text" else written)
    except Interrupted:
        tail = " (no index.json: the run is incomplete)" if out_dir is not None else ""
        click.echo(f"ndbg: terminated; reports written so far are complete{tail}", err=True)
        sys.exit(143)
    finally:  # an error writing a report: the workers are ended now, not at exit
        stream.close()
    pictures.finish()
    if out_dir is not None:
        _refuse_input(where, out_dir / "index.json", inputs)
        _write(where, out_dir / "index.json", dumps(_batch_doc(reports)))
    elif out_file is not None:
        r = reports[0]
        _refuse_input(where, out_file, _part_files(r, options.root))
        text = {"json": dumps, "jsonl": _jsonl_line, "text": render}[fmt](r)
        _write(where, out_file, text)
    elif fmt == "json":
        doc = _batch_doc(reports) if batch else reports[0]
        click.echo(dumps(doc), nl=False)
    elif fmt == "text":
        click.echo("\n".join(render(r) for r in reports), nl=False)
    faults.tell(options.cache)
    _trim_cache(options.cache)
    sys.exit(code)


#: Warnings summarised on stderr per assembly; the rest are counted (all are in the report).
MAX_WARNING_LINES = 20


def _warning_lines(report: dict) -> list[str]:
    """One ``ndbg: warning: NAME: MESSAGE [PART]`` line per warning of ``report`` (at most
    :data:`MAX_WARNING_LINES`, then how many more), for stderr: a report written to a file,
    a folder or as JSON carries its warnings (interferences, skipped stages, open meshes)
    where the person running ndbg does not look."""
    from ..report.document import identity

    name = identity(report)[0]
    warnings = report.get("warnings") or []
    lines = [f"ndbg: warning: {name}: {w['message']}"
             + (f" [{w['part']}]" if w.get("part") else "")
             for w in warnings[:MAX_WARNING_LINES]]
    if len(warnings) > MAX_WARNING_LINES:
        lines.append(f"ndbg: warning: {name}: ... and {len(warnings) - MAX_WARNING_LINES} "
                     "more (see the report)")
    return lines


def _note(line: str) -> None:
    """Print ``line`` on stderr, first clearing the progress bar's line on a terminal (the
    bar is drawn again at the next assembly)."""

    if sys.stderr.isatty():
        click.echo("\r" + " " * 70 + "\r", nl=False, err=True)
    click.echo(line, err=True)


def _jsonl_line(report: dict) -> str:
    """One compact JSON line (with its newline) of a report, for ``--format jsonl``."""
    from ..report.document import clean

    return json.dumps(clean(report), sort_keys=True, separators=(",", ":"),
                      ensure_ascii=False) + "\n"


def _outputs(out: str | None, out_dir: str | None, batch: bool
             ) -> tuple[Path | None, Path | None, str]:
    """Where ``analyze`` writes: ``(folder, file, the path as given)``, at most one of the
    first two. A folder for ``--out-dir``, and for ``--out`` with several assemblies, naming
    an existing folder, or ending with a slash; else ``--out`` is a file. The place is
    checked before any analysis: one that cannot be written is an input error (exit 2)."""
    if out_dir or (out and (batch or out.endswith(("/", os.sep)) or Path(out).is_dir())):
        where = out_dir or out
        folder = Path(where)
        check_writable(where, folder)
        return folder, None, where
    if out:
        check_writable(out, Path(out).parent)
        return None, Path(out), out
    return None, None, ""


def _write(where: str, path: Path, text: str) -> None:
    """:func:`write_atomic` of ``text`` to ``path``; an error names ``where`` (exit 2)."""
    try:
        write_atomic(path, text)
    except OSError as exc:
        raise cannot_write(where, exc) from None


def _drop_index(where: str, out_dir: Path, inputs: set[Path]) -> None:
    """Remove an earlier run's ``index.json`` from ``out_dir`` before this run writes any
    report; the run writes its own (atomically) once every report is written.

    A rerun into the same folder that is killed or interrupted part-way would otherwise
    leave the old index describing reports that are partly this run's: whoever reads the
    folder (a CI job, ``ndbg check DIR``, which takes it for a folder of reports only when
    it holds an index.json) could not tell. So an index, when there is one, is always the
    complete list of one run's reports. Report files of an earlier run that this one does
    not rewrite stay in the folder; they are not in the index."""
    index = out_dir / "index.json"
    _refuse_input(where, index, inputs)
    try:
        index.unlink()
    except FileNotFoundError:
        pass
    except OSError as exc:  # a folder named index.json, a read-only folder
        raise cannot_write(where, exc) from None


def _input_files(targets: list[Path]) -> set[Path]:
    """The resolved input files (a folder target: the files in it), that no output may
    replace."""
    files = set()
    for t in targets:
        for f in (t.rglob("*") if t.is_dir() else [t]):
            files.add(f.resolve())
    return files


def _part_files(report: dict, root: str | None) -> set[Path]:
    """The resolved files a report's parts were read from (mesh files of a manifest; their
    sources are relative to ``root``, the folder of the report's paths)."""
    parts = (report.get("assembly") or {}).get("parts") or []
    return {(Path(root or ".") / p["source"]).resolve() for p in parts
            if "#" not in str(p.get("source"))}


def _refuse_input(where: str, path: Path, inputs: set[Path]) -> None:
    """An input error if writing ``path`` would replace one of the ``inputs``."""
    if path.resolve() in inputs:
        raise InputError(f"cannot write {where}: {path} is an input of this run")


class CacheFaults:
    """What the cache skipped in a run, summed over its reports (each analysis, in any
    worker process, hands its cache's faults over in its report dict, taken out here before
    anything is written), and told once at the end: the answers are the same without the
    cache, so these are warnings, on stderr only."""

    def __init__(self) -> None:
        self.unreadable = self.unwritten = 0
        self.why: str | None = None

    def add(self, report: dict) -> None:
        from ..core.cache import CACHE_FAULTS

        got = report.pop(CACHE_FAULTS, None) or {}
        self.unreadable += got.get("unreadable", 0)
        self.unwritten += got.get("unwritten", 0)
        self.why = self.why or got.get("write_error")

    def tell(self, directory: str | None) -> None:
        if STATE.quiet or not directory:
            return
        if self.unreadable:
            click.echo(f"ndbg: warning: cache {directory}: {self.unreadable} unreadable "
                       "entr(ies) (truncated, damaged or of another format) skipped: their "
                       "results were computed again", err=True)
        if self.unwritten:
            click.echo(f"ndbg: warning: cache {directory} cannot be written ({self.why}): "
                       f"{self.unwritten} result(s) computed but not stored", err=True)


def _trim_cache(directory: str | None) -> None:
    """After a run: the cache back under its size limit (:func:`ndbg_cli.core.cache.trim`);
    never fails the run (a malformed ``$NDBG_CACHE_MAX_MB`` is a warning)."""
    from ..core.cache import max_bytes, trim

    if not directory:
        return
    try:
        limit = max_bytes()
    except ValueError as exc:
        click.echo(f"ndbg: warning: {exc}; the cache is not trimmed", err=True)
        return
    removed, freed = trim(directory, limit)
    if removed and not STATE.quiet:
        click.echo(f"ndbg: cache trimmed: {removed} file(s) ({freed / 2**20:.1f} MB): least "
                   f"recently used entries and leftovers of killed writes, removed from "
                   f"{directory}", err=True)


def _options(ctx: click.Context, config: str | None, **given) -> Options:
    """Options from the config file, overridden by the options given on the command line."""
    from ..core.cache import default_dir
    from ..io.config import read_config

    settings = read_config(config) if config else {}
    for name, value in given.items():
        source = ctx.get_parameter_source(name)
        flagged = source is not None and source.name != "DEFAULT"
        if flagged or name not in settings:
            settings[name] = value
        # the click types let NaN and infinity through their ranges (a tolerance is checked
        # by the loader, against the assembly's size)
        problem = (setting_problem(name, value, null=False) if flagged and name != "tolerance"
                   else None)
        if problem:
            raise InputError(f"--{name.replace('_', '-')}: {problem}")
    chosen = ctx.meta.get("ndbg_cache")  # "" is --no-cache
    if chosen is not None:
        settings["cache"] = chosen or None
    elif "cache" not in settings:
        settings["cache"] = str(default_dir())
    return Options(**settings)


def _exit_code(report: dict) -> int:
    if "error" in report:
        return int(report["error"]["code"])
    return int(report.get("exit_code", EXIT_OK))


def _batch_doc(reports: list[dict]) -> dict:
    from ..report.document import BATCH_SCHEMA

    failed = sum(1 for r in reports if "error" in r)
    return {"schema": BATCH_SCHEMA, "tool": {"name": "ndbg", "version": __version__},
            "summary": {"assemblies": len(reports), "ok": len(reports) - failed,
                        "errors": failed},
            "reports": reports}


def _report_name(r: dict, names: set[str]) -> str:
    """A file stem for a report, unique within the batch (``bell``, ``bell-2``, ...) and never
    ``index`` (``index-2``: ``index.json`` is the batch's index)."""
    from ..report.document import identity

    stem = identity(r)[0]
    stem = re.sub(r"[^A-Za-z0-9_.-]+", "_", stem) or "assembly"
    name, k = stem, 1
    # ``index`` is the batch's index.json; compared case-folded since ``Bell.json`` and
    # ``bell.json`` are one file on case-insensitive file systems
    while name.casefold() in names or name.casefold() == "index":
        k += 1
        name = f"{stem}-{k}"
    names.add(name.casefold())
    return name


def _index_entry(r: dict, file: str) -> dict:
    """What ``index.json`` keeps of a report: identity and error, not the analysis, and
    ``report``, the name of its file in the folder (so that a reader takes this run's files,
    not others left there). Every entry has the top-level ``source`` the batch schema
    requires (an error record has its own; a report's is its assembly's)."""
    from ..report.document import identity

    out = {k: v for k, v in r.items() if k in {"schema", "tool", "source", "error"}}
    out["source"] = identity(r)[1]
    out["report"] = file
    if "assembly" in r:
        out["assembly"] = {"name": r["assembly"]["name"], "source": r["assembly"]["source"]}
    return out


@cli.command(context_settings=CONTEXT)
@click.argument("paths", nargs=-1, required=True, type=click.Path())
@click.option("--rules", "rules_file", type=click.Path(),
              help="YAML rules file (see configs/rules-*.yaml); needed unless --self.")
@click.option("--self", "self_check", is_flag=True,
              help="Check that each report's answers agree with each other (a proven "
              "plan against 'interlocked' and the classes, the families against each "
              "other, ...): one line per contradiction, exit 1 on any.")
@click.option("--junit", type=click.Path(dir_okay=False), help="Also write a JUnit XML "
              "report here (one test case per assembly).")
@click.option("--format", "fmt", type=click.Choice(["text", "json"]), default="text",
              show_default=True)
@click.option("-j", "--jobs", type=click.IntRange(1), default=None,
              help="Worker processes (default: the number of cores).")
@click.option("--motion", type=click.Choice(MOTIONS), default="all", show_default=True)
@click.option("--config", "config", type=click.Path(), help="YAML analysis settings file.")
@click.option("--infinite-budget", type=range_type("infinite_budget"),
              default=DEFAULTS.infinite_budget,
              show_default=True, help="As for analyze.")
@root_option
@common_load_options
@cache_options
@click.pass_context
def check(ctx, paths, rules_file, self_check, junit, fmt, jobs, motion, config, infinite_budget,
          root, units, tolerance, allow_outside_paths, mesh_tolerance, load_timeout,
          load_memory, max_triangles) -> None:
    """CI gate: analyse PATHS (or read saved .json reports, or a folder of them) and check
    design rules (--rules), the reports' consistency (--self), or both.

    Exit code 0 when every rule holds and no report contradicts itself, 1 when a rule is
    violated (one line per violation: assembly, rule, measured value, expected, why) or a
    report contradicts itself (--self: one line per contradiction: assembly, consistency
    rule, what disagrees, the report fields involved), 2 for bad input or a bad rules file.

    \b
    Example:
      ndbg check assemblies/bell.yaml --rules configs/rules-bell.yaml --junit ndbg.xml
      ndbg check --self assemblies/
      ndbg check --self reports/ --rules configs/rules-bell.yaml
    """
    if not rules_file and not self_check:
        fail("nothing to check: give --rules FILE, --self, or both", EXIT_INPUT)
    from ..io.formats import prestart_reader

    if len(paths) == 1:  # a native reader's start-up overlaps the imports below
        prestart_reader(paths[0])
    from ..core.progress import progress
    from ..io.formats import discover
    from ..report.diff import holds_reports, read_reports
    from ..report.document import dumps
    from ..report.junit import junit_xml
    from ..report.rules import RuleSet, evaluate, load_rules

    ruleset = load_rules(rules_file) if rules_file else RuleSet()
    options = _options(ctx, config, motion=motion, units=units, tolerance=tolerance,
                       allow_outside_paths=allow_outside_paths,
                       infinite_budget=infinite_budget, mesh_tolerance=mesh_tolerance,
                       load_timeout=load_timeout, load_memory=load_memory,
                       max_triangles=max_triangles)
    options = with_root(options, root)
    saved, targets = [], []
    for p in paths:
        if not Path(p).exists():
            fail(f"{p}: no such file or directory", EXIT_INPUT)
        q = Path(p)
        if q.suffix.lower() in (".json", ".jsonl") or holds_reports(q):
            saved.extend(read_reports(p).values())
        else:
            targets.extend(discover(p))
    if not saved and not targets:
        fail("nothing to check: no assembly or report in " + ", ".join(paths), EXIT_INPUT)
    reports = list(saved)
    outcomes = [evaluate(r, ruleset) for r in saved]
    faults = CacheFaults()
    if targets:  # the stages only then: a gate on saved reports starts fast
        from ..pipeline.batch import default_jobs, run_batch

        stream = run_batch(targets, options, jobs or default_jobs(), debug=STATE.debug)
        for r in progress(stream, len(targets), "checking", quiet=STATE.quiet):
            faults.add(r)
            reports.append(r)
            outcomes.append(evaluate(r, ruleset))
    faults.tell(options.cache)
    for pattern in ruleset.unmatched(reports):
        click.echo(f"ndbg check: warning: rules for '{pattern}' matched no assembly", err=True)
    if junit:
        _write(junit, Path(junit), junit_xml(outcomes))
    failed = [o for oc in outcomes for o in oc if not o.passed]
    # a failed rule is a violation when the analysis proves it, else undecided (it fails
    # only through the rules file's ``undecided: fail``)
    undecided = sum(1 for o in failed if o.ok is None)
    found = _contradictions(reports) if self_check else None
    if fmt == "json":
        doc = {"schema": "ndbg.check/1", "rules": rules_file,
               "summary": {"assemblies": len(outcomes), "rules_checked": sum(map(len, outcomes)),
                           "violations": len(failed) - undecided,
                           "undecided_failed": undecided,
                           "failed_assemblies": len({o.assembly for o in failed})},
               "outcomes": [[{"assembly": o.assembly, "source": o.source, "rule": o.rule,
                              "expected": o.expected, "measured": o.measured, "ok": o.ok,
                              "passed": o.passed, "reason": o.reason} for o in oc]
                            for oc in outcomes]}
        if found is not None:
            doc["summary"]["contradictions"] = len(found)
            doc["contradictions"] = found
        click.echo(dumps(doc), nl=False)
    else:
        for o in failed:
            click.echo(o.line())
        n = len(outcomes)
        bad = len({o.assembly for o in failed})
        tail = f", {undecided} undecided (undecided: fail)" if undecided else ""
        if rules_file:
            click.echo(f"ndbg check: {n - bad} of {n} assemblies pass "
                       f"({sum(map(len, outcomes))} rules checked, "
                       f"{len(failed) - undecided} violation(s){tail})", err=bool(failed))
        if found is not None:
            _echo_contradictions(found, len(reports))
    _trim_cache(options.cache)
    errors = [_exit_code(r) for r in reports if "error" in r]
    if errors:
        sys.exit(max(errors))  # 2 input error, 3 internal error
    sys.exit(EXIT_VIOLATION if failed or found else EXIT_OK)


def _contradictions(reports: list[dict]) -> list[dict]:
    """Each report's contradictions (:func:`ndbg_cli.report.consistency.contradictions`) as
    records naming the assembly, in the reports' order."""
    from ..report.consistency import contradictions
    from ..report.document import identity

    return [{"assembly": identity(r)[0], "source": identity(r)[1], **c.record()}
            for r in reports for c in contradictions(r)]


def _echo_contradictions(found: list[dict], n: int) -> None:
    """One line per contradiction on stdout, then the count on stderr (as the rules do)."""
    for c in found:
        click.echo(f"{c['assembly']}: {c['rule']}: {c['message']} [{', '.join(c['fields'])}]")
    bad = len({c["source"] for c in found})
    click.echo(f"ndbg check --self: {n - bad} of {n} reports consistent "
               f"({len(found)} contradiction(s))", err=bool(found))



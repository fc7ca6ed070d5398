"""The ``ndbg`` command line: a thin layer over the library (:mod:`ndbg_cli.pipeline.analysis`).

Exit codes (see :mod:`ndbg_cli.core.errors`): 0 ok, 1 a violation a gate asked about, 2 usage or
input error, 3 internal error. Errors print one line on stderr, never a traceback unless
``--debug`` is given.
"""

from __future__ import annotations

import dataclasses
import json
import os
import re
import sys
import tempfile
import traceback
from pathlib import Path

import click

from .._version import __version__
from ..core.errors import EXIT_INPUT, EXIT_INTERNAL, EXIT_OK, EXIT_VIOLATION, InputError, NdbgError
from ..core.files import ESCAPE, write_atomic
from ..core.progress import progress
from ..io.loaders import discover
from ..pipeline.analysis import MOTIONS, SETTINGS, STRATEGIES, Options, read_config, setting_problem
from ..pipeline.batch import Interrupted, default_jobs, run_batch, run_batch_dask
from ..report.document import BATCH_SCHEMA, clean, dumps, identity
from ..report.text import render

CONTEXT = {"help_option_names": ["-h", "--help"], "max_content_width": 100}


class _State:
    debug = False
    quiet = False


STATE = _State()


def fail(message: str, code: int) -> None:
    click.echo(f"ndbg: error: {message}", err=True)
    sys.exit(code)


#: The options' defaults are the library's (:class:`Options`).
_DEFAULT = Options()


def _range(name: str) -> click.ParamType:
    """The click type of a numeric setting, from its range in :data:`analysis.SETTINGS`
    (the one a config file is checked against)."""
    kind, low, excluded = (SETTINGS[name] + (None, False))[:3]
    if kind is int:
        return click.IntRange(low)
    return click.FloatRange(low, min_open=excluded)


@click.group(context_settings=CONTEXT)
@click.version_option(__version__, "-V", "--version", prog_name="ndbg")
@click.option("--debug", is_flag=True, help="Show tracebacks of internal errors.")
@click.option("-q", "--quiet", is_flag=True, help="No progress bar or notes on stderr.")
def cli(debug: bool, quiet: bool) -> None:
    """Assembly sequencing and complexity analysis with non-directional blocking graphs.

    \b
    Example:
      ndbg analyze assemblies/bell.yaml
      ndbg analyze assemblies/ --format json > reports.json
    """
    STATE.debug = debug
    STATE.quiet = quiet


def _set_debug(ctx, param, value):
    if value:
        STATE.debug = True


def _set_quiet(ctx, param, value):
    if value:
        STATE.quiet = True


def _global_options(f):
    """``--debug`` and ``--quiet`` are accepted after the subcommand too."""
    f = click.option("--debug", is_flag=True, expose_value=False, callback=_set_debug,
                     is_eager=True, help="Show tracebacks of internal errors.")(f)
    f = click.option("-q", "--quiet", is_flag=True, expose_value=False, callback=_set_quiet,
                     is_eager=True, help="No progress bar or notes on stderr.")(f)
    return f


def _cache_options(f):
    """``--cache DIR`` / ``--no-cache``: the per-part-pair result cache (kept in ``ctx.meta``,
    read by :func:`_options`)."""
    def remember(ctx, param, value):
        # --no-cache ("") wins over --cache DIR whatever their order on the command line
        if value is not None and ctx.meta.get("ndbg_cache") != "":
            ctx.meta["ndbg_cache"] = value
        return value

    f = click.option("--no-cache", "no_cache", is_flag=True, default=None, expose_value=False,
                     callback=lambda ctx, p, v: remember(ctx, p, "" if v else None),
                     help="Do not read or write the per-part-pair result cache.")(f)
    f = click.option("--cache", "cache_dir", type=click.Path(file_okay=False),
                     expose_value=False, callback=remember,
                     help="Per-part-pair result cache directory (default: $NDBG_CACHE_DIR, "
                     "else ~/.cache/ndbg): unchanged part pairs are not recomputed.")(f)
    return f


def _common_load_options(f):
    f = _global_options(f)
    f = click.option("--units", help="Unit of the input (mm, cm, m, in): converts files that "
                     "record theirs (manifest, STEP), declares it for those that don't.")(f)
    f = click.option("--tolerance", type=float,
                     help="Length tolerance in the assembly unit (default: 1e-4 x diagonal).")(f)
    f = click.option("--allow-outside-paths", is_flag=True,
                     help="Let manifests name mesh files outside their folder.")(f)
    return f


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
              "its infinite-translation NDBG's part pairs (default: the number of cores). "
              "Same reports.")
@click.option("--scheduler", metavar="ADDRESS", help="Run the batch on a dask.distributed "
              "cluster: tcp://HOST:PORT of a running scheduler (its workers must see the input "
              "files at the same paths), or 'local' to start one on this machine with --jobs "
              "worker processes. Same reports, same order. Needs pip install 'ndbg-cli[dask]'.")
@click.option("--motion", type=click.Choice(MOTIONS), default="all", show_default=True,
              help="Motion family of the blocking graphs.")
@click.option("--interference", type=click.Choice(["error", "warn", "ignore"]), default="warn",
              show_default=True, help="What interpenetrating parts are.")
@click.option("--timings", is_flag=True, help="Record wall-clock timings in the report "
              "(makes it differ from run to run).")
@click.option("--config", "config", type=click.Path(), help="YAML settings file (see "
              "configs/default.yaml); options given on the command line win.")
@click.option("--strategy", type=click.Choice(STRATEGIES), default="shortest",
              show_default=True, help="How the reported assembly tree is chosen.")
@click.option("--threads-as-cylinders", is_flag=True,
              help="Read declared screw joints as plain cylinders (threads ignored).")
@click.option("--connected", is_flag=True, help="Only partitionings whose two sides are each "
              "connected in the contact graph in the lists (the plan always prefers them; "
              "classes keep the paper's definitions).")
@click.option("--max-partitions", type=_range("max_partitions"), default=_DEFAULT.max_partitions,
              show_default=True,
              help="Partitionings listed per motion family (the report says when it cut).")
@click.option("--max-nodes", type=_range("max_nodes"), default=_DEFAULT.max_nodes,
              show_default=True,
              help="AND/OR graph budget: subassemblies per search (a graph with more is "
              "cut at once; the measures then come from anytime searches).")
@click.option("--max-work", type=_range("max_work"), default=_DEFAULT.max_work,
              show_default=True,
              help="AND/OR graph budget: work units per search (DBGs induced on the "
              "subassemblies expanded and regions listed; counted, so reports stay "
              "reproducible).")
@click.option("--time-limit", type=_range("time_limit"), default=_DEFAULT.time_limit,
              help="AND/OR graph budget: seconds per search (off by default: a search cut "
              "by the clock makes the report depend on the machine's speed and load).")
@click.option("--infinite-budget", type=_range("infinite_budget"),
              default=_DEFAULT.infinite_budget,
              show_default=True, help="Facing triangle pairs beyond which the infinite-"
              "translation NDBG is skipped (with a warning).")
@_common_load_options
@_cache_options
@click.pass_context
def analyze(ctx, paths, fmt, out, out_dir, jobs, scheduler, motion, interference, timings, config,
            strategy, threads_as_cylinders, connected, max_partitions, max_nodes, max_work,
            time_limit, infinite_budget, units, tolerance, allow_outside_paths) -> None:
    """Analyse assemblies: manifests, model files (STEP, GLB, ...) or folders.

    A folder holding manifests is a batch (one report each); a folder holding only meshes is
    one assembly. One bad assembly in a batch gives an error record; the others complete.

    \b
    Examples:
      ndbg analyze assemblies/bell.yaml --format json
      ndbg analyze assemblies/ --format jsonl --scheduler tcp://10.0.0.5:8786
    """
    options = _options(ctx, config, motion=motion, units=units, tolerance=tolerance,
                       allow_outside_paths=allow_outside_paths, interference=interference,
                       timings=timings, strategy=strategy,
                       threads_as_cylinders=threads_as_cylinders, connected=connected,
                       max_partitions=max_partitions, max_nodes=max_nodes, max_work=max_work,
                       time_limit=time_limit, infinite_budget=infinite_budget)
    options = dataclasses.replace(options, progress=not STATE.quiet)
    targets: list[Path] = []
    for p in paths:
        if not Path(p).exists():
            fail(f"{p}: no such file or directory", EXIT_INPUT)
        targets.extend(discover(p))
    batch = len(targets) > 1 or any(Path(p).is_dir() and discover(p) != [Path(p)] for p in paths)
    out_dir, out_file, where = _outputs(out, out_dir, batch)
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
    if scheduler:
        stream = run_batch_dask(targets, options, scheduler, jobs, debug=STATE.debug)
    else:
        stream = run_batch(targets, options, jobs, debug=STATE.debug)
    # the warnings are in a text report on stdout; elsewhere a human would not see them
    summary = not STATE.quiet and (out_dir is not None or out_file is not None or fmt != "text")
    try:
        if out_dir is not None:  # once the run can start (a dask scheduler was reached)
            _drop_index(where, out_dir, inputs)
        for r in progress(stream, len(targets), "analyzing", quiet=STATE.quiet):
            code = max(code, _exit_code(r))
            if "error" in r:
                _note(f"ndbg: error: {r['error']['message']}")
            elif summary:
                for line in _warning_lines(r):
                    _note(line)
            if out_dir is not None:
                path = out_dir / f"{_report_name(r, names)}.json"
                _refuse_input(where, path, inputs | _part_files(r))
                _write(where, path, dumps(r))
                reports.append(_index_entry(r, path.name))
            elif fmt == "jsonl" and out_file is None:
                click.echo(_jsonl_line(r), nl=False)
            else:
                reports.append(r)
    except Interrupted:
        tail = " (no index.json: the run is incomplete)" if out_dir is not None else ""
        click.echo(f"ndbg: terminated; reports written so far are complete{tail}", err=True)
        sys.exit(143)
    finally:  # an error writing a report: the workers are ended now, not at exit
        stream.close()
    if out_dir is not None:
        _refuse_input(where, out_dir / "index.json", inputs)
        _write(where, out_dir / "index.json", dumps(_batch_doc(reports)))
    elif out_file is not None:
        r = reports[0]
        _refuse_input(where, out_file, _part_files(r))
        text = {"json": dumps, "jsonl": _jsonl_line, "text": render}[fmt](r)
        _write(where, out_file, text)
    elif fmt == "json":
        doc = _batch_doc(reports) if batch else reports[0]
        click.echo(dumps(doc), nl=False)
    elif fmt == "text":
        click.echo("\n".join(render(r) for r in reports), nl=False)
    _trim_cache(options.cache)
    sys.exit(code)


#: Warnings summarised on stderr per assembly; the rest are counted (all are in the report).
MAX_WARNING_LINES = 20


def _warning_lines(report: dict) -> list[str]:
    """One ``ndbg: warning: NAME: MESSAGE [PART]`` line per warning of ``report`` (at most
    :data:`MAX_WARNING_LINES`, then how many more), for stderr: a report written to a file,
    a folder or as JSON carries its warnings (interferences, skipped stages, open meshes)
    where the person running ndbg does not look."""
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
        _check_writable(where, folder)
        return folder, None, where
    if out:
        _check_writable(out, Path(out).parent)
        return None, Path(out), out
    return None, None, ""


def _cannot_write(where: str, exc: OSError) -> InputError:
    """The one-line input error for an output path ``where`` (as the user gave it)."""
    if isinstance(exc, FileExistsError):  # mkdir over a file
        reason = f"{exc.filename} is not a directory"
    else:
        reason = exc.strerror or str(exc)
    return InputError(f"cannot write {where}: {reason}")


def _check_writable(where: str, folder: Path) -> None:
    """``folder`` made if missing, and a file created and removed in it; else the
    :func:`_cannot_write` error naming ``where``."""
    try:
        folder.mkdir(parents=True, exist_ok=True)
        with tempfile.NamedTemporaryFile(dir=folder, prefix=".ndbg-probe-", suffix=".tmp"):
            pass
    except OSError as exc:
        raise _cannot_write(where, exc) from None


def _write(where: str, path: Path, text: str) -> None:
    """:func:`write_atomic` of ``text`` to ``path``; an error names ``where`` (exit 2)."""
    try:
        write_atomic(path, text)
    except OSError as exc:
        raise _cannot_write(where, exc) from None


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
        raise _cannot_write(where, exc) from None


def _input_files(targets: list[Path]) -> set[Path]:
    """The resolved input files (a folder target: the files in it), that no output may
    replace."""
    files = set()
    for t in targets:
        for f in (t.rglob("*") if t.is_dir() else [t]):
            files.add(f.resolve())
    return files


def _part_files(report: dict) -> set[Path]:
    """The resolved files a report's parts were read from (mesh files of a manifest)."""
    parts = (report.get("assembly") or {}).get("parts") or []
    return {Path(p["source"]).resolve() for p in parts if "#" not in str(p.get("source"))}


def _refuse_input(where: str, path: Path, inputs: set[Path]) -> None:
    """An input error if writing ``path`` would replace one of the ``inputs``."""
    if path.resolve() in inputs:
        raise InputError(f"cannot write {where}: {path} is an input of this run")


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
    failed = sum(1 for r in reports if "error" in r)
    return {"schema": BATCH_SCHEMA, "tool": {"name": "ndbg", "version": __version__},
            "summary": {"assemblies": len(reports), "ok": len(reports) - failed,
                        "errors": failed},
            "reports": reports}


def _report_name(r: dict, names: set[str]) -> str:
    """A file stem for a report, unique within the batch (``bell``, ``bell-2``, ...) and never
    ``index`` (``index-2``: ``index.json`` is the batch's index)."""
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
    out = {k: v for k, v in r.items() if k in {"schema", "tool", "source", "error"}}
    out["source"] = identity(r)[1]
    out["report"] = file
    if "assembly" in r:
        out["assembly"] = {"name": r["assembly"]["name"], "source": r["assembly"]["source"]}
    return out


@cli.command(context_settings=CONTEXT)
@click.argument("paths", nargs=-1, required=True, type=click.Path())
@click.option("--rules", "rules_file", required=True, type=click.Path(),
              help="YAML rules file (see configs/rules-*.yaml).")
@click.option("--junit", type=click.Path(dir_okay=False), help="Also write a JUnit XML "
              "report here (one test case per assembly).")
@click.option("--format", "fmt", type=click.Choice(["text", "json"]), default="text",
              show_default=True)
@click.option("-j", "--jobs", type=click.IntRange(1), default=None,
              help="Worker processes (default: the number of cores).")
@click.option("--motion", type=click.Choice(MOTIONS), default="all", show_default=True)
@click.option("--config", "config", type=click.Path(), help="YAML analysis settings file.")
@click.option("--infinite-budget", type=_range("infinite_budget"),
              default=_DEFAULT.infinite_budget,
              show_default=True, help="As for analyze.")
@_common_load_options
@_cache_options
@click.pass_context
def check(ctx, paths, rules_file, junit, fmt, jobs, motion, config, infinite_budget, units,
          tolerance, allow_outside_paths) -> None:
    """CI gate: analyse PATHS (or read saved .json reports, or a folder of them) and check
    design rules.

    Exit code 0 when every rule holds, 1 when any is violated (one line per violation:
    assembly, rule, measured value, expected, why), 2 for bad input or a bad rules file.

    \b
    Example:
      ndbg check assemblies/bell.yaml --rules configs/rules-bell.yaml --junit ndbg.xml
    """
    from ..report.diff import holds_reports, read_reports
    from ..report.junit import junit_xml
    from ..report.rules import evaluate, load_rules

    ruleset = load_rules(rules_file)
    options = _options(ctx, config, motion=motion, units=units, tolerance=tolerance,
                       allow_outside_paths=allow_outside_paths,
                       infinite_budget=infinite_budget)
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
    stream = run_batch(targets, options, jobs or default_jobs(), debug=STATE.debug)
    for r in progress(stream, len(targets), "checking", quiet=STATE.quiet):
        reports.append(r)
        outcomes.append(evaluate(r, ruleset))
    for pattern in ruleset.unmatched(reports):
        click.echo(f"ndbg check: warning: rules for '{pattern}' matched no assembly", err=True)
    if junit:
        _write(junit, Path(junit), junit_xml(outcomes))
    failed = [o for oc in outcomes for o in oc if not o.passed]
    # a failed rule is a violation when the analysis proves it, else undecided (it fails
    # only through the rules file's ``undecided: fail``)
    undecided = sum(1 for o in failed if o.ok is None)
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
        click.echo(dumps(doc), nl=False)
    else:
        for o in failed:
            click.echo(o.line())
        n = len(outcomes)
        bad = len({o.assembly for o in failed})
        tail = f", {undecided} undecided (undecided: fail)" if undecided else ""
        click.echo(f"ndbg check: {n - bad} of {n} assemblies pass "
                   f"({sum(map(len, outcomes))} rules checked, "
                   f"{len(failed) - undecided} violation(s){tail})", err=bool(failed))
    _trim_cache(options.cache)
    errors = [_exit_code(r) for r in reports if "error" in r]
    if errors:
        sys.exit(max(errors))  # 2 input error, 3 internal error
    sys.exit(EXIT_VIOLATION if failed else EXIT_OK)


# the other commands register themselves on the group
from . import commands  # noqa: E402,F401


def main(argv: list[str] | None = None) -> None:
    """Entry point: run the CLI, mapping exceptions to exit codes and one-line messages.

    stdout and stderr write what their encoding cannot (the undecodable bytes of a file name
    that is not UTF-8, kept by Python as lone surrogates) as ``\\xNN``, as the reports do
    (:data:`ndbg_cli.core.files.ESCAPE`): otherwise a text report or an error message naming
    such a file fails with UnicodeEncodeError (stdout's default is strict), or writes
    the raw byte (a C locale's surrogateescape), which is not UTF-8."""
    for stream in (sys.stdout, sys.stderr):
        try:
            stream.reconfigure(errors=ESCAPE)
        except (AttributeError, ValueError, OSError):  # replaced by a non-TextIOWrapper
            pass
    try:
        cli.main(args=argv, prog_name="ndbg", standalone_mode=False)
    except click.exceptions.Exit as exc:
        sys.exit(exc.exit_code)
    except click.ClickException as exc:
        exc.show()
        sys.exit(EXIT_INPUT)
    except click.exceptions.Abort:
        click.echo("ndbg: aborted", err=True)
        sys.exit(130)
    except InputError as exc:
        fail(exc.message, exc.exit_code)
    except NdbgError as exc:
        fail(exc.message, exc.exit_code)
    except SystemExit:
        raise
    except BrokenPipeError:
        sys.exit(EXIT_OK)
    except Exception as exc:
        if STATE.debug:
            traceback.print_exc()
        fail(f"internal error: {exc.__class__.__name__}: {exc} "
             "(run with --debug for a traceback)", EXIT_INTERNAL)

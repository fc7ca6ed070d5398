"""The ``ndbg`` command group and what its commands share: the global options, the
output-path checks and the one-line failure. Imports no stage, so that ``ndbg --help``,
``--version`` and ``schema`` start fast."""

from __future__ import annotations

import sys
import tempfile
from pathlib import Path

import click

from .._version import __version__
from ..core.errors import InputError
from ..core.files import one_line
from ..core.options import SETTINGS, Options

CONTEXT = {"help_option_names": ["-h", "--help"], "max_content_width": 100}


class _State:
    debug = False
    quiet = False


STATE = _State()


def fail(message: str, code: int) -> None:
    click.echo(f"ndbg: error: {one_line(message)}", err=True)
    sys.exit(code)


#: The options' defaults are the library's (:class:`Options`).
DEFAULTS = Options()


def range_type(name: str) -> click.ParamType:
    """The click type of a numeric setting, from its range in :data:`ndbg_cli.core.options.SETTINGS`
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


def global_options(f):
    """``--debug`` and ``--quiet`` are accepted after the subcommand too."""
    f = click.option("--debug", is_flag=True, expose_value=False, callback=_set_debug,
                     is_eager=True, help="Show tracebacks of internal errors.")(f)
    f = click.option("-q", "--quiet", is_flag=True, expose_value=False, callback=_set_quiet,
                     is_eager=True, help="No progress bar or notes on stderr.")(f)
    return f


def cache_options(f):
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


def common_load_options(f):
    f = global_options(f)
    f = click.option("--units", help="Unit of the input (mm, cm, m, in): converts files that "
                     "record theirs (manifest, STEP), declares it for those that don't.")(f)
    f = click.option("--tolerance", type=float,
                     help="Length tolerance in the assembly unit (default: 1e-4 x diagonal).")(f)
    f = click.option("--allow-outside-paths", is_flag=True,
                     help="Let manifests name mesh files outside their folder.")(f)
    f = click.option("--mesh-tolerance", type=range_type("mesh_tolerance"),
                     default=DEFAULTS.mesh_tolerance,
                     help="STEP/IGES tessellation: largest distance from a facet to the "
                     "exact surface, in the assembly unit (default: 0.01 mm, or 1e-5 x the "
                     "model's size above 1 m). Larger: faster, coarser.")(f)
    f = click.option("--load-timeout", type=range_type("load_timeout"),
                     default=DEFAULTS.load_timeout, show_default=True,
                     help="Seconds a native reader (STEP, IGES, glTF, 3DXML, 3MF; run in a "
                     "child process) may take before the file is given up (exit 2).")(f)
    f = click.option("--load-memory", type=range_type("load_memory"),
                     default=DEFAULTS.load_memory, show_default=True,
                     help="GiB of address space a native reader's process may use.")(f)
    f = click.option("--max-triangles", type=range_type("max_triangles"),
                     default=DEFAULTS.max_triangles, show_default=True,
                     help="Triangles one assembly may have: more is an input error (exit 2) "
                     "as soon as the files read pass it, before any analysis.")(f)
    return f


def root_option(f):
    """``--root DIR``: the folder the reports' paths are written relative to (read by
    :func:`with_root`)."""
    return click.option("--root", type=click.Path(), default=None,
                        help="Write the reports' paths (sources, files) relative to this "
                        "folder (default: the current one); a path outside it stays "
                        "absolute.")(f)


def with_root(options: Options, root: str | None) -> Options:
    """``options`` with its ``root`` set to ``root`` (``--root``), else the current folder,
    made absolute: worker processes and cluster workers write the same paths. A ``root``
    that is not a folder is an input error (exit 2)."""
    import dataclasses

    from ..core.paths import report_root

    if root is not None and not Path(root).is_dir():
        raise InputError(f"--root {root}: no such directory")
    return dataclasses.replace(options, root=str(report_root(root)))


def load_settings(mesh_tolerance, load_timeout, load_memory, max_triangles) -> dict:
    """The :func:`ndbg_cli.io.loaders.load` arguments of the common load options besides
    units, tolerance and paths (for the commands that load without :class:`Options`)."""
    return {"mesh_tolerance": mesh_tolerance, "load_timeout": load_timeout,
            "load_memory": load_memory, "max_triangles": max_triangles,
            "progress": not STATE.quiet}


def cannot_write(where: str, exc: OSError) -> InputError:
    """The one-line input error for an output path ``where`` (as the user gave it)."""
    if isinstance(exc, FileExistsError):  # mkdir over a file
        reason = f"{exc.filename} is not a directory"
    else:
        reason = exc.strerror or str(exc)
    return InputError(f"cannot write {where}: {reason}")


def check_writable(where: str, folder: Path) -> None:
    """``folder`` made if missing, and a file created and removed in it; else the
    :func:`cannot_write` error naming ``where``."""
    try:
        folder.mkdir(parents=True, exist_ok=True)
        with tempfile.NamedTemporaryFile(dir=folder, prefix=".ndbg-probe-", suffix=".tmp"):
            pass
    except OSError as exc:
        raise cannot_write(where, exc) from None



"""Per-part-pair result cache (the paper's incremental update, section 4.3, in practical form).

The expensive geometry (the contacts of two parts, the blocked set ``B_ij``) is computed pair
by pair, and each result depends only on the two parts' placed geometry (:attr:`Part.hash`),
the tolerances and the code that computed it. A :class:`PairCache` stores results on disk
under a key made of exactly these (the code as a digest of the stage's module sources,
:func:`code_digest`), so editing one part recomputes only the pairs that involve it, and
results from another version of ndbg are never reused. Results are stored exactly (pickled
numpy arrays and shapely WKB), so a warm run's report is byte-identical to a cold one's. The
cache is the user's own: pickle is only safe for files you wrote yourself.
"""

from __future__ import annotations

import ast
import hashlib
import os
import pickle
import re
import stat
import time
from functools import cache as cache_fn
from importlib.util import resolve_name
from pathlib import Path
from typing import Any

from .._version import __version__
from ..core.files import write_atomic

#: Modules whose code determines each stage's per-pair results (dotted names below
#: ``ndbg_cli``), with every package module they import (:func:`stage_modules`).
STAGE_MODULES = {
    "contacts": ("contacts.contacts3d", "contacts.features", "contacts.facets",
                 "contacts.interference", "core.assembly"),
    "infinite": ("ndbg.infinite.build", "ndbg.infinite.cubemap", "core.assembly"),
}

#: The package's folder (module names resolve to files below it).
_PACKAGE_DIR = Path(__file__).resolve().parent.parent


def _module_file(name: str) -> Path | None:
    """The source file of the package module ``name`` (dotted, below ``ndbg_cli``), or
    None when it is a package without code of its own or not a module of ours."""
    base = _PACKAGE_DIR.joinpath(*name.split("."))
    for path in (base.with_suffix(".py"), base / "__init__.py"):
        if path.is_file():
            return path
    return None


#: Functions of :mod:`ndbg_cli.kernels.compiled` taking the name of a kernel module of
#: :data:`KERNEL_PACKAGE`: ``loaded("_cone_kernels")`` reads that module's kernels
#: (compiled from it, ahead of time or not) as an import would.
KERNEL_LOADERS = ("kernels", "loaded")
KERNEL_PACKAGE = "kernels"


def _relative_imports(source: str, name: str, path: Path) -> set[str]:
    """The package modules (dotted names) that module ``name`` (source file ``path``) imports
    with relative imports (``from ..x.y import ...``, ``from . import x``; anywhere in the
    file, functions included) or names to a :data:`KERNEL_LOADERS` function."""
    package = ".".join(["ndbg_cli", *name.split(".")[:None if path.name == "__init__.py"
                                                   else -1]])
    out: set[str] = set()
    for node in ast.walk(ast.parse(source)):
        if (isinstance(node, ast.Call) and len(node.args) == 1
                and (node.func.id if isinstance(node.func, ast.Name) else
                     getattr(node.func, "attr", None)) in KERNEL_LOADERS
                and isinstance(node.args[0], ast.Constant)
                and isinstance(node.args[0].value, str)):
            target = f"{KERNEL_PACKAGE}.{node.args[0].value}"
            if _module_file(target) is not None:
                out.add(target)
        if not isinstance(node, ast.ImportFrom) or not node.level:
            continue
        target = resolve_name("." * node.level + (node.module or ""), package)
        target = target.removeprefix("ndbg_cli").lstrip(".")
        # ``from .pkg import module`` names a module too
        for dotted in (target, *(f"{target}.{a.name}".lstrip(".") for a in node.names)):
            if dotted and _module_file(dotted) is not None:
                out.add(dotted)
    return out


@cache_fn
def stage_modules(stage: str) -> tuple[str, ...]:
    """The modules of :data:`STAGE_MODULES` for ``stage`` and all package modules they
    import, directly or not (sorted): a change to any of them changes the stage's digest."""
    seen: set[str] = set()
    todo = list(STAGE_MODULES[stage])
    while todo:
        name = todo.pop()
        if name in seen:
            continue
        seen.add(name)
        path = _module_file(name)
        if path is None:  # an installed wheel without sources
            continue
        try:
            source = path.read_text(encoding="utf-8")
        except OSError:
            continue
        todo.extend(_relative_imports(source, name, path) - seen)
    return tuple(sorted(seen))


#: The key of a report dict (never written: the command line takes it out) holding the
#: cache's faults of that analysis (:meth:`PairCache.faults`), for the user to be told once.
CACHE_FAULTS = "_cache_faults"

#: The content of ``CACHEDIR.TAG``, written in the cache directory: the standard signature
#: line, then what the folder is.
CACHEDIR_TAG = ("Signature: 8a477f597d28d172789f06886806bc55\n"
                "# This file is a cache directory tag created by ndbg (per-part-pair results).\n")
#: Default size limit of the cache directory, megabytes (``$NDBG_CACHE_MAX_MB`` overrides).
DEFAULT_MAX_MB = 2048
#: A trim removes entries until the cache holds at most this fraction of the limit (so that
#: the next runs do not trim again at once).
TRIM_TO = 0.8
#: Age (seconds) after which an entry's temporary file is left over from a killed write
#: (a live write renames it within milliseconds).
STALE_TEMP_S = 3600.0


def default_dir() -> Path:
    """The cache directory used when none is given: ``$NDBG_CACHE_DIR``, else
    ``$XDG_CACHE_HOME/ndbg``, else ``~/.cache/ndbg``."""
    env = os.environ.get("NDBG_CACHE_DIR")
    if env:
        return Path(env)
    base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    return Path(base) / "ndbg"


@cache_fn
def code_digest(stage: str) -> str:
    """Digest of the package version, the stage's module sources and the versions of the
    libraries whose numerics enter the results."""
    from importlib import metadata

    h = hashlib.sha256(__version__.encode())
    for name in stage_modules(stage):
        path = _module_file(name)
        try:
            h.update(path.read_bytes() if path else name.encode())
        except OSError:  # installed without sources: the version stands for them
            h.update(name.encode())
    for lib in ("numpy", "shapely", "trimesh", "manifold3d", "python-fcl", "scipy"):
        try:
            h.update(f"{lib}={metadata.version(lib)}".encode())
        except metadata.PackageNotFoundError:
            h.update(f"{lib}=none".encode())
    return h.hexdigest()[:16]


class _Counted:
    """Lookups counted per stage (``hits``, ``misses``): what both caches report."""

    def __init__(self) -> None:
        self.hits: dict[str, int] = {}
        self.misses: dict[str, int] = {}

    def _count(self, stage: str, hit: bool, final: bool = True) -> None:
        if not (hit or final):
            return
        counts = self.hits if hit else self.misses
        counts[stage] = counts.get(stage, 0) + 1

    def stats(self) -> dict[str, dict[str, int]]:
        """``{stage: {"hits": h, "misses": m}}``."""
        stages = sorted(set(self.hits) | set(self.misses))
        return {s: {"hits": self.hits.get(s, 0), "misses": self.misses.get(s, 0)}
                for s in stages}


class PairCache(_Counted):
    """A directory of per-pair results; ``hits`` and ``misses`` count lookups per stage.

    Layout: ``DIR/<stage>/<key[:2]>/<key>.pkl``, each file written atomically (temporary file
    and rename), so concurrent batch workers and killed runs never leave a torn entry; an
    unreadable entry is a miss and is rewritten. A hit refreshes its entry's modification
    time (for :func:`trim`). Default directory: :func:`default_dir`."""

    def __init__(self, root: str | Path):
        super().__init__()
        self.root = Path(root)
        # faults, told to the user once per run (:meth:`faults`): entries that exist but
        # could not be read (truncated, foreign bytes, another format), entries that could
        # not be stored (read-only or full folder, a path through a file), and why
        self.unreadable: dict[str, int] = {}
        self.unwritten: dict[str, int] = {}
        self.write_error: str | None = None

    def key(self, stage: str, *parts: Any) -> str:
        """The key of a stage's result for ``parts`` (hashes, tolerances: anything with a
        stable ``repr``)."""
        text = "\x1f".join([stage, code_digest(stage), *map(repr, parts)])
        return hashlib.sha256(text.encode()).hexdigest()

    def _path(self, stage: str, key: str) -> Path:
        return self.root / stage / key[:2] / f"{key}.pkl"

    def get(self, stage: str, key: str, check: Any = None, *, final: bool = True
            ) -> Any | None:
        """The stored value, or ``None`` (a miss). An unreadable entry, or one that
        ``check(value)`` (returning the value to use) rejects by raising, is a miss too: the
        analysis never fails because of its cache. ``final`` False: a miss is not counted
        (the caller then looks under another key: one result, one lookup counted)."""
        try:
            with open(self._path(stage, key), "rb") as f:
                value = pickle.load(f)
            if check is not None:
                value = check(value)
        except (FileNotFoundError, NotADirectoryError):  # not stored: a plain miss
            self._count(stage, False, final)
            return None
        except Exception:  # torn, foreign or corrupt entry (any unpickling error)
            self._count(stage, False, final)
            self.unreadable[stage] = self.unreadable.get(stage, 0) + 1
            return None
        self._count(stage, True)
        try:  # used now: the last entry a trim removes
            os.utime(self._path(stage, key))
        except OSError:
            pass
        return value

    def put(self, stage: str, key: str, value: Any) -> None:
        """Store ``value`` atomically; a cache that cannot be written is skipped (the
        analysis never fails because of its cache), counted in :attr:`unwritten`."""
        if self.write_error is not None and self.unwritten.get(stage, 0) > 64:
            # a folder that refused this many writes will refuse the rest: counted, not tried
            self.unwritten[stage] += 1
            return
        try:
            write_atomic(self._path(stage, key),
                         pickle.dumps(value, protocol=pickle.HIGHEST_PROTOCOL), durable=False)
            tag = self.root / "CACHEDIR.TAG"
            if not tag.exists():  # backup tools skip a tagged folder (bford.info/cachedir)
                write_atomic(tag, CACHEDIR_TAG.encode(), durable=False)
        except OSError as exc:
            self.unwritten[stage] = self.unwritten.get(stage, 0) + 1
            if self.write_error is None:
                self.write_error = exc.strerror or type(exc).__name__

    def faults(self) -> dict:
        """``{"unreadable": n, "unwritten": n, "write_error": why}`` when some entry could
        not be read or stored in this run, else ``{}``."""
        bad, unwritten = sum(self.unreadable.values()), sum(self.unwritten.values())
        if not bad and not unwritten:
            return {}
        return {"unreadable": bad, "unwritten": unwritten, "write_error": self.write_error}


class MemoryCache(_Counted):
    """Per-pair results kept in memory for one run, with :class:`PairCache`'s interface.

    Used when no cache directory is given, so that a stage run twice on nearly the same parts
    computes each pair once: the contacts of the pairs that clash units leave unchanged
    (:func:`ndbg_cli.pipeline.stages.run_stages`). The keys hold the parts' content hashes
    and the tolerances, as on disk; values are shared, not copied, so callers must not change
    them (the contact stage copies what it renumbers).

    >>> memo = MemoryCache()
    >>> memo.put("contacts", memo.key("contacts", "h1", "h2", 0.1), [1, 2])
    >>> memo.get("contacts", memo.key("contacts", "h1", "h2", 0.1)), memo.stats()
    ([1, 2], {'contacts': {'hits': 1, 'misses': 0}})
    """

    def __init__(self) -> None:
        super().__init__()
        self._store: dict[tuple, Any] = {}

    def key(self, stage: str, *parts: Any) -> tuple:
        """The key of a stage's result for ``parts`` (hashes, tolerances: hashable values
        compared exactly)."""
        return (stage, *parts)

    def get(self, stage: str, key: tuple, check: Any = None, *, final: bool = True
            ) -> Any | None:
        """The stored value, or ``None`` (a miss); ``check`` is not needed (the value was
        made by this process); ``final`` as :meth:`PairCache.get`'s."""
        value = self._store.get(key)
        self._count(stage, value is not None, final)
        return value

    def put(self, stage: str, key: tuple, value: Any) -> None:
        """Keep ``value`` under ``key``."""
        self._store[key] = value

    def faults(self) -> dict:
        """Always ``{}``: memory neither tears nor refuses a write."""
        return {}


def open_cache(directory: str | Path | None) -> PairCache | None:
    """A :class:`PairCache` on ``directory``, or ``None`` for no caching (``None`` or ``""``)."""
    return PairCache(directory) if directory else None


def max_bytes() -> int | None:
    """The cache's size limit in bytes: ``$NDBG_CACHE_MAX_MB`` (a non-negative number of
    megabytes; 0 means none), else :data:`DEFAULT_MAX_MB`. ``None``: no limit. Raises
    ``ValueError`` on a malformed value."""
    text = os.environ.get("NDBG_CACHE_MAX_MB", "").strip()
    try:
        mb = float(text) if text else float(DEFAULT_MAX_MB)
    except ValueError:
        mb = float("nan")
    if not 0 <= mb < float("inf"):  # negative, NaN or infinite
        raise ValueError(f"NDBG_CACHE_MAX_MB must be a number of megabytes >= 0, not {text!r}")
    return None if mb == 0 else int(mb * 1024 * 1024)


#: The file name of an entry: its key, 64 hexadecimal digits (:meth:`PairCache.key`).
_ENTRY = re.compile(r"([0-9a-f]{64})\.pkl")
#: The temporary file of an entry being written (:func:`~ndbg_cli.core.files.write_atomic`).
_TEMP = re.compile(r"\.([0-9a-f]{64})\.pkl\.[A-Za-z0-9_]+\.tmp")


def _files(root: Path, pattern: str, name: re.Pattern) -> list[tuple[str, Path, os.stat_result]]:
    """``(stage, path, stat)`` of the regular files ``<stage>/<key[:2]>/pattern`` under
    ``root`` whose name ``name`` matches with the key in the folder it belongs to, for a stage
    of :data:`STAGE_MODULES` (a cache pointed at a folder of one's own leaves its other files
    alone); vanished ones skipped (another run may be trimming too)."""
    out = []
    for stage in sorted(STAGE_MODULES):
        for path in (root / stage).glob(pattern):
            m = name.fullmatch(path.name)
            if m is None or m.group(1)[:2] != path.parent.name:
                continue
            try:
                st = path.stat()
            except OSError:
                continue
            if stat.S_ISREG(st.st_mode):
                out.append((stage, path, st))
    return out


def _entries(root: Path) -> list[tuple[float, int, str, Path]]:
    """``(mtime, bytes, stage, path)`` of every entry under ``root``: only files that ndbg
    writes, ``<stage>/<key[:2]>/<key>.pkl`` (:func:`_files`)."""
    return [(st.st_mtime, st.st_size, stage, path)
            for stage, path, st in _files(root, "??/*.pkl", _ENTRY)]


def _stale_temps(root: Path, now: float) -> list[tuple[int, Path]]:
    """``(bytes, path)`` of the entries' temporary files under ``root`` older than
    :data:`STALE_TEMP_S` (only the names :func:`~ndbg_cli.core.files.write_atomic` gives an
    entry's, in the entry's own folder)."""
    return [(st.st_size, path) for _, path, st in _files(root, "??/.*.tmp", _TEMP)
            if st.st_mtime < now - STALE_TEMP_S]


def usage(root: str | Path) -> dict:
    """``{"entries": n, "bytes": b, "stages": {stage: {"entries": n, "bytes": b}}}`` of the
    cache directory ``root`` (zeros when it does not exist)."""
    stages: dict[str, dict[str, int]] = {}
    for _, size, stage, _ in _entries(Path(root)):
        st = stages.setdefault(stage, {"entries": 0, "bytes": 0})
        st["entries"] += 1
        st["bytes"] += size
    return {"entries": sum(s["entries"] for s in stages.values()),
            "bytes": sum(s["bytes"] for s in stages.values()),
            "stages": dict(sorted(stages.items()))}


def trim(root: str | Path, limit: int | None) -> tuple[int, int]:
    """Remove the stale temporary files of the cache ``root`` (:func:`_stale_temps`), then
    its least recently used entries while it holds more than ``limit`` bytes, down to
    :data:`TRIM_TO` of it (``None``: no limit). Returns ``(files removed, bytes freed)``;
    files that cannot be removed are left (never an error).

    After each ``analyze`` / ``check`` run the CLI trims the cache to ``$NDBG_CACHE_MAX_MB``
    megabytes (:data:`DEFAULT_MAX_MB`; 0: no limit), so a CI runner's cache stays bounded
    however many part versions it sees. Temporary files of writes that never finished (a run
    killed between writing and renaming) go once :data:`STALE_TEMP_S` seconds old."""
    removed = freed = 0
    for size, path in _stale_temps(Path(root), time.time()):
        try:
            path.unlink()
        except OSError:
            continue
        removed += 1
        freed += size
    if limit is None:
        return removed, freed
    entries = _entries(Path(root))
    total = sum(e[1] for e in entries)
    if total <= limit:
        return removed, freed
    gone = freed  # the temporary files were not part of the total
    for _, size, _, path in sorted(entries, key=lambda e: (e[0], str(e[3]))):
        if total - (freed - gone) <= TRIM_TO * limit:
            break
        try:
            path.unlink()
        except FileNotFoundError:  # another run trimmed it: gone all the same
            freed += size
            continue
        except OSError:
            continue
        removed += 1
        freed += size
    return removed, freed


def clear(root: str | Path) -> tuple[int, int]:
    """Remove every entry of the cache ``root`` (a trim to nothing); ``(entries removed,
    bytes freed)``."""
    return trim(root, 0)

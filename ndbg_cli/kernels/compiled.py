"""Kernels compiled ahead of time: the entry points of a numba kernel module (its ``EXPORTS``)
built by numba's ``pycc`` into a plain extension module beside it.

Numba's start costs about 0.5 s of CPU in each process that calls a kernel: 0.15-0.3 s to
import numba, and 0.25 s at the first call to set up its compiler, even when the machine code
comes from numba's cache. On a product of tens of parts that is most of what the analysis costs
beyond reading the model. A module built ahead of time imports in a millisecond and needs
neither numba nor LLVM to run. ``make bytecode`` builds one per kernel module of
:data:`BUILT` (``python -m ndbg_cli.kernels``: about 50 s for the seven with
the machine's C compiler, once, and again only when a module's source, or that of a kernel
module it imports, changes).

One implementation: the compiled module is built from the numba source, by the same compiler
(LLVM, no fast-math, no fused multiply-add that the source does not ask for), so its results
are the just-in-time kernels' to the bit (``tests/test_compiled_kernels.py`` compares them).
It records the SHA-256 of the source it was built from (its module's and those its module
imports, with numpy's, numba's and llvmlite's versions), and :func:`kernels` takes it only
when that is the source and stack beside it: a stale build is never run. Its functions read
their arrays' memory as declared, unchecked, so :func:`kernels` puts each behind a
conversion to the declared type and layout (and writes back into the caller's array an
argument its module's ``WRITES`` says it writes, when it had to be copied).
Without a build (no C compiler, a plain ``pip install``), or with ``NUMBA_DISABLE_JIT`` set,
the kernels run through numba's just-in-time compiler as before.
"""

from __future__ import annotations

import ast
import functools
import hashlib
import importlib
import importlib.util
import os
import re
import subprocess
import sys
import tempfile
import time
import warnings
from collections.abc import Callable
from pathlib import Path
from types import SimpleNamespace

import numpy as np

__all__ = ["BUILT", "BuildError", "build", "kernels", "loaded"]

#: Kernel modules built ahead of time -> the name of their compiled module: the sweep test's
#: (every proof calls it), the box hierarchy's (every run's finger probes and narrow phase),
#: the triangle predicates' (every run's narrow phase) and the exact infinite family's. That
#: family serves the small products too (tens of parts), where numba's start was most of the
#: analysis, and the proof that no plan exists on large ones.
BUILT = {name: f"{name}_aot" for name in (
    "_sweep_kernels", "_box_kernels", "_triangle_kernels", "_cone_kernels", "_cover_kernels",
    "_term_kernels", "_union_kernels")}

_HERE = Path(__file__).resolve().parent


def _digest(source: bytes) -> int:
    """The first 8 bytes of the SHA-256 of a kernel module's ``source``, numpy's version and
    numba's and llvmlite's version files, as a signed int64 (what a compiled function
    returns): a build is stale when any of them changed (found without importing numba)."""
    h = hashlib.sha256(source)
    h.update(np.__version__.encode())
    for package in ("numba", "llvmlite"):
        spec = importlib.util.find_spec(package)
        where = None if spec is None else spec.submodule_search_locations
        if not where:
            raise ImportError(f"{package} is not installed")
        h.update(Path(where[0], "_version.py").read_bytes())
    return int.from_bytes(h.digest()[:8], "little", signed=True)


def _source(module: str) -> bytes:
    return (_HERE / f"{module}.py").read_bytes()


#: ``from .x import ...`` or ``from . import x, y`` (parenthesized over lines too), at any
#: indentation: read with a pattern first, as parsing a kernel module costs 5-10 ms (12-30 ms
#: with the modules it imports) at every run's first kernel. A match in a docstring can only
#: add a module to the digest.
_LOCAL_IMPORT = re.compile(rb"^[ \t]*from[ \t]+\.(\w*)[ \t]+import[ \t]+(\([^)]*\)|[^\n]*)",
                           re.MULTILINE)
#: Every ``from .``: where the pattern above does not account for each one plainly (a comment,
#: a continuation or a ``;`` in it, another layout), the module is parsed instead.
_FROM_DOT = re.compile(rb"\bfrom\s+\.")


def _local_imports(module: str) -> set[str]:
    """The modules of this package that ``module`` imports (``from .x import ...``,
    ``from . import x``; anywhere in the file), read from its source."""
    source = _source(module)
    plain = _LOCAL_IMPORT.findall(source)
    if len(plain) != len(_FROM_DOT.findall(source)) or any(
            c in names for _, names in plain for c in (b"#", b"\\", b";")):
        found = set()
        for node in ast.walk(ast.parse(source)):
            if isinstance(node, ast.ImportFrom) and node.level == 1:
                found |= {node.module} if node.module else {a.name for a in node.names}
    else:
        found = {package.decode() for package, _ in plain if package} | {
            n.split()[0] for package, names in plain if not package
            for n in names.decode().strip("()").split(",") if n.split()}
    return {n for n in found if (_HERE / f"{n}.py").is_file()}


def _built_from(module: str) -> bytes:
    """The source a build of ``module`` compiles: its own, then that of each module of this
    package it imports, directly or not (their kernels are compiled into it), by name."""
    seen, todo = set(), [module]
    while todo:
        name = todo.pop()
        if name not in seen:
            seen.add(name)
            todo += sorted(_local_imports(name))
    return b"".join(_source(name) for name in [module, *sorted(seen - {module})])


def _compiled(module: str) -> SimpleNamespace | None:
    """The ``EXPORTS`` of ``module``'s compiled module, each behind :func:`_checked`, when it
    is built from the source beside it (read once: its digest and its ``EXPORTS``), else
    None."""
    try:
        compiled = importlib.import_module(f"{__package__}.{BUILT[module]}")
        source = _source(module)
        if compiled.source_digest() != _digest(_built_from(module)):
            return None
        writes = _writes(source.decode())
        return SimpleNamespace(**{n: _checked(getattr(compiled, n), sig, writes.get(n, ()))
                                  for n, sig in _exports(source.decode()).items()},
                               compiled=True)
    except Exception:  # noqa: BLE001 - not built, built for another numpy: numba's then
        return None


def _split(text: str) -> list[str]:
    """``text`` split at its commas outside brackets and parentheses."""
    out, depth, start = [], 0, 0
    for k, ch in enumerate(text):
        depth += (ch in "[(") - (ch in "])")
        if ch == "," and depth == 0:
            out.append(text[start:k])
            start = k + 1
    return out + [text[start:]]


def _arguments(signature: str) -> list:
    """The arguments of a numba signature string such as ``"f8[::1](f8[:,:,::1],f8)"``, each
    ``(dtype, ndim)`` for an array, ``None`` for a scalar and a list of these for a tuple
    (``Tuple((i8[::1],f8))``)."""
    depth = 0
    for k in range(len(signature) - 1, -1, -1):  # the opening of the last group
        depth += (signature[k] == ")") - (signature[k] == "(")
        if depth == 0:
            break
    return _specs(signature[k + 1:-1])


_DTYPES = {"f8": np.float64, "i8": np.int64, "i4": np.int32, "b1": np.bool_}


def _specs(text: str) -> list:
    out: list = []
    for a in _split(text):
        if a.startswith("Tuple((") and a.endswith("))"):
            out.append(_specs(a[len("Tuple(("):-2]))
        else:
            out.append((np.dtype(_DTYPES[a[:2]]), a.count(",") + 1) if "[" in a else None)
    return out


def _convert(name: str, value: object, spec: object) -> object:
    """``value`` as the compiled function ``name`` reads an argument of ``spec``
    (:func:`_arguments`)."""
    if spec is None:
        return value
    if isinstance(spec, list):
        if not isinstance(value, tuple) or len(value) != len(spec):
            raise TypeError(f"{name}: a tuple of {len(spec)} expected")
        return tuple(_convert(name, v, s) for v, s in zip(value, spec))
    a = np.ascontiguousarray(value, dtype=spec[0])
    if a.ndim != spec[1]:
        raise TypeError(f"{name}: an argument has {a.ndim} dimensions, not {spec[1]}")
    return a


def _written(name: str, value: object, spec: tuple) -> np.ndarray:
    """The array the compiled function ``name`` writes into for the argument ``value`` (of
    ``spec``): ``value`` itself when C-contiguous, else a copy to write back. What the
    just-in-time kernel refuses to write into (a read-only array) or would write as another
    type is refused."""
    if not (isinstance(value, np.ndarray) and value.flags.writeable
            and value.dtype == spec[0] and value.ndim == spec[1]):
        raise TypeError(f"{name} writes into an argument: a writeable {spec[0]} array of "
                        f"{spec[1]} dimensions is needed")
    return value if value.flags.c_contiguous else np.ascontiguousarray(value)


def _checked(fn: Callable, signature: str, writes: tuple[int, ...] = ()) -> Callable:
    """``fn`` (compiled ahead of time for ``signature`` only, which reads its arrays' memory
    as the declared type, layout and dimensions, unchecked) taking what numba's dispatcher
    takes: each array argument (in a tuple too) converted to a C-contiguous array of the
    declared type (not copied when it is one already; another type or layout is copied, as
    the just-in-time kernel would compile another version), and one of another dimension
    refused. The arguments ``writes`` (positions: the kernel writes into them, its module's
    ``WRITES``) are written into the caller's array, as the just-in-time kernel does: a
    copy made for their layout (``update_sat`` into a window of a table) is written back."""
    specs = _arguments(signature)
    name = getattr(fn, "__name__", "kernel")

    def call(*args: object) -> object:
        got = [_written(name, a, s) if k in writes else _convert(name, a, s)
               for k, (a, s) in enumerate(zip(args, specs))] + list(args[len(specs):])
        out = fn(*got)
        for k in writes:
            if got[k] is not args[k]:
                args[k][...] = got[k]
        return out

    call.__name__ = call.__qualname__ = name
    call.__doc__ = fn.__doc__
    return call


def kernels(module: str) -> SimpleNamespace:
    """The kernels of ``module`` (a name of :data:`BUILT`) that its ``EXPORTS`` lists: the
    compiled module's when built from the current source and stack (each behind
    :func:`_checked`), else the numba module's own (compiled just in time). Either way
    only the ``EXPORTS``, so that a kernel a caller uses but the build lacks fails on every
    machine alike.

    Examples
    --------
    >>> from ndbg_cli.kernels.compiled import kernels
    >>> import numpy as np
    >>> t = np.array([[[0.0, 0, 0], [1, 0, 0], [0, 1, 2]]])  # one triangle (u, v, z)
    >>> kernels("_sweep_kernels").boxes(t).tolist()  # (u_lo, v_lo, u_hi, v_hi, z_lo, z_hi)
    [[0.0, 0.0, 1.0, 1.0, 0.0, 2.0]]
    """
    got = None if _jit_disabled() else _compiled(module)
    if got is not None:
        return got
    source = importlib.import_module(f"{__package__}.{module}")
    return SimpleNamespace(**{n: getattr(source, n) for n in source.EXPORTS}, compiled=False)


@functools.cache
def loaded(module: str) -> SimpleNamespace:
    """:func:`kernels` of ``module``, found once per process: what the callers use (the
    compiled module's digest is read once, not at each call)."""
    return kernels(module)


def _jit_disabled() -> bool:
    return os.environ.get("NUMBA_DISABLE_JIT", "0") not in ("", "0")


def _exports(text: str) -> dict[str, str]:
    """The ``EXPORTS`` of a kernel module's source ``text`` (:func:`_literal`)."""
    got = _literal(text, "EXPORTS")
    if got is None:
        raise ValueError("no EXPORTS")
    return got


def _writes(text: str) -> dict[str, tuple[int, ...]]:
    """The ``WRITES`` of a kernel module's source ``text`` (entry point -> the positions of
    the arguments it writes into; :func:`_literal`), else none."""
    return _literal(text, "WRITES") or {}


def _literal(text: str, name: str) -> dict | None:
    """The dict literal assigned to ``name`` at the start of a line of a kernel module's
    source ``text``, read without importing the module (which imports numba) or parsing all
    of it: from its ``{`` to the brace closing it; None without one."""
    start = text.find(f"\n{name} = {{")
    if start < 0:
        return None
    start = text.index("{", start)
    depth = 0
    for end in range(start, len(text)):
        depth += (text[end] == "{") - (text[end] == "}")
        if depth == 0:
            return ast.literal_eval(text[start:end + 1])
    raise ValueError(f"{name}: no closing brace")


def _returning(value: int) -> Callable[[], int]:
    """A function returning ``value`` (numba freezes it into the compiled code)."""

    def source_digest() -> int:
        return value

    return source_digest


def build(force: bool = False) -> list[str]:
    """Build the compiled module of each kernel module of :data:`BUILT` whose build is
    missing or stale (all with ``force``), beside its source; returns the names built.

    The module is compiled in a temporary folder, imported there by a new interpreter (its
    digest read back), and only then moved into place whole: a process
    importing it meanwhile sees the old file or the new one, never a part (a truncated
    extension module crashes the interpreter that loads it, past any ``except``). A build
    that failed is not tried again for the same digest (``NAME.failed`` beside it) unless
    ``force``. A module that fails leaves the others to be built: :class:`BuildError` then
    says which failed and which were built."""
    done, errors = [], []
    for module, name in BUILT.items():
        failed, digest = _HERE / f"{name}.failed", None
        try:
            digest = _digest(_built_from(module))
            if not force and (_compiled(module) is not None or (
                    failed.exists() and failed.read_text().strip() == str(digest))):
                continue
            _build_one(module, name, digest)
        except Exception as exc:  # noqa: BLE001 - the others are still built; raised below
            if digest is not None:  # not tried again for this source (unless forced)
                failed.write_text(f"{digest}\n")
            errors.append(f"{name}: {exc}")
            continue
        failed.unlink(missing_ok=True)
        done.append(name)
    if errors:
        raise BuildError(done, errors)
    return done


class BuildError(RuntimeError):
    """Some kernel modules could not be built (``failed``: ``"name: why"`` each); ``done``
    names those that were."""

    def __init__(self, done: list[str], failed: list[str]) -> None:
        super().__init__("; ".join(failed))
        self.done, self.failed = done, failed


def _build_one(module: str, name: str, digest: int) -> None:
    """Compile ``module``'s ``EXPORTS`` into ``name`` beside it, recording ``digest``."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # pycc is "pending deprecation" in numba 0.6x
        from numba.pycc import CC
    source = importlib.import_module(f"{__package__}.{module}")
    cc = CC(name)
    for fn, signature in source.EXPORTS.items():
        cc.export(fn, signature)(getattr(source, fn).py_func)
    cc.export("source_digest", "i8()")(_returning(digest))
    with tempfile.TemporaryDirectory(dir=_HERE, prefix=".build-") as tmp:
        cc.output_dir = tmp
        cc.compile()
        (out,) = Path(tmp).glob(f"{name}.*")
        if _digest(_built_from(module)) != digest:
            raise RuntimeError(f"{module}.py changed during the build")
        with open(out, "rb") as f:
            os.fsync(f.fileno())
        probe = ("import importlib.util as u, sys; "
                 f"s = u.spec_from_file_location({name!r}, sys.argv[1]); "
                 "m = u.module_from_spec(s); s.loader.exec_module(m); print(m.source_digest())")
        got = subprocess.run([sys.executable, "-c", probe, str(out)], capture_output=True,
                             text=True, timeout=120)
        if got.returncode != 0 or got.stdout.strip() != str(digest):
            raise RuntimeError(f"the built {out.name} does not load ({got.returncode}): "
                               f"{got.stderr.strip()[-300:]}")
        os.replace(out, _HERE / out.name)
    importlib.invalidate_caches()


def main() -> int:
    """``python -m ndbg_cli.kernels [--force]``: build what is stale, say
    what was done on stderr; exit 1 when a build fails (the kernels then run just in time)."""
    t0 = time.perf_counter()
    failed = []
    try:
        done = build(force="--force" in sys.argv[1:])
    except BuildError as exc:
        done, failed = exc.done, exc.failed
    except Exception as exc:  # noqa: BLE001 - reported, with what it means
        done, failed = [], [str(exc)]
    for why in failed:
        print(f"ndbg: kernels could not be compiled ahead of time ({why}); numba will compile "
              "them at run time (about 0.5 s more per run that needs them)", file=sys.stderr)
    if done:
        print(f"ndbg: compiled {', '.join(done)} ahead of time in "
              f"{time.perf_counter() - t0:.1f} s", file=sys.stderr)
    return 1 if failed else 0


"""Kernels compiled ahead of time: the entry points of a numba kernel module (its ``EXPORTS``)
built by numba's ``pycc`` into a plain extension module beside it.

Numba's start costs about 0.4 s of CPU in each process that calls a kernel: 0.15 s to import
numba, and 0.25 s at the first call to set up its compiler, even when the machine code comes
from numba's cache. On a product of tens of parts that is most of what the analysis costs
beyond reading the model. A module built ahead of time imports in a millisecond and needs
neither numba nor LLVM to run. ``make bytecode`` builds it (``python -m
ndbg_cli.ndbg.infinite._compiled``: about 11 s with the machine's C compiler, once, and again
only when the kernels' source changes).

One implementation: the compiled module is built from the numba source, by the same compiler
(LLVM, no fast-math, no fused multiply-add that the source does not ask for), so its results
are the just-in-time kernels' to the bit (``tests/test_compiled_kernels.py`` compares them).
It records the SHA-256 of the source it was built from, and :func:`kernels` takes it only when
that is the source beside it: a stale build is never run. Without a build (no C compiler, a
plain ``pip install``), or with ``NUMBA_DISABLE_JIT`` set, the kernels run through numba's
just-in-time compiler as before.
"""

from __future__ import annotations

import hashlib
import importlib
import os
import sys
import tempfile
import time
import warnings
from collections.abc import Callable
from pathlib import Path
from types import ModuleType

__all__ = ["BUILT", "build", "kernels"]

#: Kernel modules built ahead of time -> the name of their compiled module. Only the sweep
#: test's: every proof calls it, while the other kernels serve the exact infinite family,
#: whose cost dwarfs numba's start.
BUILT = {"_sweep_kernels": "_sweep_kernels_aot"}

_HERE = Path(__file__).resolve().parent


def _digest(module: str) -> int:
    """The first 8 bytes of the SHA-256 of ``module``'s source file, as a signed int64 (what
    a compiled function returns)."""
    source = (_HERE / f"{module}.py").read_bytes()
    return int.from_bytes(hashlib.sha256(source).digest()[:8], "little", signed=True)


def _compiled(module: str) -> ModuleType | None:
    """``module``'s compiled module when it is built from the source beside it, else None."""
    try:
        compiled = importlib.import_module(f"{__package__}.{BUILT[module]}")
        return compiled if compiled.source_digest() == _digest(module) else None
    except Exception:  # noqa: BLE001 - not built, built for another numpy: numba's then
        return None


def kernels(module: str) -> ModuleType:
    """The kernels of ``module`` (a name of :data:`BUILT`): its compiled module when built
    from the current source, else the numba module itself (compiled just in time).

    Examples
    --------
    >>> from ndbg_cli.ndbg.infinite._compiled import kernels
    >>> import numpy as np
    >>> t = np.array([[[0.0, 0, 0], [1, 0, 0], [0, 1, 2]]])  # one triangle (u, v, z)
    >>> kernels("_sweep_kernels").boxes(t).tolist()  # (u_lo, v_lo, u_hi, v_hi, z_lo, z_hi)
    [[0.0, 0.0, 1.0, 1.0, 0.0, 2.0]]
    """
    if os.environ.get("NUMBA_DISABLE_JIT", "0") in ("", "0"):
        got = _compiled(module)
        if got is not None:
            return got
    return importlib.import_module(f"{__package__}.{module}")


def _returning(value: int) -> Callable[[], int]:
    """A function returning ``value`` (numba freezes it into the compiled code)."""

    def source_digest() -> int:
        return value

    return source_digest


def build(force: bool = False) -> list[str]:
    """Build the compiled module of each kernel module of :data:`BUILT` whose build is
    missing or stale (all with ``force``), beside its source; returns the names built. The
    module is written to a temporary folder first and moved into place whole, so that a
    process importing it meanwhile sees the old file or the new one."""
    done = []
    for module, name in BUILT.items():
        if not force and _compiled(module) is not None:
            continue
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # pycc is "pending deprecation" in numba 0.6x
            from numba.pycc import CC
        source = importlib.import_module(f"{__package__}.{module}")
        cc = CC(name)
        for fn, signature in source.EXPORTS.items():
            cc.export(fn, signature)(getattr(source, fn).py_func)
        cc.export("source_digest", "i8()")(_returning(_digest(module)))
        with tempfile.TemporaryDirectory(dir=_HERE) as tmp:
            cc.output_dir = tmp
            cc.compile()
            (out,) = Path(tmp).glob(f"{name}.*")
            os.replace(out, _HERE / out.name)
        importlib.invalidate_caches()
        done.append(name)
    return done


def main() -> int:
    """``python -m ndbg_cli.ndbg.infinite._compiled [--force]``: build what is stale, say
    what was done on stderr; exit 1 when a build fails (the kernels then run just in time)."""
    t0 = time.perf_counter()
    try:
        done = build(force="--force" in sys.argv[1:])
    except Exception as exc:  # noqa: BLE001 - reported, with what it means
        print(f"ndbg: the kernels could not be compiled ahead of time ({exc}); numba will "
              "compile them at run time (about 0.4 s more per run)", file=sys.stderr)
        return 1
    if done:
        print(f"ndbg: compiled {', '.join(done)} ahead of time in "
              f"{time.perf_counter() - t0:.1f} s", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())

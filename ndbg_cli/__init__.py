"""ndbg: assembly sequencing and complexity analysis with non-directional blocking graphs.

Library API (the CLI is a thin layer over it)::

    import ndbg_cli
    asm = ndbg_cli.load("assemblies/bell.yaml")     # -> Assembly
    report = ndbg_cli.analyze(asm)                   # -> dict (the JSON report)
"""

import os as _os

from ._version import __version__

# Every matrix ndbg hands to BLAS/LAPACK is tiny (6 x 6 systems, m x 6 SVDs): threads buy
# nothing there, and on a busy machine (a CI runner, ``--jobs N`` workers) their spinning
# made single SVDs many times slower (benchmarks/NOTES.md). One thread each, unless the caller
# chose (only effective when numpy is not imported yet: the CLI and its worker processes).
for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    _os.environ.setdefault(_var, "1")

from .core.assembly import Assembly, Diagnostic, Joint, Part  # noqa: E402
from .core.errors import InputError, NdbgError  # noqa: E402
from .io.loaders import discover, load  # noqa: E402
from .pipeline.analysis import Options, analyze, analyze_path  # noqa: E402

__all__ = ["__version__", "Assembly", "Part", "Joint", "Diagnostic", "InputError", "NdbgError",
           "load", "discover", "analyze", "analyze_path", "Options"]

"""ndbg: assembly sequencing and complexity analysis with non-directional blocking graphs.

Library API (the CLI is a thin layer over it)::

    import ndbg_cli
    asm = ndbg_cli.load("assemblies/bell.yaml")     # -> Assembly
    report = ndbg_cli.analyze(asm)                   # -> dict (the JSON report)
"""

__version__ = "0.1.0"

from .analysis import Options, analyze, analyze_path  # noqa: E402
from .assembly import Assembly, Diagnostic, Joint, Part  # noqa: E402
from .errors import InputError, NdbgError  # noqa: E402
from .loaders import discover, load  # noqa: E402

__all__ = ["__version__", "Assembly", "Part", "Joint", "Diagnostic", "InputError", "NdbgError",
           "load", "discover", "analyze", "analyze_path", "Options"]

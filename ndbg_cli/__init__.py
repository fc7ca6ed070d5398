"""ndbg: assembly sequencing and complexity analysis with non-directional blocking graphs.

Library API (the CLI is a thin layer over it)::

    import ndbg_cli
    asm = ndbg_cli.load("assemblies/bell.yaml")     # -> Assembly
    report = ndbg_cli.analyze(asm)                   # -> dict (the JSON report)
    contacts = ndbg_cli.find_contacts(asm)           # or the stages one by one:
    family = ndbg_cli.build_ndbg(asm, "infinitesimal_translation", contacts)

The names are imported on first use (PEP 562), so that ``import ndbg_cli`` and the CLI's
``--help`` do not pay for numpy, trimesh and the compiled kernels.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

from ._version import __version__

#: Public name -> the module that defines it.
_API = {
    "Assembly": "core.assembly", "Part": "core.assembly", "Joint": "core.assembly",
    "Diagnostic": "core.assembly", "InputError": "core.errors", "NdbgError": "core.errors",
    "Options": "core.options", "load": "io.loaders", "discover": "io.formats",
    "analyze": "pipeline.analysis", "analyze_path": "pipeline.analysis",
    "find_contacts": "pipeline.stages", "build_ndbg": "pipeline.stages",
    "measure": "pipeline.stages", "plan_assembly": "pipeline.stages",
}

__all__ = ["__version__", "Assembly", "Part", "Joint", "Diagnostic", "InputError", "NdbgError",
           "Options", "load", "discover", "analyze", "analyze_path", "find_contacts",
           "build_ndbg", "measure", "plan_assembly"]


def __getattr__(name: str) -> Any:
    module = _API.get(name)
    if module is None:
        raise AttributeError(f"module 'ndbg_cli' has no attribute {name!r}")
    value = getattr(importlib.import_module(f".{module}", __name__), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(__all__)


if TYPE_CHECKING:
    from .core.assembly import Assembly, Diagnostic, Joint, Part
    from .core.errors import InputError, NdbgError
    from .core.options import Options
    from .io.formats import discover
    from .io.loaders import load
    from .pipeline.analysis import analyze, analyze_path
    from .pipeline.stages import build_ndbg, find_contacts, measure, plan_assembly

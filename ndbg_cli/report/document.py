"""Reports: deterministic JSON and the report JSON Schema.

Determinism: the same input gives byte-identical JSON. Keys are sorted, lists are built in a
stable order by the stages, floats are rounded to :data:`FLOAT_DIGITS` significant digits
(and magnitudes below :data:`ZERO`, ``-0.0`` included, become ``0.0``), and wall-clock
timings are left out unless asked for (``timings`` is then ``{}``), since they differ on every
run.

Text is written through :mod:`ndbg_cli.core.files` (atomic, file-name bytes escaped).
"""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import numpy as np

from ..core.files import printable

#: Version of the report format; bumped on any incompatible change.
REPORT_SCHEMA = "ndbg.report/1"
BATCH_SCHEMA = "ndbg.batch/1"
CONTACTS_SCHEMA = "ndbg.contacts/1"
QUERY_SCHEMA = "ndbg.query/1"
REMOVE_SCHEMA = "ndbg.remove/1"
#: Significant digits kept for every float in a report.
FLOAT_DIGITS = 9
#: Floats of smaller magnitude are written as 0.0 (numerical noise such as 1e-22 in a unit
#: vector; far below any length, area or volume tolerance in any supported unit).
ZERO = 1e-15


def validate_report(doc: dict) -> None:
    """Raise ``jsonschema.ValidationError`` if ``doc`` is not a valid report or batch."""
    import jsonschema

    from ..core.schemas import report_schema

    jsonschema.Draft202012Validator(report_schema()).validate(doc)


def clean(value: Any) -> Any:
    """JSON-ready copy of ``value``: numpy types to Python, floats rounded, tuples to lists,
    strings :func:`printable` (a file name that is not UTF-8 would otherwise fail the
    encoding of the whole report)."""
    if isinstance(value, str):
        return printable(value)
    if isinstance(value, dict):
        return {printable(str(k)): clean(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [clean(v) for v in value]
    if isinstance(value, np.ndarray):
        return clean(value.tolist())
    if isinstance(value, (bool, np.bool_)):
        return bool(value)
    if isinstance(value, (int, np.integer)):
        return int(value)
    if isinstance(value, (float, np.floating)):
        x = float(value)
        if not math.isfinite(x):
            return None
        x = float(f"{x:.{FLOAT_DIGITS}g}")
        return 0.0 if abs(x) < ZERO else x
    return value


def dumps(doc: dict) -> str:
    """Deterministic JSON text of a report (sorted keys, 2-space indent, trailing newline)."""
    return json.dumps(clean(doc), sort_keys=True, indent=2, ensure_ascii=False) + "\n"


def identity(report: dict) -> tuple[str, str]:
    """``(name, source)`` of a report or error record: the assembly's name and source file,
    or, for an error record (no assembly), the stem and path of the input it was made for."""
    a = report.get("assembly") or {}
    source = str(a.get("source") or report.get("source") or "")
    return str(a.get("name") or Path(source or "?").stem), source

"""Reports: deterministic JSON, the report JSON Schema, atomic writes.

Determinism: the same input gives byte-identical JSON. Keys are sorted, lists are built in a
stable order by the stages, floats are rounded to :data:`FLOAT_DIGITS` significant digits
(and ``-0.0`` becomes ``0.0``), and wall-clock timings are left out unless asked for
(``timings`` is then ``{}``), since they differ on every run.
"""

from __future__ import annotations

import json
import math
import os
import tempfile
from importlib import resources
from pathlib import Path
from typing import Any

import numpy as np

#: Version of the report format; bumped on any incompatible change.
REPORT_SCHEMA = "ndbg.report/1"
BATCH_SCHEMA = "ndbg.batch/1"
#: Significant digits kept for every float in a report.
FLOAT_DIGITS = 9

_SCHEMA: dict | None = None


def report_schema() -> dict:
    """The report's JSON Schema, shipped in ``ndbg_cli/schemas/report.schema.json``."""
    global _SCHEMA
    if _SCHEMA is None:
        text = resources.files("ndbg_cli").joinpath("schemas/report.schema.json").read_text()
        _SCHEMA = json.loads(text)
    return _SCHEMA


def validate_report(doc: dict) -> None:
    """Raise ``jsonschema.ValidationError`` if ``doc`` is not a valid report or batch."""
    import jsonschema

    jsonschema.Draft202012Validator(report_schema()).validate(doc)


def clean(value: Any) -> Any:
    """JSON-ready copy of ``value``: numpy types to Python, floats rounded, tuples to lists."""
    if isinstance(value, dict):
        return {str(k): clean(v) for k, v in value.items()}
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
        return 0.0 if x == 0 else x
    return value


def dumps(doc: dict) -> str:
    """Deterministic JSON text of a report (sorted keys, 2-space indent, trailing newline)."""
    return json.dumps(clean(doc), sort_keys=True, indent=2, ensure_ascii=False) + "\n"


def write_atomic(path: str | Path, text: str) -> None:
    """Write ``text`` to ``path`` atomically: a temporary file in the same folder, fsynced,
    then renamed over the target, so a reader never sees a half-written report."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    try:
        with os.fdopen(fd, "w", encoding="utf-8") as fh:
            fh.write(text)
            fh.flush()
            os.fsync(fh.fileno())
        os.replace(tmp, path)
    except BaseException:
        try:
            os.unlink(tmp)
        except OSError:
            pass
        raise

"""YAML config files: settings for :class:`~ndbg_cli.core.options.Options` (see
``configs/default.yaml``), checked with the same types and ranges as the command line."""

from __future__ import annotations

import dataclasses
from pathlib import Path

from ..core.errors import InputError
from ..core.options import Options, setting_problem
from ..core.units import canonical_unit
from .manifest import read_located


def read_config(path: str | Path) -> dict:
    """Settings from a YAML config file (see ``configs/default.yaml``): a mapping whose keys
    are :class:`Options` fields. Unknown keys and bad values are input errors."""
    doc = read_located(path, "config", "a config must be a YAML mapping", empty_ok=True)
    data = doc.data
    # ``workers`` comes from --jobs only (one assembly; a batch spreads its assemblies),
    # ``mapper`` from --scheduler, ``progress`` from --quiet (one assembly; a batch shows
    # its own bar) and ``contact_points`` from --detail
    fields = {f.name for f in dataclasses.fields(Options)} - {"workers", "mapper", "progress",
                                                               "contact_points"}
    unknown = sorted(set(map(str, data)) - fields)
    if unknown:
        raise InputError(f"unknown setting '{unknown[0]}' (known: {', '.join(sorted(fields))})",
                         file=str(path), line=doc.line((unknown[0],)))
    for name, value in data.items():
        problem = setting_problem(name, value)
        if problem:
            raise doc.error((name,), problem)
    if data.get("units") is not None:
        try:
            data["units"] = canonical_unit(data["units"], file=str(path))
        except InputError as exc:
            raise doc.error(("units",), exc.problem) from None
    return data

"""The JSON Schemas ndbg ships (``ndbg_cli/schemas``): the report's, with the stages' fragments
embedded, and the manifest's. Read with the standard library only, so that ``ndbg schema``
starts fast."""

from __future__ import annotations

import json
from functools import cache
from importlib import resources

#: Stage fragments (``schemas/fragments/NAME.json``) embedded in the report schema.
FRAGMENTS = ("infinitesimal", "infinite", "generalized", "planning")


def read_schema(name: str) -> dict:
    """The shipped schema file ``schemas/NAME`` as a dict (a fresh copy each call)."""
    return json.loads(resources.files("ndbg_cli").joinpath(f"schemas/{name}").read_text())


@cache
def report_schema() -> dict:
    """The report's JSON Schema: ``schemas/report.schema.json`` with the stages' fragments
    (``schemas/fragments/*.json``) embedded under ``$defs`` as resources with ids
    ``urn:ndbg:report:1:NAME``, so that ``ndbg schema`` prints one self-contained document."""
    doc = read_schema("report.schema.json")
    for key, sub in read_schema("fragments/contacts.json").items():
        doc["$defs"][key] = sub
    for name in FRAGMENTS:
        frag = read_schema(f"fragments/{name}.json")
        frag.pop("$schema", None)
        frag["$id"] = f"urn:ndbg:report:1:{name}"
        doc["$defs"][f"fragment_{name}"] = frag
    return doc


@cache
def manifest_schema() -> dict:
    """The manifest's JSON Schema (``schemas/manifest.schema.json``)."""
    return read_schema("manifest.schema.json")

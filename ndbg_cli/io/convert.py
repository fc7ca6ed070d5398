"""``ndbg convert``: an assembly (e.g. a STEP file) to per-part meshes plus a manifest."""

from __future__ import annotations

import re
from pathlib import Path

import yaml

from ..core.assembly import Assembly
from ..core.errors import InputError
from ..core.files import write_atomic
from .formats import MODEL_SUFFIXES


def safe_name(part_id: str) -> str:
    """A file-name-safe version of a part id, without a model file's suffix (a part read from
    ``b.stl`` is named ``b.stl``; its mesh is ``b.stl``, not ``b.stl.stl``)."""
    name = re.sub(r"[^A-Za-z0-9_.-]+", "_", part_id).strip("._")
    stem, dot, suffix = name.rpartition(".")
    if dot and stem and f".{suffix.lower()}" in MODEL_SUFFIXES:
        name = stem.strip("._")
    return name or "part"


def convert_assembly(asm: Assembly, out: Path, *, force: bool = False) -> Path:
    """Write ``out/meshes/<id>.stl`` (binary, in the assembly frame and unit) for every part
    and ``out/<name>.yaml``; return the manifest's path. Refuses to overwrite an existing
    manifest unless ``force``."""
    if asm.dimension != 3:
        raise InputError("convert writes meshes: 2D assemblies are manifests already",
                         file=asm.source)
    out = Path(out)
    manifest = out / f"{safe_name(asm.name)}.yaml"
    if manifest.exists() and not force:
        raise InputError("manifest exists (use --force to overwrite)", file=str(manifest))
    (out / "meshes").mkdir(parents=True, exist_ok=True)
    used: set[str] = set()
    parts = []
    for p in asm.parts:
        name, k = safe_name(p.id), 1
        while name.lower() in used:
            k += 1
            name = f"{safe_name(p.id)}-{k}"
        used.add(name.lower())
        rel = f"meshes/{name}.stl"
        # atomically: a failed write leaves no partial mesh (nor a .tmp file) behind
        write_atomic(out / rel, p.mesh.export(file_type="stl"))
        entry = {"id": p.id, "mesh": rel}
        if p.fixed:
            entry["fixed"] = True
        parts.append(entry)
    doc = {"name": asm.name, "units": asm.units, "parts": parts}
    if asm.tolerance is not None:
        doc["tolerance"] = asm.tolerance
    if asm.joints:
        doc["joints"] = [{"type": j.type, "parts": list(j.parts), "axis": list(j.axis),
                          "point": list(j.point), "pitch": j.pitch} for j in asm.joints]
    header = f"# converted by ndbg from {asm.source}\n"
    write_atomic(manifest, header + yaml.safe_dump(doc, sort_keys=False))
    return manifest

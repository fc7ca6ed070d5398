"""The input formats ndbg reads, by file suffix, and which of their readers are native code.

A light module (no numpy, no trimesh): the CLI consults it before it imports the stages, to
start a native reader's child process early (:func:`prestart_reader`).
"""

from __future__ import annotations

from pathlib import Path

from .isolated import prestart

MANIFEST_SUFFIXES = {".yaml", ".yml"}
CAD_SUFFIXES = {".step", ".stp", ".iges", ".igs"}
SCENE_SUFFIXES = {".glb", ".gltf", ".3dxml", ".3mf", ".obj"}
MESH_SUFFIXES = {".stl", ".ply", ".off", ".obj", ".glb"}
MODEL_SUFFIXES = CAD_SUFFIXES | SCENE_SUFFIXES | MESH_SUFFIXES
#: Model files whose readers parse the file in C or C++ (OpenCASCADE for STEP/IGES; libxml2
#: through lxml for 3DXML and 3MF; image decoders for the textures of glTF and 3DXML files):
#: read in a child process with a time and a memory limit (:mod:`ndbg_cli.io.isolated`). STL,
#: PLY, OFF and OBJ are parsed by trimesh in Python and numpy, in the process itself.
NATIVE_SUFFIXES = CAD_SUFFIXES | {".glb", ".gltf", ".3dxml", ".3mf"}

#: The reader of each native format, as an error message names it.
_READERS = {".step": "the STEP reader (OpenCASCADE)", ".stp": "the STEP reader (OpenCASCADE)",
            ".iges": "the IGES reader (OpenCASCADE)", ".igs": "the IGES reader (OpenCASCADE)"}

#: The function a reader's child runs (:func:`ndbg_cli.io.loaders.read_model`).
READ_MODEL = "ndbg_cli.io.loaders:read_model"


def reader_name(suffix: str) -> str:
    """How an error names the reader of files with ``suffix`` (e.g. ``.step``)."""
    return _READERS.get(suffix.lower(), f"the {suffix[1:].upper()} reader (trimesh)")


def reader_preload(suffix: str) -> tuple[str, ...]:
    """The modules a reader's child imports before its request (those of the reader)."""
    cad = ("cascadio",) if suffix.lower() in CAD_SUFFIXES else ()
    return ("ndbg_cli.io.loaders", *cad)


def prestart_reader(path: str | Path) -> None:
    """If ``path`` is a model file read by a native reader, start its child process now
    (:func:`ndbg_cli.io.isolated.prestart`), so that its start-up overlaps the caller's."""
    suffix = Path(path).suffix.lower()
    if suffix in NATIVE_SUFFIXES and Path(path).is_file():
        prestart(*reader_preload(suffix))


def discover(path: str | Path) -> list[Path]:
    """The assemblies a path names: a directory of manifests is a batch (one per manifest,
    recursing into sub-directories that hold manifests); anything else is one assembly."""
    p = Path(path)
    if not p.is_dir():
        return [p]
    manifests = sorted(q for q in p.rglob("*") if q.suffix.lower() in MANIFEST_SUFFIXES
                       and q.is_file())
    return manifests if manifests else [p]

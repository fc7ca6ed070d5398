"""Loading assemblies from every input format ndbg accepts (:func:`load`): YAML manifests,
multi-body model files (STEP, IGES, GLB, ...) and directories of mesh files. A directory
holding manifests is a *batch* (one assembly per manifest); see
:func:`ndbg_cli.io.formats.discover`.
"""

from __future__ import annotations

import contextlib
import io
import logging
import math
import os
import re
import sys
import warnings
from collections.abc import Callable
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np
import trimesh

from ..core.assembly import Assembly, Diagnostic, Joint, Part, point_extent
from ..core.constants import (
    DEFLECTION_RELATIVE,
    LOAD_MEMORY_GIB,
    LOAD_TIMEOUT_S,
    MAX_TRIANGLES,
    MIN_TOLERANCE,
    STEP_ANGULAR_DEFLECTION_RAD,
    STEP_DEFLECTION_MM,
)
from ..core.errors import InputError
from ..core.progress import StatusLine
from ..core.units import canonical_unit, scale
from .formats import (
    CAD_SUFFIXES,
    MANIFEST_SUFFIXES,
    MESH_SUFFIXES,
    MODEL_SUFFIXES,
    NATIVE_SUFFIXES,
    READ_MODEL,
    reader_name,
    reader_preload,
)
from .isolated import in_child, run_isolated
from .limits import TriangleBudget, check_max_triangles
from .manifest import _Located, placement, read_manifest
from .validate import make_part, make_polygon_part


@dataclass(frozen=True)
class Reading:
    """How model files are read (:func:`load`'s arguments of the same names): the
    tessellation's deflection, the limits of a native reader's child process, whether it is
    used (``None``: for :data:`NATIVE_SUFFIXES`), whether it shows a status line, and the
    most triangles the assembly may have (``None``: any)."""

    units: str | None = None
    mesh_tolerance: float | None = None
    load_timeout: float | None = LOAD_TIMEOUT_S
    load_memory: float | None = LOAD_MEMORY_GIB
    isolate: bool | None = None
    progress: bool = False
    max_triangles: int | None = MAX_TRIANGLES
    meanwhile: Callable[[], Any] | None = None


def load(path: str | Path, *, units: str | None = None, tolerance: float | None = None,
         allow_outside_paths: bool = False, mesh_tolerance: float | None = None,
         load_timeout: float | None = LOAD_TIMEOUT_S,
         load_memory: float | None = LOAD_MEMORY_GIB, isolate: bool | None = None,
         progress: bool = False, max_triangles: int | None = MAX_TRIANGLES,
         meanwhile: Callable[[], Any] | None = None) -> Assembly:
    """Load one assembly from a manifest, a model file, or a directory of mesh files.

    ``units`` overrides the unit the input's lengths are in (for files whose unit is not
    recorded, e.g. STL); ``tolerance`` overrides the length tolerance (in the assembly unit).
    ``allow_outside_paths`` lets a manifest name mesh files outside its own folder.
    Raises :class:`InputError` with a one-line message for any bad input.

    A model file whose reader is native code (:data:`NATIVE_SUFFIXES`; ``isolate`` forces it
    on or off for any model file) is read in a child process: a crash of the reader, more
    than ``load_timeout`` seconds or more than ``load_memory`` GiB there (``None``: no limit)
    is an :class:`InputError` too. ``mesh_tolerance`` is the tessellation's deflection for
    STEP/IGES files, in the assembly unit (default: 0.01 mm, more for a model larger than
    1 m, see :data:`ndbg_cli.core.constants.DEFLECTION_RELATIVE`). ``progress``: a status line
    on stderr while a child reads (see :class:`ndbg_cli.core.progress.StatusLine`).
    More than ``max_triangles`` triangles in the files (``None``: no limit) is an
    :class:`InputError`, raised as soon as the files read so far pass it. ``meanwhile()``
    is called while each native reader's child reads (work of the caller's that the read
    then hides; it should cost nothing when called again).

    * a YAML manifest (``.yaml``/``.yml``): parts are mesh files or 2D polygons;
    * one multi-body file: STEP/STP and IGES/IGS (tessellated with OpenCASCADE through
      ``cascadio``), GLB/GLTF, 3DXML, 3MF, OBJ with objects or groups, or a single mesh file
      (STL, PLY, OFF). Every scene-graph instance becomes one part, placed by its world
      transform; ids come from node names (unique within a scene graph), parts ordered by name;
    * a directory holding only mesh files: one part per file, already in the assembly frame,
      id = file stem, files in name order.

    Parameters
    ----------
    path : str or Path
        A manifest, a model file or a folder of meshes.
    units : str, optional
        The unit of the input's lengths (mm, cm, m, in).
    tolerance : float, optional
        The length tolerance, in the assembly's unit (default: 1e-4 x the diagonal).
    allow_outside_paths : bool
        Let a manifest name mesh files outside its folder.

    Returns
    -------
    Assembly
        The parts, placed in one frame, with their diagnostics.

    Examples
    --------
    >>> import ndbg_cli
    >>> asm = ndbg_cli.load("assemblies/hover.yaml")
    >>> asm.ids, asm.units
    (['base', 'puck', 'bridge'], 'mm')
    """
    p = Path(path)
    if not p.exists():
        raise InputError("no such file or directory", file=str(path))
    for name, value in (("tolerance", tolerance), ("mesh tolerance", mesh_tolerance),
                        ("load timeout", load_timeout), ("load memory", load_memory)):
        if value is not None and not 0 < value < math.inf:  # NaN fails both
            raise InputError(f"{name} must be positive and finite, got {value}",
                             file=str(path))
    check_max_triangles(max_triangles, str(path))
    reading = Reading(units=units, mesh_tolerance=mesh_tolerance, load_timeout=load_timeout,
                      load_memory=load_memory, isolate=isolate, progress=progress,
                      max_triangles=max_triangles, meanwhile=meanwhile)
    with _quiet_numerics():
        asm = _load(p, str(path), reading, allow_outside_paths)
    if tolerance is not None:
        asm = asm.replace(tolerance=float(tolerance))
    _check_tolerance(asm, str(path))
    return asm


def _load(p: Path, path: str, reading: Reading, allow_outside_paths: bool) -> Assembly:
    units = reading.units
    if p.is_dir():
        manifests = sorted(q for q in p.iterdir() if q.suffix.lower() in MANIFEST_SUFFIXES)
        if manifests:
            raise InputError("directory holds manifests: it is a batch, analyse it as such "
                             "(ndbg analyze DIR) or name one manifest", file=str(path))
        asm = load_mesh_directory(p, units=units, reading=reading)
    elif p.suffix.lower() in MANIFEST_SUFFIXES:
        asm = load_manifest(p, units=units, allow_outside_paths=allow_outside_paths,
                            reading=reading)
    elif p.suffix.lower() in MODEL_SUFFIXES:
        asm = load_model(p, reading=reading)
    else:
        known = " ".join(sorted(MANIFEST_SUFFIXES | MODEL_SUFFIXES))
        raise InputError(f"unknown file type '{p.suffix}' (known: {known})", file=str(path))
    return asm


def _check_tolerance(asm: Assembly, file: str) -> None:
    """An explicit tolerance (manifest, config or --tolerance) must be smaller than the
    assembly's size (:attr:`~ndbg_cli.core.assembly.Assembly.size`): lengths below it count as
    zero, so one that large makes every gap a contact and every part a point (a unit slip,
    such as mm for m). It must also be at least :data:`~ndbg_cli.core.constants.MIN_TOLERANCE`
    (absolute, and relative to that size): a smaller one is below the coordinates' rounding
    and the report's floats."""
    t = asm.tolerance
    if t is None:
        return
    if not t < asm.size:
        raise InputError(f"tolerance {t:g} {asm.units} is not smaller than the assembly's "
                         f"size ({asm.size:.6g} {asm.units})", file=file)
    least = MIN_TOLERANCE * max(1.0, asm.size)
    if t < least:
        raise InputError(f"tolerance {t:g} {asm.units} is below the smallest one ndbg can "
                         f"honour here, {least:.3g} {asm.units} (1e-12 of the assembly's "
                         f"size, and at least 1e-12 {asm.units})", file=file)


# -- manifests ----------------------------------------------------------------------------

def load_manifest(path: Path, *, units: str | None = None,
                  allow_outside_paths: bool = False, reading: Reading | None = None
                  ) -> Assembly:
    """Load a YAML manifest (3D meshes or 2D polygons); ``reading``: how its mesh files are
    read (their deflection in the assembly unit)."""
    doc = read_manifest(path)
    data = doc.data
    file = str(path)
    # The manifest records its unit, so a --units override converts rather than relabels.
    doc_units = _unit(data.get("units", "mm"), doc, ("units",))
    asm_units = canonical_unit(units, file=file) if units else doc_units
    reading = replace(reading or Reading(), units=asm_units)
    dimension = int(data.get("dimension", 3))
    folder = path.parent.resolve()
    parts: list[Part] = []
    diags: list[Diagnostic] = []
    seen: dict[str, int] = {}
    budget = TriangleBudget(reading.max_triangles, file, len(data["parts"]))
    for k, entry in enumerate(data["parts"]):
        where = ("parts", k)
        pid = entry["id"]
        if pid in seen:
            raise doc.error(where + ("id",), f"duplicate part id '{pid}' (also parts[{seen[pid]}])",
                            part=pid)
        seen[pid] = k
        part_units = _unit(entry.get("units", doc_units), doc, where + ("units",))
        s = scale(part_units, asm_units)
        T = placement(entry, dimension=dimension, doc=doc, path=where, scale=s)
        fixed = bool(entry.get("fixed", False)) or data.get("base") == pid
        if dimension == 2:
            if "mesh" in entry or "polygon" not in entry:
                raise doc.error(where, "a 2D part needs 'polygon' (and no 'mesh')", part=pid)
            part, d = make_polygon_part(pid, entry["polygon"], entry.get("holes", ()),
                                        transform=T, scale=s, source=file, fixed=fixed)
        else:
            if "polygon" in entry or "mesh" not in entry:
                raise doc.error(where, "a 3D part needs 'mesh' (polygons need dimension: 2)",
                                part=pid)
            mesh_path = _resolve(entry["mesh"], folder, doc, where + ("mesh",), pid,
                                 allow_outside_paths)
            v, f = _read_single_mesh(mesh_path, part=pid, reading=reading)
            budget.add(len(f), k + 1)
            part, d = make_part(pid, v, f, transform=T, scale=s, source=str(mesh_path),
                                fixed=fixed)
        parts.append(part)
        diags.extend(d)
    ids = set(seen)
    base = data.get("base")
    if base is not None and base not in ids:
        raise doc.error(("base",), f"base part '{base}' is not a part id")
    s_doc = scale(doc_units, asm_units)
    joints = tuple(_joint(j, doc, ("joints", k), ids, s_doc)
                   for k, j in enumerate(data.get("joints", [])))
    if base is None:
        fixed_ids = [p.id for p in parts if p.fixed]
        if len(fixed_ids) > 1:
            raise doc.error(("parts",), f"more than one fixed part: {', '.join(fixed_ids)}")
        base = fixed_ids[0] if fixed_ids else None
    return Assembly(name=str(data.get("name", path.stem)), parts=tuple(parts), units=asm_units,
                    dimension=dimension, source=file,
                    tolerance=data["tolerance"] * s_doc if "tolerance" in data else None,
                    base=base, joints=joints, expect=dict(data.get("expect", {}) or {}),
                    diagnostics=tuple(diags), metadata=dict(data.get("metadata", {}) or {}))


def _unit(name: Any, doc: _Located, path: tuple) -> str:
    try:
        return canonical_unit(name)
    except InputError as exc:
        raise doc.error(path, exc.problem) from None


def _resolve(rel: str, folder: Path, doc: _Located, path: tuple, pid: str,
             allow_outside: bool) -> Path:
    if "\0" in rel:  # no file can be named so; the OS calls would raise a ValueError (exit 3)
        raise doc.error(path, f"mesh path {rel!r} contains a NUL character", part=pid)
    target = (folder / rel).resolve()
    if not allow_outside and not target.is_relative_to(folder):
        raise doc.error(path, f"mesh path '{rel}' leaves the manifest's folder "
                              "(use --allow-outside-paths to permit it)", part=pid)
    if not target.is_file():
        raise doc.error(path, f"mesh file '{rel}' not found", part=pid)
    return target


def _joint(entry: dict, doc: _Located, path: tuple, ids: set, s: float) -> Joint:
    a, b = entry["parts"]
    for k, pid in enumerate((a, b)):
        if pid not in ids:
            raise doc.error(path + ("parts", k), f"joint names unknown part '{pid}'")
    if a == b:
        raise doc.error(path + ("parts",), "a joint needs two different parts")
    axis = np.asarray(entry["axis"], dtype=float)
    if np.linalg.norm(axis) < 1e-12:
        raise doc.error(path + ("axis",), "joint axis has zero length")
    axis = axis / np.linalg.norm(axis)
    pitch = float(entry.get("pitch", 0.0)) * s
    if entry["type"] == "screw" and pitch == 0.0:
        raise doc.error(path, "a screw joint needs a non-zero pitch")
    point = tuple(float(c) * s for c in entry.get("point", (0.0, 0.0, 0.0)))
    return Joint(type=entry["type"], parts=(a, b), axis=tuple(map(float, axis)), point=point,
                 pitch=pitch)


# -- meshes and scenes --------------------------------------------------------------------

def _read_single_mesh(path: Path, *, part: str | None = None, reading: Reading | None = None
                      ) -> tuple[np.ndarray, np.ndarray]:
    """Vertices and faces of a mesh file, all bodies of a scene file merged into one."""
    meshes, _ = _read_instances(path, reading or Reading(), part=part)
    if not meshes:
        raise InputError("file holds no triangle mesh", file=str(path), part=part)
    if len(meshes) == 1:
        _, v, f = meshes[0]
        return v, f
    offsets = np.cumsum([0] + [len(v) for _, v, _ in meshes[:-1]])
    v = np.vstack([v for _, v, _ in meshes])
    f = np.vstack([f + o for (_, _, f), o in zip(meshes, offsets)])
    return v, f


@contextlib.contextmanager
def _quiet_numerics():
    """No numpy floating-point warnings, no library warnings (numpy's ``invalid value
    encountered in cast``...) and no log records of trimesh's on stderr (it logs tracebacks
    of what it fails to parse, which Python's last-resort handler prints when the program
    configured no logging) while a file is read and its parts are made: what they are about
    (NaN or huge coordinates, bad indices, a damaged file) is checked for, and reported, by
    the loader and :func:`ndbg_cli.io.validate.make_part`. Local: the caller's warning
    filters and numpy settings are as they were afterwards, and a program that configured
    logging still gets trimesh's records."""
    logger = logging.getLogger("trimesh")
    handler = logging.NullHandler()  # a handler found: the last-resort one stays silent
    logger.addHandler(handler)
    try:
        with warnings.catch_warnings(), np.errstate(all="ignore"):
            warnings.simplefilter("ignore")
            yield
    finally:
        logger.removeHandler(handler)


def _read_scene(path: Path, *, part: str | None = None, units: str | None = None,
                mesh_tolerance: float | None = None,
                stage: Callable[[str], None] | None = None) -> trimesh.Scene:
    suffix = path.suffix.lower()
    try:
        if suffix in CAD_SUFFIXES:
            return _read_cad(path, units=units, mesh_tolerance=mesh_tolerance, stage=stage)
        if stage is not None:
            stage(f"reading the {suffix[1:].upper()} file")
        kwargs: dict[str, Any] = {}
        if suffix == ".obj":
            kwargs = {"split_objects": True, "split_groups": True, "group_material": False}
        name = str(path)
        try:
            name.encode("utf-8")
        except UnicodeEncodeError:
            # a file name that is not UTF-8 (lone surrogates in Python): trimesh names a
            # body after its file and encodes the names to hash the scene graph, which then
            # fails. Read it from an open file, as trimesh names a stream's bodies (by the
            # file's content, else ``geometry_0``...); other files it refers to (a glTF's
            # buffers, an OBJ's materials) are still found next to it.
            with open(path, "rb") as fh:
                return trimesh.load(fh, file_type=suffix[1:], force="scene", process=False,
                                    resolver=trimesh.resolvers.FilePathResolver(name),
                                    **kwargs)
        loaded = trimesh.load(name, force="scene", process=False, **kwargs)
    except (InputError, MemoryError):
        raise
    except Exception as exc:  # trimesh raises many kinds for unreadable files
        raise InputError(f"cannot read {suffix[1:].upper()} file: {_short(exc)}",
                         file=str(path), part=part) from None
    return loaded


def read_model(path: str | Path, units: str | None = None, mesh_tolerance: float | None = None,
               *, part: str | None = None, stage: Callable[[str], None] | None = None
               ) -> tuple[list[tuple[str, np.ndarray, np.ndarray]], dict]:
    """A model file's mesh instances (:func:`_scene_instances`: node name, world-frame
    vertices, faces: plain numpy arrays, cheap to send from a child process) and what the
    reader recorded (``ndbg_units``, ``ndbg_scene_units``, ``ndbg_deflection_mm``).

    Run in a child process for native readers (:func:`load_model`). Every failure of the
    reader is an :class:`InputError`; ``stage(text)`` is told what it is doing."""
    path = Path(path)
    with _quiet_numerics():
        scene = _read_scene(path, part=part, units=units, mesh_tolerance=mesh_tolerance,
                            stage=stage)
        if stage is not None:
            stage("collecting the meshes")
        inst = _instances_of(scene, path, part)
    keys = ("ndbg_units", "ndbg_scene_units", "ndbg_deflection_mm")
    return inst, {k: scene.metadata[k] for k in keys if k in scene.metadata}


def _instances_of(scene: trimesh.Scene, path: Path, part: str | None = None
                  ) -> list[tuple[str, np.ndarray, np.ndarray]]:
    """:func:`_scene_instances`, a malformed scene (meshes or transforms of the wrong shape,
    a broken scene graph) being an input error."""
    try:
        return _scene_instances(scene)
    except InputError as exc:
        if exc.file is not None:
            raise
        raise InputError(f"cannot read {path.suffix[1:].upper()} file: {exc.problem}",
                         file=str(path), part=part) from None
    except MemoryError:
        raise
    except Exception as exc:
        raise InputError(f"cannot read {path.suffix[1:].upper()} file: {_short(exc)}",
                         file=str(path), part=part) from None


def _short(exc: BaseException) -> str:
    text = str(exc).strip().splitlines()
    return f"{exc.__class__.__name__}: {text[0] if text else ''}".strip(": ")


_STEP_UNIT = re.compile(r"LENGTH_UNIT\s*\(\s*\)\s*NAMED_UNIT\s*\(\s*\*\s*\)\s*SI_UNIT\s*\(\s*"
                        r"(\.\w+\.|\$)\s*,\s*\.METRE\.\s*\)", re.I)
_STEP_CONV = re.compile(r"CONVERSION_BASED_UNIT\s*\(\s*'(\w+)'", re.I)


def step_length_unit(text: str) -> str:
    """The length unit a STEP file declares (``mm`` when it declares none we know)."""
    m = _STEP_UNIT.search(text)
    if m:
        prefix = m.group(1).strip(".").upper()
        return {"MILLI": "mm", "CENTI": "cm", "$": "m"}.get(prefix, "mm")
    m = _STEP_CONV.search(text)
    if m and m.group(1).upper() in {"INCH", "INCHES"}:
        return "in"
    return "mm"


def _read_cad(path: Path, *, units: str | None = None, mesh_tolerance: float | None = None,
              stage: Callable[[str], None] | None = None) -> trimesh.Scene:
    """Tessellate a STEP or IGES file with OpenCASCADE (cascadio) into a scene.

    cascadio writes STEP shapes in metres whatever the file's unit, and IGES shapes in
    OpenCASCADE's internal millimetres; the scene is tagged with that unit and the caller
    converts it to the file's declared unit. OpenCASCADE prints progress on the process's
    standard output, which would corrupt a JSON report piped from stdout: it is silenced.

    The linear deflection is ``mesh_tolerance`` (in ``units``, else the file's unit) when
    given, else :func:`default_deflection_mm`; it is recorded as ``ndbg_deflection_mm``.
    """
    if sys.modules.get("cascadio", False) is None:
        # kept out of the ndbg program's process (cli.main), which reads CAD files in the
        # reader's child; read here all the same when a caller reads one in process
        del sys.modules["cascadio"]
    import cascadio

    data = path.read_bytes()
    kind = "iges" if path.suffix.lower() in {".iges", ".igs"} else "step"
    text = data[:200000].decode("latin-1") if kind == "step" else ""
    file_units = step_length_unit(text) if kind == "step" else "mm"
    if mesh_tolerance is not None:
        chosen = canonical_unit(units, file=str(path)) if units else file_units
        deflection = mesh_tolerance * scale(chosen, "mm")
    else:
        deflection = default_deflection_mm(data, file_units) if kind == "step" \
            else STEP_DEFLECTION_MM
    if stage is not None:
        stage(f"reading and tessellating the {kind.upper()} file with OpenCASCADE "
              f"(deflection {deflection:.3g} mm)")
    with _quiet_native_output():
        glb = cascadio.load(data, file_type=kind, tol_linear=deflection,
                            tol_angular=STEP_ANGULAR_DEFLECTION_RAD, use_parallel=False)
    if not glb:
        raise InputError(f"cannot read {kind.upper()} file: OpenCASCADE found no shape in it",
                         file=str(path))
    if stage is not None:
        stage("building the meshes")
    scene = trimesh.load(io.BytesIO(glb), file_type="glb", force="scene", process=False)
    scene.metadata["ndbg_units"] = file_units
    scene.metadata["ndbg_scene_units"] = "m" if kind == "step" else "mm"
    scene.metadata["ndbg_deflection_mm"] = deflection
    return scene


_STEP_POINT = re.compile(rb"CARTESIAN_POINT\s*\(\s*'[^']*'\s*,\s*\(([^()]*)\)", re.I)


def default_deflection_mm(data: bytes, file_units: str) -> float:
    """The default linear deflection (mm) of a STEP file's tessellation:
    :data:`STEP_DEFLECTION_MM`, or :data:`DEFLECTION_RELATIVE` times the model's size where
    that is larger (a model larger than 1 m). The size is
    :func:`ndbg_cli.core.assembly.point_extent` of the file's points (``CARTESIAN_POINT``:
    vertices, control points, placements; the same in any frame, unlike a box diagonal),
    found before OpenCASCADE tessellates anything; an estimate, which is all a deflection
    needs."""
    rows = [g for g in _STEP_POINT.findall(data) if g.count(b",") == 2]
    if not rows:
        return STEP_DEFLECTION_MM
    try:
        pts = np.array(b",".join(rows).split(b","), dtype="S").astype(float).reshape(-1, 3)
    except ValueError:  # a number STEP allows and numpy does not read: keep the default
        return STEP_DEFLECTION_MM
    pts = pts[np.all(np.isfinite(pts), axis=1)]
    if not len(pts):
        return STEP_DEFLECTION_MM
    size = point_extent(pts)[0] * scale(file_units, "mm")
    return max(STEP_DEFLECTION_MM, DEFLECTION_RELATIVE * size)


@contextlib.contextmanager
def _quiet_native_output():
    """Silence C-level stdout and stderr for the duration: OpenCASCADE prints progress and
    parse errors there, around the one-line error ndbg gives. ``NDBG_DEBUG_NATIVE=1`` keeps
    them."""
    if os.environ.get("NDBG_DEBUG_NATIVE") or in_child():  # a child's output is its log
        yield
        return
    sys.stdout.flush()
    sys.stderr.flush()
    saved = [os.dup(1), os.dup(2)]
    null = os.open(os.devnull, os.O_WRONLY)
    try:
        os.dup2(null, 1)
        os.dup2(null, 2)
        yield
    finally:
        os.dup2(saved[0], 1)
        os.dup2(saved[1], 2)
        for fd in (*saved, null):
            os.close(fd)


def natural_key(name: str) -> tuple:
    """Sort key that orders ``nut_2`` before ``nut_10``."""
    return tuple((0, int(t), "") if t.isdigit() else (1, 0, t.lower())
                 for t in re.split(r"(\d+)", name) if t)


#: trimesh names the repeated instances of one glTF node ``NAME_xxxxxx`` with a random hex
#: suffix (a fresh one at every load).
_RANDOM_SUFFIX = re.compile(r"^(.*)_[0-9a-f]{6}$")


def _scene_instances(scene: trimesh.Scene) -> list[tuple[str, np.ndarray, np.ndarray]]:
    """``(node name, world-frame vertices, faces)`` for every mesh instance, ordered by node
    name (natural order), which is stable whatever order the file's scene graph has.

    Repeated instances of one node come back from trimesh with random name suffixes; those
    suffixes are dropped (when at least two names share the stem) and the instances ordered by
    geometry name and placement, so the same file gives the same ids at every load
    (:func:`unique_ids` then numbers the repeats ``-2``, ``-3``...)."""
    rows = []
    for node in scene.graph.nodes_geometry:
        T, geom_name = scene.graph[node]
        geom = scene.geometry.get(geom_name)
        if not isinstance(geom, trimesh.Trimesh) or len(geom.faces) == 0:
            continue
        rows.append((str(node), T, str(geom_name), geom))
    stems = [m.group(1) if (m := _RANDOM_SUFFIX.match(name)) else None for name, *_ in rows]
    count: dict[str, int] = {}
    for stem in stems:
        if stem is not None:
            count[stem] = count.get(stem, 0) + 1
    out = []
    for (name, T, geom_name, geom), stem in zip(rows, stems):
        if stem is not None and count[stem] > 1:
            name = stem
        v = np.asarray(geom.vertices, dtype=float)
        if v.ndim != 2 or v.shape[1] != 3:  # e.g. an OBJ whose vertex lines lost numbers
            raise InputError(f"mesh '{geom_name}' has vertices of shape {v.shape}, not "
                             "(n, 3)")
        T = np.asarray(T, dtype=float)
        if T.shape != (4, 4):
            raise InputError(f"node '{name}' has a transform of shape {T.shape}, not 4 x 4")
        v = v @ T[:3, :3].T + T[:3, 3]
        key = (natural_key(name), name, geom_name, tuple(np.round(T[:3, :], 9).ravel()))
        out.append((key, name, v, np.asarray(geom.faces)))
    out.sort(key=lambda r: r[0])
    return [(name, v, f) for _, name, v, f in out]


def unique_ids(names: list[str]) -> list[str]:
    """Make names unique and stable: later repeats get ``-2``, ``-3``..., in order."""
    out, used = [], set()
    for name in names:
        base = name.strip() or "part"
        cand, k = base, 1
        while cand in used:
            k += 1
            cand = f"{base}-{k}"
        used.add(cand)
        out.append(cand)
    return out


def _read_instances(path: Path, reading: Reading, *, part: str | None = None
                    ) -> tuple[list[tuple[str, np.ndarray, np.ndarray]], dict]:
    """:func:`read_model` of ``path``, in a child process for a native reader (see
    :func:`load`)."""
    suffix = path.suffix.lower()
    isolate = reading.isolate if reading.isolate is not None else suffix in NATIVE_SUFFIXES
    args = (path, reading.units, reading.mesh_tolerance)
    if not isolate:
        return read_model(*args, part=part)
    hint = "a coarser --mesh-tolerance tessellates faster" if suffix in CAD_SUFFIXES else ""
    status = StatusLine(f"loading {path.name}", quiet=not reading.progress)
    try:
        return run_isolated(READ_MODEL, args, file=str(path), reader=reader_name(suffix),
                            timeout=reading.load_timeout, memory_gib=reading.load_memory,
                            preload=reader_preload(suffix), timeout_hint=hint,
                            progress=status.update, part=part, meanwhile=reading.meanwhile)
    finally:
        status.close()


def load_model(path: Path, *, units: str | None = None, reading: Reading | None = None
               ) -> Assembly:
    """Load a single model file: one part per scene-graph mesh instance. Native readers
    (:data:`NATIVE_SUFFIXES`, or any when ``reading.isolate``) run in a child process (see
    :func:`load`); ``units`` overrides ``reading.units``."""
    reading = reading or Reading()
    if units is not None:
        reading = replace(reading, units=units)
    units, mesh_tolerance = reading.units, reading.mesh_tolerance
    inst, meta = _read_instances(path, reading)
    if not inst:
        raise InputError("file holds no triangle mesh", file=str(path))
    TriangleBudget(reading.max_triangles, str(path), len(inst)).add(
        sum(len(f) for _, _, f in inst), len(inst))
    file_units = meta.get("ndbg_units")
    if file_units is not None:  # STEP/IGES record their unit: convert cascadio's metres to it
        asm_units = canonical_unit(units, file=str(path)) if units else file_units
        s = scale(meta["ndbg_scene_units"], asm_units)
    elif units is not None:  # the file records no reliable unit: the option declares it
        asm_units, s = canonical_unit(units, file=str(path)), 1.0
    elif path.suffix.lower() in {".glb", ".gltf"}:
        asm_units, s = "m", 1.0  # glTF lengths are metres by specification
    else:
        asm_units, s = "mm", 1.0
    ids = unique_ids([name for name, _, _ in inst])
    parts, diags = [], []
    for pid, (node, v, f) in zip(ids, inst):
        part, d = make_part(pid, v, f, scale=s, source=f"{path}#{node}")
        parts.append(part)
        diags.extend(d)
    deflection = meta.get("ndbg_deflection_mm")
    if mesh_tolerance is None and deflection is not None and deflection > STEP_DEFLECTION_MM:
        diags.append(Diagnostic(
            "warning", "coarse-tessellation",
            f"tessellated with a deflection of {deflection:.3g} mm, {DEFLECTION_RELATIVE:g} x "
            f"the model's size (the default for a model larger than 1 m; "
            f"--mesh-tolerance chooses it)", file=str(path)))
    return Assembly(name=path.stem, parts=tuple(parts), units=asm_units, source=str(path),
                    diagnostics=tuple(diags))


def load_mesh_directory(path: Path, *, units: str | None = None,
                        reading: Reading | None = None) -> Assembly:
    """Load a directory of mesh files, one part per file, already in the assembly frame."""
    files = sorted(q for q in path.iterdir() if q.is_file() and q.suffix.lower() in MESH_SUFFIXES)
    if not files:
        known = " ".join(sorted(MESH_SUFFIXES))
        raise InputError(f"directory holds no manifest and no mesh file ({known})",
                         file=str(path))
    stems: dict[str, Path] = {}
    for q in files:
        if q.stem in stems:
            raise InputError(f"two files give the same part id '{q.stem}': "
                             f"{stems[q.stem].name} and {q.name}", file=str(path), part=q.stem)
        stems[q.stem] = q
    asm_units = canonical_unit(units, file=str(path)) if units else "mm"
    parts, diags = [], []
    reading = replace(reading or Reading(), units=asm_units)
    budget = TriangleBudget(reading.max_triangles, str(path), len(files))
    for k, q in enumerate(files):
        v, f = _read_single_mesh(q, part=q.stem, reading=reading)
        budget.add(len(f), k + 1)
        part, d = make_part(q.stem, v, f, source=str(q))
        parts.append(part)
        diags.extend(d)
    return Assembly(name=path.name, parts=tuple(parts), units=asm_units, source=str(path),
                    diagnostics=tuple(diags))


__all__ = ["load", "load_manifest", "load_model", "load_mesh_directory",
           "read_model", "default_deflection_mm", "step_length_unit", "unique_ids"]

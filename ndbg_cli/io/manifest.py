"""YAML manifests: reading (:func:`read_manifest`), schema validation with line numbers,
placements (:func:`placement`), parts.

YAML is read with the safe loader (plus YAML 1.2's ``1e-3`` floats, see :class:`YamlLoader`);
duplicate keys are errors.
"""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from ..core.errors import InputError
from ..core.schemas import manifest_schema

#: Deepest nesting of lists and mappings a YAML input may have (with its aliases expanded).
#: Manifests, configs and rules need a handful of levels; past Python's recursion limit
#: (about 300 levels for PyYAML's composer) every reader of the data would fail with a
#: RecursionError, an internal error instead of an input error.
MAX_YAML_DEPTH = 100
#: Nodes the aliases of a YAML input may add to it when expanded. Readers walk the data as a
#: tree (line numbers, finiteness, the schema), so nine nested anchors of nine aliases each
#: (a "billion laughs" of 400 bytes) would make them walk 9**9 nodes (1.3 GB, minutes).
MAX_ALIAS_NODES = 100_000


class YamlLimitError(yaml.composer.ComposerError):
    """A YAML input nested too deeply or whose aliases expand too much (see
    :data:`MAX_YAML_DEPTH`, :data:`MAX_ALIAS_NODES`); ``problem`` says which, and
    ``problem_mark`` where."""


class YamlLoader(yaml.SafeLoader):
    """The safe loader, reading ``1e-3``, ``2E6`` and ``1.0e12`` as floats, as YAML 1.2
    does (PyYAML follows YAML 1.1, whose floats need a dot and a signed exponent, and reads
    those as strings). Only numbers with an exponent are added; every other tag is YAML
    1.1's, as before.

    It also refuses documents nested deeper than :data:`MAX_YAML_DEPTH` and those whose
    aliases expand to more than :data:`MAX_ALIAS_NODES` extra nodes (or refer to themselves),
    with a :class:`YamlLimitError` (a ``yaml.YAMLError``): checked while composing, before
    anything is built, for ``yaml.load`` and ``yaml.compose`` alike. Every YAML input ndbg
    reads (manifests, configs, rules files) goes through it."""

    def __init__(self, stream):
        super().__init__(stream)
        self._depth = 0
        self._aliases = 0

    def compose_node(self, parent, index):
        if self.check_event(yaml.AliasEvent):
            self._aliases += 1
            return super().compose_node(parent, index)
        self._depth += 1
        try:
            if self._depth > MAX_YAML_DEPTH:  # before PyYAML's recursion gets deeper
                raise YamlLimitError(problem=f"nested deeper than {MAX_YAML_DEPTH} levels",
                                     problem_mark=self.peek_event().start_mark)
            return super().compose_node(parent, index)
        finally:
            self._depth -= 1

    def get_single_node(self):
        node = super().get_single_node()
        if node is not None and self._aliases:
            _check_expansion(node)
        return node


def _children(node: yaml.Node) -> list[yaml.Node]:
    if isinstance(node, yaml.MappingNode):
        return [n for pair in node.value for n in pair]
    if isinstance(node, yaml.SequenceNode):
        return list(node.value)
    return []


def _check_expansion(root: yaml.Node) -> None:
    """:class:`YamlLimitError` if the document ``root`` (a graph: an alias is its anchored
    node again) expands, as a tree, to more than :data:`MAX_ALIAS_NODES` nodes beyond its
    own, or deeper than :data:`MAX_YAML_DEPTH`, or is recursive. One post-order walk over
    the distinct nodes (not recursive: the graph may be deep), each node's expanded size
    and depth from its children's; the error marks the first node found too large."""
    size: dict[int, int] = {}
    depth: dict[int, int] = {}
    open_: set[int] = set()
    stack: list[tuple[yaml.Node, bool]] = [(root, False)]
    distinct = 0
    while stack:
        node, done = stack.pop()
        k = id(node)
        if done:
            open_.discard(k)
            kids = _children(node)
            size[k] = 1 + sum(size[id(c)] for c in kids)
            depth[k] = 1 + max((depth[id(c)] for c in kids), default=0)
            distinct += 1
            problem = None
            if depth[k] > MAX_YAML_DEPTH:
                problem = f"nested deeper than {MAX_YAML_DEPTH} levels once its aliases " \
                          "are expanded"
            elif size[k] > distinct + MAX_ALIAS_NODES:
                problem = (f"its aliases expand to more than {MAX_ALIAS_NODES} extra values "
                           "(nested anchors and aliases, a 'billion laughs'?)")
            if problem:
                raise YamlLimitError(problem=problem, problem_mark=node.start_mark)
            continue
        if k in size:
            continue
        if k in open_:
            raise YamlLimitError(problem="an alias refers to a node that contains it",
                                 problem_mark=node.start_mark)
        open_.add(k)
        stack.append((node, True))
        stack.extend((c, False) for c in reversed(_children(node)) if id(c) not in size)


YamlLoader.add_implicit_resolver(
    "tag:yaml.org,2002:float",
    re.compile(r"^[-+]?(?:[0-9]+(?:\.[0-9]*)?|\.[0-9]+)[eE][-+]?[0-9]+$"),
    list("-+.0123456789"))


def yaml_input_error(exc: yaml.YAMLError, file: str) -> InputError:
    """The one-line input error of a YAML reading error: ``malformed YAML: PROBLEM`` (or,
    for a :class:`YamlLimitError`, the PROBLEM alone: the YAML is well formed), with the
    problem's line when PyYAML knows it."""
    mark = getattr(exc, "problem_mark", None)
    problem = getattr(exc, "problem", None) or str(exc).splitlines()[0]
    if not isinstance(exc, YamlLimitError):
        problem = f"malformed YAML: {problem}"
    return InputError(problem, file=file, line=mark.line + 1 if mark else None)


class _Located:
    """Manifest data plus the source line of every key path (for error messages)."""

    def __init__(self, data: Any, lines: dict[tuple, int], file: str):
        self.data = data
        self.lines = lines
        self.file = file

    def line(self, path: tuple) -> int | None:
        path = tuple(path)
        while path not in self.lines and path:
            path = path[:-1]
        return self.lines.get(path)

    def error(self, path: tuple, problem: str, part: str | None = None) -> InputError:
        return InputError(f"{format_path(path)}: {problem}" if path else problem,
                          file=self.file, line=self.line(path), part=part)


def format_path(path: tuple) -> str:
    """``('parts', 3, 'mesh')`` -> ``parts[3].mesh``."""
    out = ""
    for p in path:
        out += f"[{p}]" if isinstance(p, int) else (f".{p}" if out else str(p))
    return out


def _line_map(node: yaml.Node, path: tuple, out: dict, file: str) -> None:
    out.setdefault(path, node.start_mark.line + 1)
    if isinstance(node, yaml.MappingNode):
        seen: set = set()
        for key, value in node.value:
            k = key.value
            if k in seen:
                raise InputError(f"duplicate key '{k}'", file=file, line=key.start_mark.line + 1)
            seen.add(k)
            out[path + (k,)] = key.start_mark.line + 1
            _line_map(value, path + (k,), out, file)
    elif isinstance(node, yaml.SequenceNode):
        for i, value in enumerate(node.value):
            _line_map(value, path + (i,), out, file)


def read_located(path: str | Path, what: str, shape: str, empty_ok: bool = False
                 ) -> _Located:
    """A YAML mapping file (manifest, config, rules) read with :class:`YamlLoader`, with the
    line of every key path (``.line(path)``, ``.error(path, problem)``) and duplicate keys
    refused. ``what`` names the file in "cannot read WHAT" errors; ``shape`` is the error
    when the document is not a mapping (an empty document, only comments, is an empty
    mapping with ``empty_ok``). Any problem is an ``InputError``."""
    file = str(path)
    try:
        text = Path(path).read_text(encoding="utf-8")
    except OSError as exc:
        raise InputError(f"cannot read {what}: {exc.strerror or exc}", file=file) from None
    except UnicodeDecodeError as exc:
        raise InputError(f"cannot read {what}: not UTF-8 text ({exc.reason} at byte "
                         f"{exc.start})", file=file) from None
    try:
        node = yaml.compose(text, Loader=YamlLoader)
        data = yaml.load(text, Loader=YamlLoader)
    except yaml.YAMLError as exc:
        raise yaml_input_error(exc, file) from None
    if node is None and empty_ok:
        return _Located({}, {}, file)
    if node is None or not isinstance(data, dict):
        raise InputError(shape, file=file)
    lines: dict[tuple, int] = {}
    _line_map(node, (), lines, file)
    return _Located(data, lines, file)


def read_manifest(path: Path) -> _Located:
    """Read and schema-validate a manifest; ``InputError`` with a line number on failure.

    A manifest describes one assembly (``README.md``, ``schemas/manifest.schema.json``)::

        name: bell
        units: mm                 # mm, cm, m, in (default mm)
        parts:
          - id: base
            mesh: meshes/base.stl # relative to this file
            fixed: true
          - id: screw
            mesh: meshes/screw.stl
            units: in             # per-part unit, scaled into the assembly unit
            translation: [10, 0, 5]
            rotation: {euler: [0, 90, 0], order: xyz}   # degrees; or {quaternion: [w,x,y,z]},
                                                        # or {axis: [x,y,z], angle: deg}
        joints:
          - {type: screw, parts: [screw, base], axis: [0, 0, 1], point: [10, 0, 0],
             pitch: 1.25}
    """
    located = read_located(path, "manifest",
                           "a manifest must be a YAML mapping with a 'parts' list")
    _check_finite(located)
    _validate_schema(located)
    return located


#: Top-level keys whose numbers are not read as geometry (free-form hand-worked answers).
FREE_FORM = ("expect",)


def _check_finite(doc: _Located) -> None:
    """Every number the analysis reads is finite: YAML's ``.nan``, ``.inf`` (and literals
    beyond the float range, such as ``1e400``) would otherwise fail far from their cause
    (a singular matrix, a "degenerate mesh"). Checked before the schema, whose range
    tests NaN passes or fails with a confusing message. The error names the key (the
    list's line), as ``parts[2].translation: not a finite number``."""
    bad = _first_non_finite(doc.data, ())
    if bad is None:
        return
    while bad and isinstance(bad[-1], int):  # the key, not the position inside its list
        bad = bad[:-1]
    raise doc.error(bad, "not a finite number")


def _first_non_finite(value: Any, path: tuple) -> tuple | None:
    """The path of the first NaN or infinite float in ``value`` (document order), or None."""
    if isinstance(value, float):
        return None if np.isfinite(value) else path
    if isinstance(value, dict):
        items = ((k, v) for k, v in value.items() if not (path == () and k in FREE_FORM))
    elif isinstance(value, list):
        items = enumerate(value)
    else:
        return None
    for k, v in items:
        found = _first_non_finite(v, path + (k,))
        if found is not None:
            return found
    return None


def _validate_schema(doc: _Located) -> None:
    import jsonschema

    validator = jsonschema.Draft202012Validator(manifest_schema())
    errors = list(validator.iter_errors(doc.data))
    if not errors:
        return
    err = jsonschema.exceptions.best_match(errors)
    path = tuple(err.absolute_path)
    if err.validator == "additionalProperties":
        extra = sorted(set(err.instance) - set(err.schema.get("properties", {})))
        allowed = ", ".join(sorted(err.schema.get("properties", {})))
        where = path + (extra[0],) if extra else path
        raise doc.error(where, f"unknown key (allowed here: {allowed})")
    if err.validator == "oneOf" and path and path[-1] == "rotation":
        raise doc.error(path, "rotation must be degrees (2D), {quaternion: [w,x,y,z]}, "
                              "{euler: [a,b,c], order: xyz}, or {axis: [x,y,z], angle: deg}")
    raise doc.error(path, err.message)


# -- placements ---------------------------------------------------------------------------

def rotation_matrix(spec: Any, *, dimension: int, doc: _Located, path: tuple) -> np.ndarray:
    """Rotation matrix ``(dim, dim)`` from a manifest ``rotation`` entry (degrees)."""
    from scipy.spatial.transform import Rotation

    if dimension == 2:
        if not isinstance(spec, (int, float)):
            raise doc.error(path, "2D rotation must be an angle in degrees")
        a = np.radians(float(spec))
        return np.array([[np.cos(a), -np.sin(a)], [np.sin(a), np.cos(a)]])
    if isinstance(spec, (int, float)):
        raise doc.error(path, "3D rotation needs {quaternion: ...}, {euler: ..., order: ...} "
                              "or {axis: ..., angle: ...}")
    if "quaternion" in spec:
        q = np.asarray(spec["quaternion"], dtype=float)
        # divided by its largest entry first: the norm of [1e308, ...] overflows to inf, and
        # q / inf is the zero quaternion, which scipy refuses (a ValueError: exit 3)
        q = q / max(np.abs(q).max(), np.finfo(float).tiny)
        if np.linalg.norm(q) < 1e-12:
            raise doc.error(path + ("quaternion",), "quaternion has zero length")
        w, x, y, z = q / np.linalg.norm(q)
        return Rotation.from_quat([x, y, z, w]).as_matrix()
    if "euler" in spec:
        order = spec["order"]
        # the schema allows any three axes; an Euler sequence needs each to differ from the
        # next (scipy raises a ValueError otherwise, which would be an internal error)
        if any(a.lower() == b.lower() for a, b in zip(order, order[1:])):
            raise doc.error(path + ("order",), f"Euler order '{order}' repeats an axis in "
                                               "consecutive places (e.g. xyz, zxz)")
        return Rotation.from_euler(spec["order"], spec["euler"], degrees=True).as_matrix()
    axis = np.asarray(spec["axis"], dtype=float)
    if np.linalg.norm(axis) < 1e-12:
        raise doc.error(path + ("axis",), "rotation axis has zero length")
    rotvec = axis / np.linalg.norm(axis) * np.radians(float(spec["angle"]))
    return Rotation.from_rotvec(rotvec).as_matrix()


def placement(entry: dict, *, dimension: int, doc: _Located, path: tuple,
              scale: float) -> np.ndarray:
    """Homogeneous placement ``(dim+1, dim+1)`` of a part entry; translation in assembly unit.

    ``scale`` converts the part's unit to the assembly unit: a per-part ``units`` applies to
    the part's geometry and to its translation. The placement maps the part's file
    coordinates (after unit scaling) into the assembly frame, ``x' = R x + t``; ``matrix``
    (4x4; 3x3 in 2D) is an alternative to ``translation`` and ``rotation``.
    """
    d = dimension
    T = np.eye(d + 1)
    if "matrix" in entry:
        if "translation" in entry or "rotation" in entry:
            raise doc.error(path + ("matrix",),
                            "give either matrix or translation/rotation, not both")
        M = np.asarray(entry["matrix"], dtype=float) if _is_rect(entry["matrix"]) else None
        if M is None or M.shape != (d + 1, d + 1):
            shape = "x".join(map(str, M.shape)) if M is not None else "ragged"
            raise doc.error(path + ("matrix",), f"matrix must be {d + 1}x{d + 1}, got {shape}")
        if not np.all(np.isfinite(M)):
            raise doc.error(path + ("matrix",), "matrix has NaN or infinite entries")
        if not np.allclose(M[d], np.eye(d + 1)[d], atol=1e-9):
            raise doc.error(path + ("matrix",), "matrix's last row must be [0, ..., 0, 1]")
        R = M[:d, :d]
        if not np.allclose(R.T @ R, np.eye(d), atol=1e-6) or np.linalg.det(R) < 0:
            raise doc.error(path + ("matrix",),
                            "matrix is not a rigid motion (its 3x3 block must be a rotation)")
        T[:d, :d] = R
        T[:d, d] = M[:d, d] * scale
        return T
    if "translation" in entry:
        t = np.asarray(entry["translation"], dtype=float)
        if t.shape != (d,):
            raise doc.error(path + ("translation",), f"translation must have {d} numbers")
        T[:d, d] = t * scale
    if "rotation" in entry:
        T[:d, :d] = rotation_matrix(entry["rotation"], dimension=d, doc=doc,
                                    path=path + ("rotation",))
    return T


def _is_rect(rows: Any) -> bool:
    return isinstance(rows, list) and all(isinstance(r, list) for r in rows) and \
        len({len(r) for r in rows}) == 1

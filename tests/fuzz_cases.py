"""The fuzzing campaign's cases (``tests/fuzz_campaign.py``): a case is ``(generator, seed)``
and :func:`build` writes its input files into a fresh folder, deterministically.

Generators:

- ``manifest``: YAML manifests drawn with hypothesis from the shipped manifest schema (valid
  ones, and ones damaged after the draw: wrong types, missing or unknown keys, huge, negative
  or NaN numbers, unicode names, absolute, relative, missing or escaping mesh paths);
- ``mesh``: random and degenerate meshes (triangle soups, slivers, duplicated faces, inverted
  normals, self-intersections, 1e-9 and 1e9 scales, coincident duplicate parts, one part,
  2,000 parts, open, flat, empty, NaN) written as STL, OBJ, PLY or GLB, analysed through a
  manifest, as the file itself or as a folder;
- ``mutation``: damaged copies of a small real file of every input format
  (:mod:`fuzzing`), the manifest included, some under a wrong extension.
"""

from __future__ import annotations

import copy
import math
import os
import random
import shutil
import threading
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import trimesh
import yaml
from hypothesis import HealthCheck, Phase, given, settings
from hypothesis import seed as hypothesis_seed
from hypothesis import strategies as st

from ndbg_cli.core.schemas import manifest_schema

from fuzzing import mutate, write_samples

GENERATORS = ("manifest", "mesh", "mutation")
#: Where the real STEP sample comes from (AS1; without it the STEP format is not fuzzed).
STEP = Path(__file__).resolve().parents[2] / "shared" / "data" / "as1" / "as1-oc-214.stp"


@dataclass
class Case:
    """What one case runs: ``ndbg analyze TARGET ARGS`` in ``folder``."""

    generator: str
    seed: int
    folder: Path
    target: str
    args: list[str] = field(default_factory=list)
    note: str = ""

    @property
    def name(self) -> str:
        return f"{self.generator}:{self.seed}"


class Pool:
    """The files cases share, written once per run: the real samples of each format and the
    small meshes manifests refer to (cases get hard links, so each stays in its folder)."""

    def __init__(self, folder: Path) -> None:
        self.folder = folder
        self.samples = write_samples(folder / "samples", STEP if STEP.is_file() else None)
        meshes = folder / "meshes"
        meshes.mkdir(parents=True, exist_ok=True)
        cube = _box((0, 0, 0), (10, 10, 10))
        cube.export(meshes / "cube.stl")
        cube.export(meshes / "cube.obj")
        trimesh.creation.cylinder(radius=3, height=8, sections=16).export(meshes / "pin.ply")
        _box((0, 0, 0), (30, 30, 5)).export(meshes / "plate.stl")
        self.meshes = sorted(p.name for p in meshes.iterdir())
        manifest = folder / "manifest"
        manifest.mkdir(exist_ok=True)
        for name in ("cube.stl", "plate.stl"):
            os.link(meshes / name, manifest / name)
        (manifest / "two.yaml").write_text(
            "name: two\nunits: mm\nbase: plate\nparts:\n  - id: plate\n    mesh: plate.stl\n"
            "  - id: cube\n    mesh: cube.stl\n    translation: [5, 5, 5]\n"
            "    rotation: {euler: [0, 0, 90], order: xyz}\n"
            "joints:\n  - {type: revolute, parts: [cube, plate], axis: [0, 0, 1]}\n")
        self.samples["yaml"] = manifest / "two.yaml"

    def link_meshes(self, folder: Path) -> None:
        for name in self.meshes:
            os.link(self.folder / "meshes" / name, folder / name)


def build(generator: str, seed: int, folder: Path, pool: Pool) -> Case:
    """Write case ``(generator, seed)`` into the empty folder ``folder``."""
    rng = random.Random(f"{generator}:{seed}")  # a string seed: stable across runs
    case = Case(generator, seed, folder, "")
    {"manifest": _manifest_case, "mesh": _mesh_case, "mutation": _mutation_case}[generator](
        case, rng, pool)
    # the motion families: all of them mostly, one alone sometimes (their own code paths)
    motion = rng.choice(("all", "all", "all", "translation", "infinite", "generalized"))
    if "--motion" not in case.args:
        case.args += ["--motion", motion]
    return case


def _box(lo, hi) -> trimesh.Trimesh:
    m = trimesh.creation.box(extents=np.subtract(hi, lo))
    m.apply_translation(np.add(lo, hi) / 2)
    return m


# --- manifests drawn from the schema --------------------------------------------------------

#: Numbers: mostly ordinary lengths and angles, sometimes hostile (one_of picks a branch
#: uniformly: the ordinary ones are repeated so a manifest is not always invalid).
_ORDINARY = st.one_of(st.integers(-20, 20), st.floats(-50, 50, allow_nan=False))
_NUMBER = st.one_of(
    *[_ORDINARY] * 12,
    st.sampled_from([0.0, -0.0, -1.0, 1e-9, -1e-9, 1e9, -1e9, 1e308, -1e308, 5e-324,
                     math.nan, math.inf, -math.inf, 2**63, -(2**63)]),
    st.integers(-(2**80), 2**80))
_NAMES = st.one_of(st.sampled_from(["a", "b", "c", "base", "plate", "cube", "pin"]),
                   st.text(min_size=1, max_size=12),
                   st.sampled_from(["ü-teil", "部品", "a b", "a/b", "..", "index", "-x", "\u202e"]))
_UNITS = st.one_of(*[st.sampled_from(["mm", "cm", "m", "in"])] * 4,
                   st.sampled_from(["MM", "ft", "", "µm"]), st.text())
_ANY = st.recursive(
    st.one_of(st.none(), st.booleans(), _NUMBER, st.text(max_size=20)),
    lambda inner: st.one_of(st.lists(inner, max_size=4),
                            st.dictionaries(st.text(max_size=8), inner, max_size=3)),
    max_leaves=8)


#: Stands for the case's folder in drawn absolute paths.
_HERE = "/FUZZ-CASE-FOLDER"


def _mesh_paths(meshes: list[str]) -> st.SearchStrategy:
    """Mesh paths: mostly the pool's meshes beside the manifest, sometimes absolute,
    missing, escaping the folder, a folder, or odd."""
    return st.one_of(
        st.sampled_from(meshes), st.sampled_from(meshes), st.sampled_from(meshes),
        st.sampled_from(meshes).map(lambda n: f"{_HERE}/{n}"),
        st.sampled_from(["missing.stl", "../cube.stl", "/etc/passwd", ".", "sub/../cube.stl",
                         "cube.STL", "cube.stl\x00x", "~/cube.stl", "C:\\cube.stl",
                         "/dev/zero", "/proc/self/mem"]),
        st.text(min_size=1, max_size=10))


def _from_schema(node: dict, defs: dict, overrides: dict[str, st.SearchStrategy],
                 key: str = "manifest", owner: str = "manifest") -> st.SearchStrategy:
    """A strategy for values valid against the JSON Schema ``node`` (the subset the
    manifest schema uses); ``overrides``: strategies for the values at keys named
    ``OWNER.KEY`` (``OWNER``: the ``$defs`` entry holding it, ``manifest`` at the top; a
    list's items ``OWNER.KEY[]``)."""
    if key in overrides:
        return overrides[key]
    if "$ref" in node:
        name = node["$ref"].split("/")[-1]
        return _from_schema(defs[name], defs, overrides, key, name)
    if "oneOf" in node:
        return st.one_of([_from_schema(n, defs, overrides, key, owner) for n in node["oneOf"]])
    if "enum" in node:
        return st.sampled_from(node["enum"])
    kind = node.get("type")
    if kind == "object":
        props = node.get("properties")
        if not props:
            return st.dictionaries(st.text(max_size=8), _ANY, max_size=3)
        required = set(node.get("required", ()))
        draw = {k: _from_schema(v, defs, overrides, f"{owner}.{k}", owner)
                for k, v in props.items()}
        return st.fixed_dictionaries({k: v for k, v in draw.items() if k in required},
                                     optional={k: v for k, v in draw.items()
                                               if k not in required})
    if kind == "array":
        lo = node.get("minItems", 0)
        return st.lists(_from_schema(node.get("items", {}), defs, overrides, key + "[]", owner),
                        min_size=lo, max_size=max(lo, min(node.get("maxItems", 4), 4)))
    if kind == "number":
        return _NUMBER
    if kind == "string":
        if "pattern" in node:
            return st.from_regex(node["pattern"], fullmatch=True)
        return st.text(min_size=node.get("minLength", 0), max_size=16)
    if kind == "boolean":
        return st.booleans()
    return _ANY


def _matrix() -> st.SearchStrategy:
    """4x4 rigid motions mostly (a translation), sometimes any numbers of any shape."""
    rigid = st.tuples(_NUMBER, _NUMBER, _NUMBER).map(
        lambda t: [[1, 0, 0, t[0]], [0, 1, 0, t[1]], [0, 0, 1, t[2]], [0, 0, 0, 1]])
    return st.one_of(rigid, st.lists(st.lists(_NUMBER, max_size=5), max_size=5))


def _manifest_strategy(meshes: list[str], dimension: int
                       ) -> st.SearchStrategy:
    """Manifests of ``dimension`` (3: parts with meshes, 2: with polygons) from the schema,
    with names, units, paths and matrices drawn where they mean something."""
    schema = manifest_schema()
    ring = st.lists(st.tuples(st.integers(-20, 20), st.integers(-20, 20)).map(list),
                    min_size=3, max_size=6)
    overrides = {"part.mesh": _mesh_paths(meshes), "part.id": _NAMES,
                 "manifest.base": _NAMES, "joint.parts[]": _NAMES, "manifest.units": _UNITS,
                 "part.units": _UNITS, "part.matrix": _matrix(), "part.polygon": ring,
                 # the schema allows 2 or 3 numbers; the dimension needs its own, mostly
                 "part.translation": st.one_of(*[st.lists(_NUMBER, min_size=dimension,
                                                          max_size=dimension)] * 9,
                                               st.lists(_NUMBER, min_size=2, max_size=3)),
                 "part.holes": st.lists(ring, max_size=2),
                 "manifest.dimension": st.just(3) if dimension == 3 else st.sampled_from([2, 2, 3])}
    if dimension == 3:
        overrides.update({"part.polygon": st.nothing(), "part.holes": st.nothing()})
    else:
        overrides.update({"part.mesh": st.nothing(), "part.matrix": st.nothing()})
    return _from_schema(schema, schema["$defs"], overrides)


def _plausible(doc: dict, dimension: int) -> dict:
    """A drawn manifest made one that can be analysed, before any damage: the schema alone
    leaves a part's ``mesh`` (or ``polygon``) optional and allows ``matrix`` beside
    ``translation``, so nearly every draw would be an error and no analysis would run."""
    if dimension == 2:
        doc["dimension"] = 2
    for k, part in enumerate(doc["parts"]):
        if dimension == 3:
            part.setdefault("mesh", "cube.stl")
        else:
            part.setdefault("polygon", [[0, 0], [10, 0], [10, 10], [0, 10]])
            part["polygon"] = [[x + 20 * k, y] for x, y in part["polygon"]]  # mostly apart
        if "matrix" in part and ("translation" in part or "rotation" in part):
            del part["matrix"]
    return doc


def _paths(doc, prefix=()) -> list[tuple]:
    """Every key path in a drawn document, for the damage below to pick from."""
    out = [prefix]
    if isinstance(doc, dict):
        for k, v in doc.items():
            out += _paths(v, (*prefix, k))
    elif isinstance(doc, list):
        for i, v in enumerate(doc):
            out += _paths(v, (*prefix, i))
    return out


#: Damage to a drawn manifest: (which key path, what, a value, a new key).
_DAMAGE = st.lists(st.tuples(st.integers(0, 10**6), st.sampled_from(("replace", "drop", "add")),
                             _ANY, st.text(max_size=8)), min_size=1, max_size=3)


def _damage(doc: dict, ops: list[tuple]) -> list[str]:
    """Break a drawn manifest: a value replaced by any value, a key dropped or added."""
    done = []
    for where, op, value, key in ops:
        paths = [p for p in _paths(doc) if p]
        if not paths:
            break
        path = paths[where % len(paths)]
        parent = doc
        for k in path[:-1]:
            parent = parent[k]
        if op == "replace":
            parent[path[-1]] = value
        elif op == "drop":
            del parent[path[-1]]
        elif isinstance(parent, dict):
            parent[key] = value
        else:
            parent.append(value)
        done.append(f"{op} {'.'.join(map(str, path))}")
    return done


#: Manifests drawn per hypothesis run (a block of case seeds).
BLOCK = 100
_BLOCKS: dict[int, list] = {}
_LOCK = threading.Lock()


def _examples(block: int, meshes: tuple[str, ...]) -> list:
    """The ``BLOCK`` manifests (with their damage) of one hypothesis run seeded ``block``:
    hypothesis draws a run of examples, each new one guided by the last, so a case is the
    ``seed % BLOCK``-th example of run ``seed // BLOCK``: reproducible, through the public
    API only. Runs are kept (the campaign's cases come in order); hypothesis is not
    thread-safe, hence the lock."""
    with _LOCK:
        if block not in _BLOCKS:
            out: list = []
            strategy = st.tuples(st.sampled_from((3, 3, 3, 2)).flatmap(
                lambda d: _manifest_strategy(list(meshes), d).map(
                    lambda m: (d, _plausible(m, d)))),
                st.sampled_from((False, False, True)), _DAMAGE)  # a third damaged

            @settings(max_examples=BLOCK, database=None, phases=[Phase.generate],
                      deadline=None, suppress_health_check=list(HealthCheck))
            @hypothesis_seed(block)
            @given(strategy)
            def collect(example) -> None:
                out.append(copy.deepcopy(example))

            collect()
            _BLOCKS.clear()  # one run at a time is enough: the cases come in order
            _BLOCKS[block] = out
        return _BLOCKS[block]


def _manifest_case(case: Case, rng: random.Random, pool: Pool) -> None:
    folder = case.folder
    pool.link_meshes(folder)
    examples = _examples(case.seed // BLOCK, tuple(pool.meshes))
    (dimension, doc), damaged, ops = copy.deepcopy(examples[case.seed % BLOCK % len(examples)])
    damage = _damage(doc, ops) if damaged else []
    text = yaml.safe_dump(doc, allow_unicode=rng.random() < 0.7, sort_keys=False)
    text = text.replace(_HERE, str(folder))  # absolute mesh paths into this case's folder
    (folder / "m.yaml").write_text(text, encoding="utf-8", errors="surrogatepass")
    case.target = "m.yaml"
    case.note = f"{dimension}D" + (f", damaged: {'; '.join(damage)}" if damage else "")


# --- random and degenerate meshes -------------------------------------------------------------

def _soup(rng: np.random.Generator) -> trimesh.Trimesh:
    tri = rng.uniform(-10, 10, (int(rng.integers(1, 200)), 3, 3))
    return trimesh.Trimesh(tri.reshape(-1, 3), np.arange(len(tri) * 3).reshape(-1, 3),
                           process=False)


def _raw(m: trimesh.Trimesh, vertices=None, faces=None) -> trimesh.Trimesh:
    return trimesh.Trimesh(m.vertices if vertices is None else vertices,
                           m.faces if faces is None else faces, process=False)


def _degenerate(kind: str, rng: np.random.Generator) -> list[trimesh.Trimesh]:
    """The parts of one degenerate assembly of the ``kind`` named."""
    a, b = _box((0, 0, 0), (10, 10, 10)), _box((0, 0, 10), (10, 10, 20))
    if kind == "soup":
        return [_soup(rng) for _ in range(int(rng.integers(1, 4)))]
    if kind == "sliver":
        v = a.vertices.copy()
        v[v[:, 0] > 5, 0] = float(rng.choice([1e-7, 1e-12, 0.0]))
        return [_raw(a, v), b]
    if kind == "duplicate-faces":
        return [_raw(a, faces=np.vstack([a.faces, a.faces[: int(rng.integers(1, 13))]])), b]
    if kind == "inverted":
        return [_raw(a, faces=a.faces[:, ::-1]), b]
    if kind == "self-intersecting":
        c = _box((5, 5, 5), (15, 15, 15))
        return [trimesh.util.concatenate([a, c]), b]
    if kind in ("tiny", "huge"):
        s = 1e-9 if kind == "tiny" else 1e9
        return [_raw(m, m.vertices * s) for m in (a, b)]
    if kind == "coincident":
        return [a, a.copy()] + ([b] if rng.random() < 0.5 else [])
    if kind == "one-part":
        return [a]
    if kind == "open":
        return [_raw(a, faces=a.faces[int(rng.integers(1, 6)):]), b]
    if kind == "flat":
        v = a.vertices.copy()
        v[:, 2] = 0
        return [_raw(a, v), b]
    if kind == "empty":
        return [trimesh.Trimesh(np.zeros((0, 3)), np.zeros((0, 3), int)), b]
    if kind == "nan":
        v = a.vertices.copy()
        v[int(rng.integers(0, len(v))), int(rng.integers(0, 3))] = float(
            rng.choice([np.nan, np.inf, -np.inf, 1e300]))
        return [_raw(a, v), b]
    if kind == "jitter":  # touching within a hair: contact or interference by 1e-7
        return [a, _raw(b, b.vertices + rng.normal(0, 1e-7, b.vertices.shape))]
    if kind in ("many", "crowd"):
        n = MANY_PARTS if kind == "many" else CROWD_PARTS
        ij = np.stack(np.unravel_index(np.arange(n), (20, 10, 10)), axis=1) * 2.0
        gap = float(rng.choice([0.0, 1.0]))  # a grid of touching cubes, or apart
        return [_box(p * (1 + gap) / 2, p * (1 + gap) / 2 + 1) for p in ij]
    raise ValueError(kind)


#: Parts of the ``crowd`` kind (in every campaign) and of the ``many`` kind (instead, with
#: ``FUZZ_MANY=1``): 2,000 tiny cubes, apart or touching in a grid, are beyond any per-case
#: time bound today: the classes' minimum-depth search and the plan's proofs grow faster
#: than the square of the parts, past the ``--max-nodes``/``--max-work`` budgets (40 cubes:
#: 6 s; 150: over a minute; 2,000: over 5 minutes, unfinished). See the README's fuzzing
#: notes.
MANY_PARTS = 2000
CROWD_PARTS = 40

_KINDS = ("soup", "sliver", "duplicate-faces", "inverted", "self-intersecting", "tiny", "huge",
          "coincident", "one-part", "open", "flat", "empty", "nan", "jitter")


def _export(m: trimesh.Trimesh, path: Path) -> None:
    """Write ``m`` as its suffix says, keeping degenerate faces and NaNs where the format can
    (trimesh's exporters would otherwise merge or drop them). Overflows of the 1e300 and
    infinite coordinates are meant: numpy's warnings about them would only clutter the
    campaign's output."""
    with np.errstate(all="ignore"):
        _write_mesh(m, path)


def _write_mesh(m: trimesh.Trimesh, path: Path) -> None:
    if path.suffix == ".glb":
        scene = trimesh.Scene()
        scene.add_geometry(m, node_name=path.stem, geom_name=path.stem)
        path.write_bytes(scene.export(file_type="glb"))
    else:
        data = m.export(file_type=path.suffix[1:])
        path.write_bytes(data.encode() if isinstance(data, str) else data)


def _mesh_case(case: Case, rng: random.Random, pool: Pool) -> None:
    gen = np.random.default_rng(rng.randrange(2**32))
    # a crowd of parts costs seconds: about 1 mesh case in 100; 2,000 parts only when asked
    crowd = rng.random() < 0.01
    kind = ("many" if os.environ.get("FUZZ_MANY") else "crowd") if crowd else rng.choice(_KINDS)
    parts = _degenerate(kind, gen)
    many = crowd
    # GLB rarely: each GLB file is read in a child interpreter of its own (about a second)
    suffix = ".stl" if many else rng.choice((".stl",) * 6 + (".obj",) * 4 + (".ply",) * 4
                                            + (".glb",))
    names = [f"p{i}{suffix}" for i in range(len(parts))]
    for m, name in zip(parts, names):
        _export(m, case.folder / name)
    how = rng.choice(("manifest", "manifest", "file", "folder")) if not many else "manifest"
    if how == "file":
        case.target = names[0]
    elif how == "folder":
        case.target = "."
    else:
        units = rng.choice(("mm", "m", "in")) if kind in ("tiny", "huge") else "mm"
        entries = [{"id": f"p{i}", "mesh": n} for i, n in enumerate(names)]
        doc = {"name": f"{kind}-{case.seed}", "units": units, "parts": entries}
        (case.folder / "m.yaml").write_text(yaml.safe_dump(doc, sort_keys=False))
        case.target = "m.yaml"
    if many:  # the infinite family's pairs would be most of the time: skipped, with a warning
        case.args += ["--infinite-budget", "0"]
    case.note = f"{kind}, {len(parts)} part(s) as {suffix[1:]}, through the {how}"


# --- mutations of real files ------------------------------------------------------------------

#: How often each sample is damaged, relative to the others: the native readers' (a child
#: interpreter each, about a second) and AS1's STEP (seconds) less often.
_WEIGHTS = {"stl": 6, "stl-ascii": 5, "obj": 6, "ply": 5, "ply-ascii": 5, "off": 5, "yaml": 8,
            "glb": 2, "gltf": 2, "3mf": 2, "3dxml": 2, "igs": 2, "step": 1}
_SUFFIXES = (".stl", ".obj", ".ply", ".off", ".glb", ".gltf", ".3mf", ".3dxml", ".igs",
             ".step", ".yaml", ".txt", "")


def _mutation_case(case: Case, rng: random.Random, pool: Pool) -> None:
    names = [n for n in _WEIGHTS if n in pool.samples]
    fmt = rng.choices(names, [_WEIGHTS[n] for n in names])[0]
    source = pool.samples[fmt]
    if fmt == "yaml":  # the manifest's meshes beside it
        for mesh in source.parent.iterdir():
            if mesh != source:
                os.link(mesh, case.folder / mesh.name)
    data, how = source.read_bytes(), "none"
    suffix = source.suffix
    if rng.random() < 0.15:  # a wrong extension, the bytes intact or damaged
        suffix = rng.choice([s for s in _SUFFIXES if s != source.suffix])
        how = "renamed"
    if how == "none" or rng.random() < 0.5:
        data, ops = mutate(data, rng)
        how = ops if how == "none" else f"renamed+{ops}"
    target = case.folder / f"sample{suffix}"
    target.write_bytes(data)
    case.target = target.name
    case.note = f"{fmt} sample, {how}"
    if fmt == "step":
        case.args += ["--motion", "translation"]  # AS1: keep the analysis short


def remove(folder: Path) -> None:
    shutil.rmtree(folder, ignore_errors=True)

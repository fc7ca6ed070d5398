"""Damaged copies of small real files, for the loaders' fuzz tests (test_load_isolation.py)
and the fuzz run of benchmarks/fuzz_loaders.py.

:func:`write_samples` writes one small real file per format (written by trimesh, by the
writers of ``formats.py``, or AS1 when the external data is there); :func:`mutate` damages a
copy the way the files of ``../shared/data/corrupt/`` were damaged (bytes flipped, chunks
spliced, duplicated, deleted or cut off) and the way text formats break (numbers replaced by
huge, negative or non-numeric ones, lines lost).
"""

from __future__ import annotations

import random
import re
from pathlib import Path

import numpy as np
import trimesh

from formats import box_patches, write_3dxml, write_iges_patches

#: The formats :func:`write_samples` writes, by the name of their sample (suffix = format).
FORMATS = ("stl", "stl-ascii", "obj", "ply", "ply-ascii", "off", "glb", "gltf", "3mf",
           "3dxml", "igs", "step")


def _box(lo, hi) -> trimesh.Trimesh:
    m = trimesh.creation.box(extents=np.subtract(hi, lo))
    m.apply_translation(np.add(lo, hi) / 2)
    return m


def write_samples(folder: Path, step: Path | None = None) -> dict[str, Path]:
    """One small real file per format in ``folder`` (two boxes, or one for the single-mesh
    formats; a cylinder where facets must be many); ``step``: a real STEP file to copy
    (else no STEP sample)."""
    folder.mkdir(parents=True, exist_ok=True)
    a, b = _box((0, 0, 0), (10, 10, 10)), _box((0, 0, 10), (10, 10, 20))
    cyl = trimesh.creation.cylinder(radius=3, height=8, sections=24)
    scene = trimesh.Scene()
    scene.add_geometry(a, node_name="lower", geom_name="lower")
    scene.add_geometry(b, node_name="upper", geom_name="upper")
    out: dict[str, Path] = {}

    def put(name: str, data: bytes | str) -> None:
        suffix = name.split("-")[0]
        path = folder / f"{name.replace('-', '_')}.{suffix}"
        path.write_bytes(data.encode() if isinstance(data, str) else data)
        out[name] = path

    put("stl", cyl.export(file_type="stl"))
    put("stl-ascii", cyl.export(file_type="stl_ascii"))
    put("obj", scene.export(file_type="obj"))
    put("ply", cyl.export(file_type="ply", encoding="binary"))
    put("ply-ascii", cyl.export(file_type="ply", encoding="ascii"))
    put("off", cyl.export(file_type="off"))
    put("glb", scene.export(file_type="glb"))
    gltf = scene.export(file_type="gltf", embed_buffers=True)
    put("gltf", gltf["model.gltf"])
    put("3mf", scene.export(file_type="3mf"))
    T = np.eye(4)
    T[:3, 3] = [0, 0, 10]
    write_3dxml(folder / "sample.3dxml", [("lower", a, np.eye(4)), ("upper", a, T)])
    out["3dxml"] = folder / "sample.3dxml"
    write_iges_patches(folder / "sample.igs", box_patches((0, 0, 0), (10, 20, 30)))
    out["igs"] = folder / "sample.igs"
    if step is not None and step.is_file():
        put("step", step.read_bytes())
    return out


_NUMBER = re.compile(rb"-?\d+\.?\d*(?:[eE][-+]?\d+)?")
_BAD_NUMBERS = (b"nan", b"inf", b"-inf", b"1e309", b"-1e308", b"0", b"-1", b"99999999999",
                b"4294967295", b"1.#QNAN", b"", b"x", b"1e-320", b"-0")


def mutate(data: bytes, rng: random.Random) -> tuple[bytes, str]:
    """A damaged copy of ``data`` and how it was damaged (one or two random operations)."""
    ops = []
    for _ in range(rng.choice((1, 1, 2))):
        op = rng.choice(("flip", "flip", "splice", "duplicate", "delete", "truncate",
                         "insert", "number", "number", "zero"))
        n = len(data)
        if n == 0:
            break
        i = rng.randrange(n)
        k = rng.randint(1, max(1, min(4096, n // 4)))
        if op == "flip":
            buf = bytearray(data)
            for _ in range(rng.randint(1, 8)):
                j = rng.randrange(n)
                buf[j] ^= 1 << rng.randrange(8)
            data = bytes(buf)
        elif op == "splice":
            j = rng.randrange(n)
            data = data[:i] + data[j:j + k] + data[i + k:]
        elif op == "duplicate":
            data = data[:i + k] + data[i:i + k] + data[i + k:]
        elif op == "delete":
            data = data[:i] + data[i + k:]
        elif op == "truncate":
            data = data[:i]
        elif op == "insert":
            data = data[:i] + bytes(rng.randrange(256) for _ in range(rng.randint(1, 64))) \
                + data[i:]
        elif op == "zero":
            data = data[:i] + b"\x00" * min(k, n - i) + data[i + k:]
        elif op == "number":
            found = list(_NUMBER.finditer(data[:200000]))
            if not found:
                continue
            chosen = rng.sample(found, min(len(found), rng.randint(1, 4)))
            for m in sorted(chosen, key=lambda m: -m.start()):  # from the end: spans hold
                data = data[:m.start()] + rng.choice(_BAD_NUMBERS) + data[m.end():]
        ops.append(op)
    return data, "+".join(ops) or "none"


def cases(samples: dict[str, Path], per_format: dict[str, int], folder: Path,
          seed: int = 20260101) -> list[tuple[str, Path, str]]:
    """``per_format[name]`` damaged copies of each sample, written into ``folder``, with a
    fixed seed: ``(format, path, how)``."""
    rng = random.Random(seed)
    folder.mkdir(parents=True, exist_ok=True)
    out = []
    for name, path in samples.items():
        data = path.read_bytes()
        for k in range(per_format.get(name, 0)):
            damaged, how = mutate(data, rng)
            q = folder / f"{path.stem}-{k:03d}{path.suffix}"
            q.write_bytes(damaged)
            out.append((name, q, how))
    return out

"""The exploded assembly as a glTF 2.0 binary (``ndbg analyze --glb``): one mesh node per
part and the plan as an animation, for Blender or any glTF viewer.

Written by hand (trimesh exports scenes but no animations): one buffer holding each part's
positions (float32) and indices (uint32), then the animation's times and translations.
``animations[0]`` ("disassembly") has one translation channel per part that moves, over
keyframes at t = 0, 1, ..., n seconds (pose ``j`` at ``t = j``, linear in between: step
``j`` plays from ``j - 1`` to ``j``); each step is also a still pose, its own animation
``"step j"`` (a STEP sampler holding pose ``j``), so a viewer that lists animations shows
any step exploded. Colours are materials (the HTML view's). Deterministic bytes.
"""

from __future__ import annotations

import json
import struct

import numpy as np

from ..core.assembly import Assembly
from ._scene import DisplayMesh, disassembly, display_meshes, poses

_FLOAT, _UINT = 5126, 5125
_ARRAY_BUFFER, _ELEMENT_ARRAY_BUFFER = 34962, 34963


class _Buffer:
    """The binary chunk being built, with its buffer views and accessors."""

    def __init__(self) -> None:
        self.data = bytearray()
        self.views: list[dict] = []
        self.accessors: list[dict] = []

    def add(self, array: np.ndarray, kind: str, target: int | None = None) -> int:
        """Append ``array`` (float32 or uint32, 4-byte aligned); its accessor's index."""
        array = np.ascontiguousarray(array)
        view = {"buffer": 0, "byteOffset": len(self.data), "byteLength": array.nbytes}
        if target is not None:
            view["target"] = target
        self.data += array.astype("<" + array.dtype.str[1:]).tobytes()
        self.views.append(view)
        acc = {"bufferView": len(self.views) - 1, "count": int(array.shape[0]),
               "componentType": _FLOAT if array.dtype == np.float32 else _UINT, "type": kind}
        if kind in ("VEC3", "SCALAR") and array.dtype == np.float32 and array.size:
            flat = array.reshape(array.shape[0], -1)
            acc["min"] = [float(x) for x in flat.min(axis=0)]
            acc["max"] = [float(x) for x in flat.max(axis=0)]
        self.accessors.append(acc)
        return len(self.accessors) - 1


def _rgba(colour: str) -> list[float]:
    return [round(int(colour[i:i + 2], 16) / 255, 4) for i in (1, 3, 5)] + [1.0]


def _meshes(buf: _Buffer, meshes: list[DisplayMesh]) -> tuple[list, list, list]:
    """glTF meshes, materials and nodes: one of each per part, named by the part."""
    gl_meshes, materials, nodes = [], [], []
    for k, m in enumerate(meshes):
        pos = buf.add(m.vertices.astype(np.float32), "VEC3", _ARRAY_BUFFER)
        idx = buf.add(m.faces.reshape(-1).astype(np.uint32), "SCALAR", _ELEMENT_ARRAY_BUFFER)
        materials.append({"name": m.id, "pbrMetallicRoughness": {
            "baseColorFactor": _rgba(m.colour), "metallicFactor": 0.0,
            "roughnessFactor": 0.8}})
        gl_meshes.append({"name": m.id, "primitives": [
            {"attributes": {"POSITION": pos}, "indices": idx, "material": k, "mode": 4}]})
        nodes.append({"name": m.id, "mesh": k, "translation": [0.0, 0.0, 0.0]})
    return gl_meshes, materials, nodes


def _animations(buf: _Buffer, offsets: np.ndarray) -> list[dict]:
    """The whole disassembly, then one still animation per step's pose."""
    steps = offsets.shape[0] - 1
    moving = [k for k in range(offsets.shape[1]) if np.any(offsets[:, k] != 0)]
    if steps == 0 or not moving:
        return []
    times = buf.add(np.arange(steps + 1, dtype=np.float32), "SCALAR")
    channels, samplers = [], []
    for k in moving:
        out = buf.add(offsets[:, k].astype(np.float32), "VEC3")
        samplers.append({"input": times, "output": out, "interpolation": "LINEAR"})
        channels.append({"sampler": len(samplers) - 1, "target": {"node": k,
                                                                  "path": "translation"}})
    anims = [{"name": "disassembly", "channels": channels, "samplers": samplers}]
    still = buf.add(np.zeros(1, dtype=np.float32), "SCALAR")
    for j in range(1, steps + 1):
        ch, sm = [], []
        for k in moving:
            out = buf.add(offsets[j:j + 1, k].astype(np.float32), "VEC3")
            sm.append({"input": still, "output": out, "interpolation": "STEP"})
            ch.append({"sampler": len(sm) - 1, "target": {"node": k, "path": "translation"}})
        anims.append({"name": f"step {j}", "channels": ch, "samplers": sm})
    return anims


def glb_bytes(report: dict, asm: Assembly) -> bytes:
    """The GLB of ``asm`` with the plan of ``report`` as animations."""
    meshes = display_meshes(asm)
    moves = disassembly(report, meshes)
    offsets = poses(meshes, moves)
    buf = _Buffer()
    gl_meshes, materials, nodes = _meshes(buf, meshes)
    anims = _animations(buf, offsets)
    doc = {"asset": {"version": "2.0", "generator": "ndbg"},
           "scene": 0, "scenes": [{"name": asm.name, "nodes": list(range(len(nodes)))}],
           "nodes": nodes, "meshes": gl_meshes, "materials": materials,
           "accessors": buf.accessors, "bufferViews": buf.views,
           "buffers": [{"byteLength": len(buf.data)}],
           "extras": {"steps": [mv.text for mv in moves]}}
    if anims:
        doc["animations"] = anims
    text = json.dumps(doc, sort_keys=True, separators=(",", ":")).encode("utf-8")
    text += b" " * (-len(text) % 4)
    data = bytes(buf.data) + b"\0" * (-len(buf.data) % 4)
    total = 12 + 8 + len(text) + 8 + len(data)
    return (struct.pack("<4sII", b"glTF", 2, total) + struct.pack("<I4s", len(text), b"JSON")
            + text + struct.pack("<I4s", len(data), b"BIN\0") + data)

"""Writers for small real files in formats trimesh cannot export (IGES, 3DXML).

They follow the formats' specifications closely enough for the real readers (OpenCASCADE
through cascadio, trimesh's 3DXML reader) to read them, so the loader tests run on real files.
"""

from __future__ import annotations

import io
import zipfile
from pathlib import Path

import numpy as np

# -- IGES ---------------------------------------------------------------------------------

def _iges_lines(text: str, letter: str, width: int = 72) -> list[str]:
    out, k = [], 0
    while k < len(text) or not out:
        out.append(text[k:k + width])
        k += width
    return [f"{line:<{width}}{letter}{n + 1:7d}" for n, line in enumerate(out)]


def box_patches(lo, hi) -> list[np.ndarray]:
    """The six faces of an axis-aligned box as 2x2 control nets (bilinear patches)."""
    x0, y0, z0 = lo
    x1, y1, z1 = hi
    P = np.array
    return [
        P([[[x0, y0, z0], [x0, y1, z0]], [[x1, y0, z0], [x1, y1, z0]]]),  # bottom
        P([[[x0, y0, z1], [x1, y0, z1]], [[x0, y1, z1], [x1, y1, z1]]]),  # top
        P([[[x0, y0, z0], [x1, y0, z0]], [[x0, y0, z1], [x1, y0, z1]]]),  # front
        P([[[x0, y1, z0], [x0, y1, z1]], [[x1, y1, z0], [x1, y1, z1]]]),  # back
        P([[[x0, y0, z0], [x0, y0, z1]], [[x0, y1, z0], [x0, y1, z1]]]),  # left
        P([[[x1, y0, z0], [x1, y1, z0]], [[x1, y0, z1], [x1, y1, z1]]]),  # right
    ]


def write_iges_patches(path: Path, patches: list[np.ndarray]) -> None:
    """Write bilinear B-spline surfaces (IGES entity 128), millimetres (units flag 2)."""
    start = _iges_lines("ndbg test file", "S")
    g = ("1H,,1H;,4Hndbg,8Htest.igs,4Hndbg,3H0.1,32,38,6,308,15,4Hndbg,1.,2,2HMM,1,1.,"
         "15H20260101.000000,1E-06,1000.,4Hndbg,4Hndbg,11,0,15H20260101.000000;")
    glob = _iges_lines(g, "G")
    d_lines, p_lines = [], []
    for k, net in enumerate(patches):
        de = 2 * k + 1
        pts = net.reshape(-1, 3)  # u fastest: net[i][j] with i = v index, j = u index
        params = [128, 1, 1, 1, 1, 0, 0, 1, 0, 0, 0., 0., 1., 1., 0., 0., 1., 1., 1., 1., 1., 1.]
        params += [float(c) for p in pts for c in p] + [0., 1., 0., 1.]
        text = ",".join(repr(x) if isinstance(x, float) else str(x) for x in params) + ";"
        first_p = len(p_lines) + 1
        chunks = [text[i:i + 64] for i in range(0, len(text), 64)]
        for c in chunks:
            p_lines.append(f"{c:<64}{de:8d}P{len(p_lines) + 1:7d}")
        d1 = f"{128:8d}{first_p:8d}{0:8d}{1:8d}{0:8d}{0:8d}{0:8d}{0:8d}{'00000000':>8}"
        d2 = f"{128:8d}{0:8d}{0:8d}{len(chunks):8d}{0:8d}{'':8}{'':8}{'':8}{0:8d}"
        d_lines.append(f"{d1}D{de:7d}")
        d_lines.append(f"{d2}D{de + 1:7d}")
    term = f"S{len(start):7d}G{len(glob):7d}D{len(d_lines):7d}P{len(p_lines):7d}"
    text = "\n".join(start + glob + d_lines + p_lines + [f"{term:<72}T{1:7d}"]) + "\n"
    Path(path).write_text(text)


# -- 3DXML --------------------------------------------------------------------------------

def write_3dxml(path: Path, instances: list[tuple[str, object, np.ndarray]]) -> None:
    """Write a tessellated 3DXML archive: one reference mesh per distinct mesh object and one
    Instance3D per ``(name, trimesh, 4x4 matrix)``."""
    ns = "http://www.3ds.com/xsd/3DXML"
    refs: dict[int, int] = {}
    body = ['<Reference3D id="1" name="assembly"/>']
    files: dict[str, str] = {}
    next_id = 2
    for name, mesh, matrix in instances:
        key = id(mesh)
        if key not in refs:
            ref, rep, inst = next_id, next_id + 1, next_id + 2
            next_id += 3
            refs[key] = ref
            fname = f"rep{ref}.3DRep"
            body.append(f'<Reference3D id="{ref}" name="ref{ref}"/>')
            body.append(f'<ReferenceRep id="{rep}" name="rep{ref}" format="TESSELLATED" '
                        f'associatedFile="urn:3DXML:{fname}"/>')
            body.append(f'<InstanceRep id="{inst}"><IsAggregatedBy>{ref}</IsAggregatedBy>'
                        f'<IsInstanceOf>{rep}</IsInstanceOf></InstanceRep>')
            pos = ",".join(" ".join(f"{c:.9g}" for c in v) for v in mesh.vertices)
            nor = ",".join(" ".join(f"{c:.9g}" for c in v) for v in mesh.vertex_normals)
            tri = " ".join(str(int(i)) for i in np.asarray(mesh.faces).ravel())
            files[fname] = (f'<?xml version="1.0"?><XMLRepresentation xmlns="{ns}"><Root>'
                            f'<Rep><Faces><Face triangles="{tri}"/></Faces><VertexBuffer>'
                            f'<Positions>{pos}</Positions><Normals>{nor}</Normals>'
                            f'</VertexBuffer></Rep></Root></XMLRepresentation>')
        m = np.asarray(matrix, dtype=float)
        rel = " ".join(f"{c:.9g}" for c in list(m[:3, :3].T.ravel()) + list(m[:3, 3]))
        body.append(f'<Instance3D id="{next_id}" name="{name}"><IsAggregatedBy>1'
                    f'</IsAggregatedBy><IsInstanceOf>{refs[key]}</IsInstanceOf>'
                    f'<RelativeMatrix>{rel}</RelativeMatrix></Instance3D>')
        next_id += 1
    root = (f'<?xml version="1.0"?><Model_3dxml xmlns="{ns}"><ProductStructure root="1">'
            + "".join(body) + "</ProductStructure></Model_3dxml>")
    buf = io.BytesIO()
    with zipfile.ZipFile(buf, "w") as z:
        z.writestr("Manifest.xml", '<?xml version="1.0"?><Manifest><Root>Root.3dxml</Root>'
                   "</Manifest>")
        z.writestr("Root.3dxml", root)
        for fname, text in files.items():
            z.writestr(fname, text)
    Path(path).write_bytes(buf.getvalue())

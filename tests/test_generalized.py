"""Generalized motions (issue 7): the 6D contact constraints, the local-freedom LP, suggested
rotations and screws, threads, and the report section.

Every expected answer is worked out by hand in the test's comments or docstrings. The
end-to-end tests run on real meshes (STL written here, loaded by the real loader) twice: with
contacts worked out by hand (``hand``) and with the real contact stage's
:func:`ndbg_cli.contacts.contacts3d.analyze_contacts` (``real``).

Tolerances: points on axes within ``10 * asm.length_tolerance`` (the assembly's length
tolerance, 1e-4 of the bounding-box diagonal); unit axes within 1e-6; pitches within
``10 * asm.length_tolerance``; sliding rows within ``rows.slide_tol`` (1e-6 of the scaled
speed); mesh overlap volumes against the bounds stated in each test.
"""

from __future__ import annotations

import dataclasses
import json
from dataclasses import dataclass
from importlib import resources
from pathlib import Path

import jsonschema
import manifold3d
import numpy as np
import pytest
import trimesh
import yaml
from scipy.linalg import expm

import ndbg_cli
from ndbg_cli.ndbg.dbg import DBG, mask_of
from ndbg_cli.ndbg.generalized import build as ge
from ndbg_cli.ndbg.generalized import motion_lp as lp
from ndbg_cli.ndbg.generalized import twist as tw
from ndbg_cli.ndbg.model import NDBG, Region
from ndbg_cli.report.generalized import generalized_text

from conftest import ASSEMBLIES

try:
    from ndbg_cli.contacts.contacts3d import analyze_contacts
except ImportError:  # pragma: no cover - the contact stage is written concurrently
    analyze_contacts = None

SECTIONS = 32  # facets of every cylinder and hole (pins and holes share their facets)


@dataclass(frozen=True)
class C:
    """A contact worked out by hand, with the contact stage's fields (normals out of a)."""

    a: str
    b: str
    kind: str
    normals: np.ndarray
    points: np.ndarray
    point_normals: np.ndarray
    area: float = 0.0
    axis: np.ndarray | None = None
    center: np.ndarray | None = None
    radius: float | None = None
    surface: str | None = None
    blocking: str = "any"


def box(lo, hi) -> trimesh.Trimesh:
    lo, hi = np.asarray(lo, float), np.asarray(hi, float)
    m = trimesh.creation.box(extents=hi - lo)
    m.apply_translation((lo + hi) / 2)
    return m


def cylinder(radius: float, z0: float, z1: float, axis: str = "z") -> trimesh.Trimesh:
    """A ``SECTIONS``-gon prism of circumradius ``radius`` along ``axis`` from ``z0`` to
    ``z1``, centred on that coordinate axis."""
    m = trimesh.creation.cylinder(radius=radius, height=z1 - z0, sections=SECTIONS)
    m.apply_translation((0, 0, (z0 + z1) / 2))
    if axis == "x":  # z -> x, x -> y, y -> z (a rotation, so the facets stay aligned)
        m.apply_transform(np.array([[0, 0, 1, 0], [1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 0, 1.0]]))
    return m


def boolean(kind: str, *meshes: trimesh.Trimesh) -> trimesh.Trimesh:
    out = getattr(trimesh.boolean, kind)(list(meshes), engine="manifold")
    out.merge_vertices()
    return out


def write(folder: Path, name: str, meshes: dict[str, trimesh.Trimesh], joints=(),
          extra: dict | None = None) -> ndbg_cli.Assembly:
    """Write ``meshes`` as STL files plus a manifest in ``folder`` and load it."""
    folder.mkdir(parents=True, exist_ok=True)
    parts = []
    for pid, m in meshes.items():
        m.export(folder / f"{pid}.stl")
        parts.append({"id": pid, "mesh": f"{pid}.stl"})
    doc = {"name": name, "units": "mm", "parts": parts, **(extra or {})}
    if joints:
        doc["joints"] = list(joints)
    path = folder / f"{name}.yaml"
    path.write_text(yaml.safe_dump(doc))
    return ndbg_cli.load(path)


# ----------------------------------------------------------------------------- boxes
def box_contacts(boxes: dict[str, tuple]) -> list[C]:
    """Exact planar contacts of touching axis-aligned boxes ``{id: (lo, hi)}``: for each pair
    sharing a face-plane with a positive-area overlap, the overlap rectangle's 4 corners with
    the normal out of the first box (assembly order)."""
    out = []
    ids = list(boxes)
    for x, ia in enumerate(ids):
        for ib in ids[x + 1:]:
            (la, ha), (lb, hb) = (np.asarray(v, float) for v in boxes[ia]), \
                (np.asarray(v, float) for v in boxes[ib])
            for k in range(3):
                for plane, sign in ((ha[k], 1.0), (la[k], -1.0)):
                    other = lb[k] if sign > 0 else hb[k]
                    if abs(plane - other) > 1e-12:
                        continue
                    u, w = [j for j in range(3) if j != k]
                    lo_u, hi_u = max(la[u], lb[u]), min(ha[u], hb[u])
                    lo_w, hi_w = max(la[w], lb[w]), min(ha[w], hb[w])
                    if hi_u - lo_u <= 1e-12 or hi_w - lo_w <= 1e-12:
                        continue
                    pts = []
                    for cu in (lo_u, hi_u):
                        for cw in (lo_w, hi_w):
                            p = np.zeros(3)
                            p[k], p[u], p[w] = plane, cu, cw
                            pts.append(p)
                    n = np.zeros(3)
                    n[k] = sign
                    out.append(C(ia, ib, "planar", n[None, :], np.array(pts),
                                 np.repeat(n[None, :], 4, axis=0),
                                 (hi_u - lo_u) * (hi_w - lo_w)))
    return out


# ----------------------------------------------------------------------------- Fig. 5
#: A 10 x 10 x 2 plate ``a`` between a floor and a lid, held in the plane by four blockers,
#: each touching one side of ``a`` along half of it, arranged like a pinwheel: no translation
#: frees ``a`` (each in-plane direction pushes into a blocker, z into floor or lid) but the
#: counter-clockwise rotation about the vertical axis through the centre (5, 5) separates
#: every blocker (worked out in the test), and that rotation is the only one.
FIG5 = {
    "a": ((0, 0, 0), (10, 10, 2)),
    "floor": ((-5, -5, -1), (15, 15, 0)),
    "lid": ((-5, -5, 2), (15, 15, 3)),
    "left": ((-2, 0, 0), (0, 5, 2)),
    "right": ((10, 5, 0), (12, 10, 2)),
    "front": ((5, -2, 0), (10, 0, 2)),
    "back": ((0, 10, 0), (5, 12, 2)),
}


def fig5(folder: Path) -> tuple[ndbg_cli.Assembly, list[C]]:
    asm = write(folder, "fig5", {k: box(*v) for k, v in FIG5.items()})
    return asm, box_contacts(FIG5)


# ----------------------------------------------------------------------------- hinge
def hinge(folder: Path) -> tuple[ndbg_cli.Assembly, list[C]]:
    """Pin (radius 1, along x, x in [0, 12]) through the base's knuckle (x in [0, 6]) and the
    leaf's knuckle (x in [6, 12]); the leaf's knuckle rests against the base's at x = 6."""
    pin = cylinder(1.0, 0, 12, "x")
    base = boolean("difference", box((0, -10, -2), (6, 2, 2)), cylinder(1.0, -1, 13, "x"))
    leaf = boolean("difference", box((6, -2, -2), (12, 10, 2)), cylinder(1.0, -1, 13, "x"))
    asm = write(folder, "hinge", {"base": base, "leaf": leaf, "pin": pin})
    ang = (np.arange(SECTIONS) + 0.5) * 2 * np.pi / SECTIONS
    r = np.cos(np.pi / SECTIONS)  # facet centres are at the inradius
    contacts = []
    for part, (x0, x1) in (("base", (0, 6)), ("leaf", (6, 12))):
        pts, nrm = [], []
        for x in ((x0 + x1) / 2,):
            for t in ang:
                pts.append([x, r * np.cos(t), r * np.sin(t)])
                nrm.append([0, -np.cos(t), -np.sin(t)])  # out of the knuckle into the pin
        # the facet centres of one row do not constrain tilting: add both ends
        pts = [[x0, p[1], p[2]] for p in pts] + [[x1, p[1], p[2]] for p in pts]
        nrm = nrm + nrm
        contacts.append(C(part, "pin", "curved", np.array(nrm), np.array(pts), np.array(nrm),
                          axis=np.array([1.0, 0, 0]), center=np.zeros(3), radius=1.0,
                          surface="cylinder"))
    sq = np.array([[6, y, z] for y in (-2, 2) for z in (-2, 2)], float)
    n = np.array([1.0, 0, 0])
    contacts.append(C("base", "leaf", "planar", n[None], sq, np.repeat(n[None], 4, 0)))
    return asm, contacts


# ----------------------------------------------------------------------------- bolt
BOLT_JOINT = {"type": "screw", "parts": ["bolt", "block"], "axis": [0, 0, 1],
              "point": [0, 0, 0], "pitch": 1.5}


def bolt(folder: Path, screw: bool) -> tuple[ndbg_cli.Assembly, list[C]]:
    """A bolt (shank radius 1, z in [0, 10], head [-2, 2]^2 x [10, 11]) in a through hole of
    a block [-5, 5]^2 x [0, 10], head resting on the block; ``screw`` declares the thread
    (right-hand, pitch 1.5 mm)."""
    blk = boolean("difference", box((-5, -5, 0), (5, 5, 10)), cylinder(1.0, -1, 11))
    blt = boolean("union", cylinder(1.0, 0, 10.5), box((-2, -2, 10), (2, 2, 11)))
    asm = write(folder, "bolt-screw" if screw else "bolt-plain", {"block": blk, "bolt": blt},
                joints=[BOLT_JOINT] if screw else ())
    ang = (np.arange(SECTIONS) + 0.5) * 2 * np.pi / SECTIONS
    r = np.cos(np.pi / SECTIONS)
    pts = [[r * np.cos(t), r * np.sin(t), z] for z in (0, 10) for t in ang]
    nrm = [[-np.cos(t), -np.sin(t), 0] for _ in (0, 10) for t in ang]
    n = np.array([0, 0, 1.0])
    sq = np.array([[x, y, 10] for x in (-2, 2) for y in (-2, 2)], float)
    contacts = [C("block", "bolt", "curved", np.array(nrm), np.array(pts), np.array(nrm),
                  axis=n, center=np.zeros(3), radius=1.0, surface="cylinder"),
                C("block", "bolt", "planar", n[None], sq, np.repeat(n[None], 4, 0))]
    return asm, contacts


# ----------------------------------------------------------------------------- helpers
SOURCES = ["hand", "real"]


def contacts_for(asm: ndbg_cli.Assembly, hand: list[C], source: str) -> list:
    if source == "hand":
        return hand
    if analyze_contacts is None:
        pytest.skip("ndbg_cli.contacts.contacts3d not available yet")
    result = analyze_contacts(asm)
    assert not result.interferences
    return list(result.contacts)


def bit(asm: ndbg_cli.Assembly, *ids: str) -> int:
    return mask_of(asm.index(i) for i in ids)


def arcs(asm: ndbg_cli.Assembly, dbg: DBG) -> set[tuple[str, str]]:
    return {(asm.ids[i], asm.ids[j]) for i, j in dbg.arcs()}


def math_rows(cs: list[C], ids: list[str], length_tol: float = 1e-9) -> tw.ContactRows:
    """Rows for the pure-math tests: centre at the origin, scale 1 (so the LP's scaled twist
    is the origin twist itself)."""
    idx = {p: k for k, p in enumerate(ids)}
    pts = np.vstack([c.points for c in cs])
    nrm = np.vstack([c.point_normals for c in cs])
    a = np.concatenate([[idx[c.a]] * len(c.points) for c in cs])
    b = np.concatenate([[idx[c.b]] * len(c.points) for c in cs])
    k = np.concatenate([[x] * len(c.points) for x, c in enumerate(cs)])
    return tw.ContactRows(pts, nrm, a, b, k, len(ids), np.zeros(3), 1.0, length_tol,
                          np.arange(len(pts)))


def plane(a: str, b: str, n, pts) -> C:
    n = np.asarray(n, float)
    pts = np.asarray(pts, float).reshape(-1, 3)
    return C(a, b, "planar", n[None], pts, np.repeat(n[None], len(pts), 0))


def square(z: float, lo=0.0, hi=1.0) -> list[list[float]]:
    return [[x, y, z] for x in (lo, hi) for y in (lo, hi)]


# ----------------------------------------------------------------------------- 6D rows
def test_point_on_plane_half_space():
    """Part ``a`` rests at p = (1, 0, 0) on ``b`` below it: n out of a into b is -z. The row
    is g = (n, p x n) = (0, 0, -1, 0, 1, 0) (p x n = (1,0,0) x (0,0,-1) = (0, 1, 0)), and a
    twist X of a is allowed iff g . X <= 0."""
    rows = math_rows([plane("a", "b", (0, 0, -1), [1, 0, 0])], ["a", "b"])
    G, _ = lp.split_rows(rows, 0b01, 0b10)
    np.testing.assert_allclose(G, [[0, 0, -1, 0, 1, 0]])
    Gb, _ = lp.split_rows(rows, 0b10, 0b01)  # b moving: the row flips
    np.testing.assert_allclose(Gb, [[0, 0, 1, 0, -1, 0]])
    speed = {  # n . (v + w x p) by hand
        "lift +z": ((0, 0, 1, 0, 0, 0), -1.0),
        "push -z": ((0, 0, -1, 0, 0, 0), 1.0),
        "slide +x": ((1, 0, 0, 0, 0, 0), 0.0),
        "w = +y about origin: p goes to -z": ((0, 0, 0, 0, 1, 0), 1.0),
        "w = -y about origin: p goes up": ((0, 0, 0, 0, -1, 0), -1.0),
        "w = +x: p is on the axis": ((0, 0, 0, 1, 0, 0), 0.0),
        "w = +y about (1, 0, 0): p on the axis": (tuple(tw.twist("rotation", (0, 1, 0),
                                                                 (1, 0, 0))), 0.0),
    }
    for name, (xi, want) in speed.items():
        got = tw.normal_speeds(rows, np.asarray(xi, float))[0]
        assert got == pytest.approx(want, abs=1e-12), name
        assert (G @ np.asarray(xi, float))[0] == pytest.approx(want, abs=1e-12), name


def test_twist_of_rotation_and_screw():
    """Rotation about the z-line through q = (1, 0, 0): v = -w x q = -(0,0,1) x (1,0,0) =
    (0, -1, 0), so the origin moves along -y and q stays. A right-hand screw of pitch 2 adds
    v_z = 2 / (2 pi)."""
    r = tw.twist("rotation", (0, 0, 2), (1, 0, 0))
    np.testing.assert_allclose(r, [0, -1, 0, 0, 0, 1], atol=1e-15)
    s = tw.twist("screw", (0, 0, 1), (1, 0, 0), pitch=2.0, sense=-1)
    np.testing.assert_allclose(s, [0, 1, -1 / np.pi, 0, 0, -1], atol=1e-15)
    m = tw.classify(s, length_tol=1e-6, scale=1.0, center=(1, 0, 5))
    assert m.type == "screw" and m.pitch == pytest.approx(2.0)  # same handedness either sense
    np.testing.assert_allclose(m.axis, [0, 0, -1], atol=1e-12)
    np.testing.assert_allclose(m.point, [1, 0, 5], atol=1e-12)
    t = tw.classify(np.array([0, 3.0, 4, 0, 0, 0]), length_tol=1e-6, scale=1.0)
    assert t.type == "translation" and t.axis == pytest.approx((0, 0.6, 0.8))


def test_two_opposite_planes_make_a_slab():
    """``m`` between ``f`` (z = 0) and ``c`` (z = 1), unit-square contacts. Allowed twists
    keep v_z + w_x y - w_y x = 0 on both squares: v_z = w_x = w_y = 0; v_x, v_y, w_z slide.
    Nothing breaks a contact, but in-plane translation slides."""
    cs = [plane("m", "f", (0, 0, -1), square(0)), plane("m", "c", (0, 0, 1), square(1))]
    rows = math_rows(cs, ["m", "f", "c"])
    G, _ = lp.split_rows(rows, 0b001, 0b110)
    assert lp.free_motion_rows(rows, 0b001, 0b110) is None
    slide = lp.free_motion_rows(rows, 0b001, 0b110, allow_sliding=True)
    assert slide is not None and slide.type == "translation" and slide.broken == 0
    assert abs(slide.axis[2]) < 1e-9
    spin = tw.twist("rotation", (0, 0, 1), (0.5, 0.5, 0))
    assert np.abs(G @ spin).max() < 1e-12  # rotating in the slab slides
    # tilting about the x-line through (0.5, 0.5, 0.5): the floor corner (0, 0, 0) moves by
    # (1,0,0) x (-0.5,-0.5,-0.5) = (0, 0.5, -0.5): into the floor at speed 0.5
    tilt = tw.twist("rotation", (1, 0, 0), (0.5, 0.5, 0.5))
    assert (G @ tilt).max() == pytest.approx(0.5)
    for d in ((0, 0, 1), (0, 0, -1), (1, 0, 1)):
        assert (G @ np.r_[d, 0, 0, 0]).max() > 0.5


def test_box_in_a_corner():
    """Unit cube ``k`` in the corner of floor (z = 0), wall ``wx`` (x = 0), wall ``wy``
    (y = 0). Translations: allowed iff d >= 0 componentwise. Rotation about the y-line
    through (1, 0, 0) with w = +y: u = w x (p - (1,0,0)) = (z, 0, 1 - x), floor -u_z <= 0,
    wall x: -u_x = -z <= 0, wall y: u_y = 0: allowed, and it lifts the floor contact; w = -y
    pushes the floor. Rotation about the z-line through the origin (the corner edge) pushes
    into wall x for w = +z (u_x = -y w) and into wall y for w = -z."""
    cs = [plane("k", "floor", (0, 0, -1), square(0)),
          plane("k", "wx", (-1, 0, 0), [[0, y, z] for y in (0, 1) for z in (0, 1)]),
          plane("k", "wy", (0, -1, 0), [[x, 0, z] for x in (0, 1) for z in (0, 1)])]
    rows = math_rows(cs, ["k", "floor", "wx", "wy"])
    G, _ = lp.split_rows(rows, 0b0001, 0b1110)
    for d, ok in (((1, 1, 1), True), ((1, 0, 0), True), ((0, 0, 1), True), ((-1, 0, 0), False),
                  ((1, 1, -0.1), False), ((0, -1, 1), False)):
        assert ((G @ np.r_[d, 0, 0, 0]).max() <= 1e-12) == ok, d
    tip = tw.twist("rotation", (0, 1, 0), (1, 0, 0))
    assert (G @ tip).max() <= 1e-12 and (G @ tip).min() < -0.5
    assert (G @ -tip).max() > 0.5
    corner = tw.twist("rotation", (0, 0, 1), (0, 0, 0))
    assert (G @ corner).max() > 0.5 and (G @ -corner).max() > 0.5
    m = lp.free_motion_rows(rows, 0b0001, 0b1110)
    assert m is not None and m.type == "translation" and min(m.axis) >= -1e-9
    assert m.broken == 12  # (1, 1, 1)-like: all three squares separate
    assert lp.free_motion_rows(rows, 0b0001, 0b1110, translation_only=True) is not None


def test_contact_rows_turns_each_cylinder_about_its_own_axis():
    """Four contacts flattened in one call (the rows are built for all contacts at once).

    0: a square "cylinder" about z through (1, 2, 0), facet normals +x, -x, +y, -y, each
    with points at offsets 3 along the normal and +-4 across it (radius 5) at heights 0, 1,
    2: each point turns onto the line where its normal is radial, (1, 2, h) + 5 n, and only
    the lowest and highest point of each normal stay: (6, 2, 0), (6, 2, 2), (-4, 2, 0),
    (-4, 2, 2), (1, 7, 0), (1, 7, 2), (1, -3, 0), (1, -3, 2).
    1: one facet about the x axis through the origin, normal +z, points (h, +-4, 3) at
    h = -1, 0, 3: they turn to (h, 0, 5), and h = -1 and 3 stay.
    2: a planar contact with one normal: its three points unchanged.
    3: an edge contact (``blocking="all"``, normals +x and +y) at two points: one row per
    point and normal, grouped by point.
    """
    def facets(center, axis, normals, heights):
        pts, nrm = [], []
        for n in normals:
            n = np.asarray(n, float)
            t = np.cross(axis, n)
            for side in (4.0, -4.0):
                for h in heights:
                    pts.append(np.asarray(center, float) + h * np.asarray(axis, float)
                               + 3.0 * n + side * t)
                    nrm.append(n)
        return np.array(pts), np.array(nrm)

    z, x = np.array([0, 0, 1.0]), np.array([1.0, 0, 0])
    sq = [[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0]]
    p0, n0 = facets([1, 2, 0], z, sq, (0, 1, 2))
    p1, n1 = facets([0, 0, 0], x, [[0, 0, 1]], (-1, 0, 3))
    p2 = np.array([[0, 0, 9.0], [1, 0, 9], [0, 1, 9]])
    p3 = np.array([[5, 5, 5.0], [5, 5, 6]])
    cs = [C("a", "b", "curved", np.array(sq, float), p0, n0, axis=z, center=np.array([1, 2, 0.0]),
            surface="cylinder"),
          C("b", "c", "curved", np.array([[0, 0, 1.0]]), p1, n1, axis=x, center=np.zeros(3),
            surface="cylinder"),
          C("a", "c", "planar", np.array([[0, 0, 2.0]]), p2, np.tile([0, 0, 2.0], (3, 1))),
          C("c", "a", "edge", np.array([[2, 0, 0.0], [0, 3, 0]]), p3, np.zeros((2, 3)),
            blocking="all")]
    idx = {"a": 0, "b": 1, "c": 2}

    class _Asm:  # contact_rows needs ids, the size, the centre and the tolerance only
        length_tolerance = 1e-6
        size, centre = float(np.sqrt(1200.0)), np.zeros(3)  # a 20 mm cube's, at the origin

        def __len__(self):
            return 3

        def index(self, pid):
            return idx[pid]

    rows = tw.contact_rows(_Asm(), cs)  # type: ignore[arg-type]
    ex, ey = [1, 0, 0], [0, 1, 0]
    want_p = [[6, 2, 0], [6, 2, 2], [-4, 2, 0], [-4, 2, 2], [1, 7, 0], [1, 7, 2], [1, -3, 0],
              [1, -3, 2], [-1, 0, 5], [3, 0, 5], [0, 0, 9], [1, 0, 9], [0, 1, 9],
              [5, 5, 5], [5, 5, 5], [5, 5, 6], [5, 5, 6]]
    want_n = [ex, ex, [-1, 0, 0], [-1, 0, 0], ey, ey, [0, -1, 0], [0, -1, 0], [0, 0, 1],
              [0, 0, 1]] + [[0, 0, 1]] * 3 + [ex, ey, ex, ey]
    np.testing.assert_allclose(rows.points, want_p, atol=1e-12)
    np.testing.assert_allclose(rows.normals, want_n, atol=1e-12)
    assert list(rows.contact) == [0] * 8 + [1] * 2 + [2] * 3 + [3] * 4
    assert list(rows.a) == [0] * 8 + [1] * 2 + [0] * 3 + [2] * 4
    assert list(rows.b) == [1] * 8 + [2] * 2 + [2] * 3 + [0] * 4
    assert list(rows.group) == list(range(13)) + [13, 13, 14, 14]


def test_edge_contact_blocks_only_when_every_normal_does():
    """An edge contact with normals (1, 0, 0) and (0, 1, 0) (``blocking="all"``): ``a``
    moving along +x pushes along n1 but slides past n2 (0): not blocked; along (1, 1, 0) it
    pushes along both: blocked."""
    e = C("a", "b", "edge", np.array([[1.0, 0, 0], [0, 1, 0]]), np.array([[0, 0, 0],
                                                                          [0, 0, 1.0]]),
          np.array([[0.7071, 0.7071, 0]] * 2), blocking="all")
    asm_like = [e]
    idx = {"a": 0, "b": 1}

    class _Asm:  # contact_rows needs ids, the size, the centre and the tolerance only
        length_tolerance = 1e-9
        size, centre = float(np.sqrt(3.0)), np.full(3, 0.5)  # the unit cube's
        parts = (0, 1)

        def __len__(self):
            return 2

        def index(self, pid):
            return idx[pid]

    rows = tw.contact_rows(_Asm(), asm_like)  # type: ignore[arg-type]
    assert len(rows.a) == 4 and list(rows.group) == [0, 0, 1, 1]
    assert arcs_of(ge.motion_dbg(rows, np.r_[1.0, 0, 0, 0, 0, 0])) == set()
    assert arcs_of(ge.motion_dbg(rows, np.r_[1.0, 1, 0, 0, 0, 0])) == {(0, 1)}
    assert arcs_of(ge.motion_dbg(rows, np.r_[-1.0, -1, 0, 0, 0, 0])) == {(1, 0)}


def arcs_of(dbg: DBG) -> set[tuple[int, int]]:
    return set(dbg.arcs())


# ----------------------------------------------------------------------------- Fig. 5
@pytest.mark.parametrize("source", SOURCES)
def test_fig5_needs_a_rotation(tmp_path, source):
    """Hand analysis of :data:`FIG5` (``a`` = [0,10]^2 x [0,2]). Translations: +x pushes into
    ``right``, -x into ``left``, +y into ``back``, -y into ``front``, +-z into lid/floor, so
    every in-plane d with a nonzero component is blocked and no translation frees ``a``.
    Rotation w = +z about (qx, qy): ``left`` (x = 0, y in [0,5], n = -x) separates iff
    -u_x = (y - qy) <= 0 for y <= 5, i.e. qy >= 5; ``right`` (x = 10, y in [5,10], n = +x):
    u_x = -(y - qy) <= 0 iff qy <= 5; ``front`` (y = 0, x in [5,10], n = -y): -u_y =
    -(x - qx) <= 0 iff qx <= 5; ``back`` (y = 10, x in [0,5], n = +y): (x - qx) <= 0 iff
    qx >= 5. Hence the only freeing motion is the counter-clockwise rotation about the z-line
    through (5, 5); it breaks the 8 blocker corners off that line (2 per blocker)."""
    asm, hand = fig5(tmp_path)
    rows = tw.contact_rows(asm, contacts_for(asm, hand, source))
    a = bit(asm, "a")
    rest = rows_full(asm) & ~a
    assert lp.free_motion_rows(rows, a, rest, translation_only=True, allow_sliding=True) is None
    m = lp.free_motion_rows(rows, a, rest)
    assert m is not None and m.type == "rotation" and m.broken == 8
    np.testing.assert_allclose(m.axis, (0, 0, 1), atol=1e-6)
    tol = 10 * asm.length_tolerance
    assert np.linalg.norm(np.array(m.point[:2]) - (5, 5)) <= tol
    found = ge.needs_rotation(asm, rows)
    assert [asm.ids[i] for s, _ in found for i in range(len(asm)) if s >> i & 1] == ["a"]
    # on the meshes: turning a by the motion (0.02 at the corners) overlaps nothing, the
    # reverse turn cuts into the four blockers
    assert overlap_after(asm, a, np.asarray(m.twist), 0.02) <= 1e-6
    assert overlap_after(asm, a, -np.asarray(m.twist), 0.02) > 1e-3
    # the blockers come out by translation (e.g. ``left`` along -x): no rotation needed
    left = lp.free_motion_rows(rows, bit(asm, "left"), rows_full(asm) & ~bit(asm, "left"))
    assert left is not None and left.type == "translation" and left.axis[0] < 0


def rows_full(asm: ndbg_cli.Assembly) -> int:
    return (1 << len(asm)) - 1


def overlap_after(asm: ndbg_cli.Assembly, moved: int, xi: np.ndarray, disp: float) -> float:
    """Volume of (moved parts after the rigid motion ``xi`` run until their fastest vertex
    has moved ``disp``) intersected with the other parts, by manifold3d."""
    mv = [p.mesh for i, p in enumerate(asm.parts) if moved >> i & 1]
    rs = [p.mesh for i, p in enumerate(asm.parts) if not moved >> i & 1]
    verts = np.vstack([m.vertices for m in mv])
    speed = np.linalg.norm(xi[:3] + np.cross(xi[3:], verts), axis=1).max()
    before = (solid(mv) ^ solid(rs)).volume()
    return (solid(mv, rigid(xi, disp / speed)) ^ solid(rs)).volume() - before


def test_shipped_fig5_example():
    """``assemblies/fig5-rotation.yaml`` (examples engineer): its ``expect.rotation`` axis
    (either orientation; the sense is checked by the LP's feasibility) and point."""
    path = ASSEMBLIES / "fig5-rotation.yaml"
    if not path.exists() or analyze_contacts is None:
        pytest.skip("assemblies/fig5-rotation.yaml or the contact stage not available yet")
    asm = ndbg_cli.load(path)
    rows = tw.contact_rows(asm, analyze_contacts(asm).contacts)
    exp = asm.expect["rotation"]
    found = ge.needs_rotation(asm, rows, ge.generalized_ndbg(asm, rows=rows))
    assert found, "no subassembly needs a rotation"
    axis = np.asarray(exp["axis"], float) / np.linalg.norm(exp["axis"])
    ok = []
    for _, mo in found:
        par = abs(float(np.dot(mo.axis, axis))) >= 1 - 1e-6
        d = np.asarray(exp["point"], float) - np.asarray(mo.point)
        on_line = np.linalg.norm(np.cross(d, axis)) <= 10 * asm.length_tolerance
        ok.append(par and on_line)
    assert any(ok), [mo.record() for _, mo in found]
    # and by the library entry point, moving the key: counter-clockwise (w = +z) only
    key = bit(asm, "key")
    m = lp.free_motion(asm, rows, key)
    assert m is not None and m.type == "rotation" and m.axis == pytest.approx((0, 0, 1))
    assert lp.free_motion(asm, rows, key, translation_only=True, allow_sliding=True) is None
    G, _ = lp.split_rows(rows, key, rows_full(asm) & ~key)
    cw = tw.to_scaled(rows, tw.twist("rotation", (0, 0, -1), exp["point"]))
    assert (G @ cw).max() > 0.01  # rotation_free_clockwise: false


# ----------------------------------------------------------------------------- hinge
@pytest.mark.parametrize("source", SOURCES)
def test_hinge(tmp_path, source):
    """Hand analysis of :func:`hinge` (pin along the x-axis). Suggested: the rotation about
    the x-axis (both pin contacts merge into one line) and the translation along it. Rotating
    about the pin slides every contact (radial normals, the x = 6 face turns in its plane):
    no arcs. Translating +x: the base's face (normal +x out of base) pushes into the leaf:
    arc base -> leaf; -x: leaf -> base. The leaf's only freeing translation is +x; any other
    direction pushes into the pin (radial) or the base (x = 6 face)."""
    asm, hand = hinge(tmp_path)
    cs = contacts_for(asm, hand, source)
    rows = tw.contact_rows(asm, cs)
    g = ge.generalized_ndbg(asm, cs, rows=rows)
    kinds = sorted((r.motion["type"], r.motion["sense"]) for r in g.regions)
    assert kinds == [("rotation", -1), ("rotation", 1), ("translation", -1),
                     ("translation", 1)]
    for r in g.regions:
        assert abs(r.motion["axis"][0]) == pytest.approx(1.0, abs=1e-6)
        if r.motion["type"] == "rotation":
            p = np.asarray(r.motion["point"])
            assert np.hypot(p[1], p[2]) <= 10 * asm.length_tolerance
            assert arcs(asm, r.dbg) == set()
        else:
            want = {("base", "leaf")} if r.motion["axis"][0] > 0 else {("leaf", "base")}
            assert arcs(asm, r.dbg) == want
    leaf = bit(asm, "leaf")
    rest = rows_full(asm) & ~leaf
    m = lp.free_motion_rows(rows, leaf, rest)
    assert m is not None and m.type == "translation"
    np.testing.assert_allclose(m.axis, (1, 0, 0), atol=1e-6)
    G, _ = lp.split_rows(rows, leaf, rest)
    for d in ((-1, 0, 0), (0, 1, 0), (0, -1, 0), (0, 0, 1), (1, 1, 0), (1, 0, -1)):
        x = np.r_[d, 0, 0, 0] / np.linalg.norm(d)
        assert (G @ x).max() > 0.09, d  # pushes in at >= sin(pi/32)-ish speeds
    spin = tw.to_scaled(rows, tw.twist("rotation", (1, 0, 0), (0, 0, 0)))
    assert np.abs(G @ spin).max() <= rows.slide_tol  # the leaf turns about the pin
    assert not ge.needs_rotation(asm, rows, g)


# ----------------------------------------------------------------------------- bolt
@pytest.mark.parametrize("source", SOURCES)
def test_bolt_with_declared_thread_only_screws_out(tmp_path, source):
    """Hand analysis of :func:`bolt` with the screw joint (right-hand, pitch 1.5, axis +z).
    The thread forbids every relative motion but the screw. Turning with w = +z advances
    +z (pitch > 0): the head (block's top, normal +z out of block) lifts off, the shank
    slides: free. The reverse screws the head into the block. Suggested motions: rotation
    and translation along the z-axis (from the cylinder) are blocked both ways by the
    thread; the screw (sense +1) has the single arc block -> bolt (the block moving by the
    same twist pushes into the head), sense -1 the arc bolt -> block."""
    asm, hand = bolt(tmp_path, screw=True)
    cs = contacts_for(asm, hand, source)
    rows = tw.contact_rows(asm, cs)
    b = bit(asm, "bolt")
    rest = rows_full(asm) & ~b
    thr = ge.threads(asm)
    assert lp.free_motion_rows(rows, b, rest, threads=thr, translation_only=True,
                               allow_sliding=True) is None
    m = lp.free_motion_rows(rows, b, rest, threads=thr)
    assert m is not None and m.type == "screw"
    np.testing.assert_allclose(m.axis, (0, 0, 1), atol=1e-6)
    assert m.pitch == pytest.approx(1.5, abs=10 * asm.length_tolerance)
    assert np.hypot(*m.point[:2]) <= 10 * asm.length_tolerance
    # (no mesh check here: the meshes are 32-gon prisms, which really do collide when turned;
    # the contact is read as the round cylinder it stands for)
    g = ge.generalized_ndbg(asm, cs, rows=rows)
    both = {("bolt", "block"), ("block", "bolt")}
    for r in g.regions:
        mo = r.motion
        if mo["type"] == "screw":
            assert mo["pitch"] == pytest.approx(1.5) and mo["source"] == "screw joint bolt-block"
            want = {("block", "bolt")} if mo["axis"][2] > 0 else {("bolt", "block")}
            assert arcs(asm, r.dbg) == want
        else:
            assert arcs(asm, r.dbg) == both, mo
    assert ge.threaded_pairs(asm) == {("bolt", "block")}
    # one partition {bolt | block}, reported once: no base, equal sizes -> the side without
    # part 0 (the block) moves
    assert [s for s, _ in ge.needs_rotation(asm, rows, g)] == [b]


@pytest.mark.parametrize("source", SOURCES)
def test_bolt_as_plain_cylinder_translates_out(tmp_path, source):
    """Without the thread (no joint, or ``threads_as_cylinders``) the shank slides in its
    hole and the head lifts off along +z: a translation, and nothing needs a rotation. The
    suggested translation +z then has the single arc block -> bolt, the rotations none."""
    for screw in (False, True):
        asm, hand = bolt(tmp_path / str(screw), screw=screw)
        cs = contacts_for(asm, hand, source)
        rows = tw.contact_rows(asm, cs)
        b = bit(asm, "bolt")
        thr = ge.threads(asm, threads_as_cylinders=True)
        assert thr == [] and ge.threaded_pairs(asm, threads_as_cylinders=True) == set()
        m = lp.free_motion_rows(rows, b, rows_full(asm) & ~b, threads=thr)
        assert m is not None and m.type == "translation"
        np.testing.assert_allclose(m.axis, (0, 0, 1), atol=1e-6)
        g = ge.generalized_ndbg(asm, cs, rows=rows, threads_as_cylinders=True)
        for r in g.regions:
            mo = r.motion
            if mo["type"] == "rotation":
                assert arcs(asm, r.dbg) == set()
            elif mo["type"] == "translation":
                want = {("block", "bolt")} if mo["axis"][2] > 0 else {("bolt", "block")}
                assert arcs(asm, r.dbg) == want
        assert not ge.needs_rotation(asm, rows, g, threads_as_cylinders=True)


def test_block_threads_in_translational_ndbg():
    """A translational NDBG over (bolt, block) with region +z: arc block -> bolt (the plain
    cylinder lets the bolt lift) and region -z: bolt -> block. Declaring the thread blocks
    both ways in every region; pairs naming absent parts are ignored."""
    n = NDBG("infinitesimal_translation", ("block", "bolt"),
             (Region(0, (0, 0, 1), DBG.from_arcs(2, [(0, 1)])),
              Region(0, (0, 0, -1), DBG.from_arcs(2, [(1, 0)]))))
    out = ge.block_threads(n, {("bolt", "block"), ("nut", "block")})
    assert [set(r.dbg.arcs()) for r in out.regions] == [{(0, 1), (1, 0)}] * 2
    assert out.family == n.family and out.regions[0].direction == (0, 0, 1)
    assert ge.block_threads(n, set()) is n


# ----------------------------------------------------------------------------- LP vs meshes
GRID = (3, 3, 2)


def polycubes(seed: int, k: int = 4) -> dict[str, list[tuple[int, int, int]]]:
    """Unit cells of a 3 x 3 x 2 grid split into ``k`` connected parts by random growth."""
    rng = np.random.default_rng(seed)
    cells = [(x, y, z) for x in range(GRID[0]) for y in range(GRID[1]) for z in range(GRID[2])]
    label = {c: -1 for c in cells}
    for p, i in enumerate(rng.choice(len(cells), k, replace=False)):
        label[cells[i]] = p
    while any(v < 0 for v in label.values()):
        c = cells[rng.integers(len(cells))]
        if label[c] >= 0:
            continue
        nb = [label[n] for n in neighbours(c) if label.get(n, -1) >= 0]
        if nb:
            label[c] = int(rng.choice(nb))
    out: dict[str, list] = {}
    for c, p in label.items():
        out.setdefault(f"p{p}", []).append(c)
    return out


def neighbours(c):
    for k in range(3):
        for s in (-1, 1):
            n = list(c)
            n[k] += s
            yield tuple(n)


def polycube_contacts(parts: dict[str, list]) -> list[C]:
    """Exact contacts: one unit square per pair of face-adjacent cells of different parts
    (the union of a pair's squares has the same convex hull constraints as its polygon)."""
    owner = {c: p for p, cs in parts.items() for c in cs}
    out = []
    for c, p in owner.items():
        for k in range(3):
            n = list(c)
            n[k] += 1
            q = owner.get(tuple(n))
            if q is None or q == p:
                continue
            u, w = [j for j in range(3) if j != k]
            pts = []
            for du in (0, 1):
                for dw in (0, 1):
                    v = [0.0, 0.0, 0.0]
                    v[k], v[u], v[w] = c[k] + 1, c[u] + du, c[w] + dw
                    pts.append(v)
            normal = np.zeros(3)
            normal[k] = 1.0
            out.append(plane(p, q, normal, pts))
    return out


def rigid(xi: np.ndarray, t: float) -> np.ndarray:
    """4x4 transform of the twist ``xi`` (origin convention) applied for time ``t``."""
    v, w = xi[:3], xi[3:]
    m = np.zeros((4, 4))
    m[:3, :3] = [[0, -w[2], w[1]], [w[2], 0, -w[0]], [-w[1], w[0], 0]]
    m[:3, 3] = v
    return expm(m * t)


def solid(meshes: list[trimesh.Trimesh], transform: np.ndarray | None = None
          ) -> manifold3d.Manifold:
    """manifold3d union of ``meshes`` (each moved by ``transform``)."""
    out = []
    for m in meshes:
        v = m.vertices if transform is None else trimesh.transform_points(m.vertices, transform)
        out.append(manifold3d.Manifold(manifold3d.Mesh(
            vert_properties=np.asarray(v, np.float32), tri_verts=np.asarray(m.faces, np.uint32))))
    return manifold3d.Manifold.batch_boolean(out, manifold3d.OpType.Add)


@pytest.mark.parametrize("seed", range(6))
def test_lp_motions_do_not_interpenetrate(tmp_path, seed):
    """For every split of a random polycube assembly, when the LP returns a motion, moving the
    split's meshes by it (largest displacement 0.02, the cells are 1) leaves an overlap volume
    with the rest below 1e-5 (second-order effects of an exact first-order motion; a
    first-order penetration at that displacement overlaps by ~1e-2 * contact area, which the
    reversed motion shows). The hand contacts are used here; the real ones are compared to
    them on the same meshes."""
    parts = polycubes(seed)
    meshes = {p: boolean("union", *[box(c, np.add(c, 1)) for c in cs]) for p, cs in parts.items()}
    asm = write(tmp_path, f"poly{seed}", meshes)
    hand = polycube_contacts(parts)
    rows = tw.contact_rows(asm, hand)
    if analyze_contacts is not None:  # the contact stage agrees on which splits are free
        real = tw.contact_rows(asm, analyze_contacts(asm).contacts)
    full = rows_full(asm)
    found = 0
    for s, prefer in ((s, p) for s in range(1, full) for p in (True, False)):
        m = lp.free_motion_rows(rows, s, full & ~s, prefer_translation=prefer)
        if analyze_contacts is not None:
            assert (lp.free_motion_rows(real, s, full & ~s, prefer_translation=prefer) is None
                    ) == (m is None), s
        if m is None:
            continue
        found += 1
        moved = [asm.parts[i].mesh for i in range(len(asm)) if s >> i & 1]
        rest = [asm.parts[i].mesh for i in range(len(asm)) if not s >> i & 1]
        xi = np.asarray(m.twist)
        verts = np.vstack([x.vertices for x in moved])
        speed = np.linalg.norm(xi[:3] + np.cross(xi[3:], verts), axis=1).max()
        t = 0.02 / speed
        b = solid(rest)
        vol = (solid(moved, rigid(xi, t)) ^ b).volume()
        assert vol <= 1e-5, (s, m.record(), vol)
        if m.broken:
            assert (solid(moved, rigid(xi, -t)) ^ b).volume() > 1e-4, (s, m.record())
    assert found > 0


@pytest.mark.parametrize("seed", range(3))
def test_rotation_rows_match_meshes(tmp_path, seed):
    """The 6D rows against the meshes for rotations: for each single part of a random
    polycube assembly and each rotation about a grid line (axis x, y or z through integer
    points, both senses), the rows say allowed (every ``G x <= 0``, one ``< 0``) or clearly
    blocked (some ``G x >= 0.05``, a penetration speed); turning the part by 0.02 (largest
    displacement) must then overlap the rest by <= 1e-5, resp. > 1e-6."""
    parts = polycubes(seed)
    meshes = {p: boolean("union", *[box(c, np.add(c, 1)) for c in cs]) for p, cs in parts.items()}
    asm = write(tmp_path, f"poly{seed}", meshes)
    rows = tw.contact_rows(asm, polycube_contacts(parts))
    full = rows_full(asm)
    checked = {"allowed": 0, "blocked": 0}
    lines = [(k, p) for k in range(3) for p in np.ndindex(4, 4, 3) if p[k] == 0]
    for i, part in enumerate(asm.parts):
        s = 1 << i
        G, _ = lp.split_rows(rows, s, full & ~s)
        b = solid([asm.parts[j].mesh for j in range(len(asm)) if j != i])
        verts = part.mesh.vertices
        for k, point in lines:
            for sense in (1, -1):
                xi = tw.twist("rotation", np.eye(3)[k], point, sense=sense)
                g = G @ tw.to_scaled(rows, xi)
                allowed = g.max() <= 1e-9 and g.min() < -1e-3
                if not allowed and g.max() < 0.05:
                    continue
                speed = np.linalg.norm(np.cross(xi[3:], verts) + xi[:3], axis=1).max()
                vol = (solid([part.mesh], rigid(xi, 0.02 / speed)) ^ b).volume()
                if allowed:
                    assert vol <= 1e-5, (part.id, k, point, sense, vol)
                else:
                    assert vol > 1e-6, (part.id, k, point, sense, g.max())
                checked["allowed" if allowed else "blocked"] += 1
    assert checked["allowed"] > 0 and checked["blocked"] > 0, checked


# ----------------------------------------------------------------------------- shipped
def shipped(name: str) -> tuple[ndbg_cli.Assembly, tw.ContactRows, list]:
    path = ASSEMBLIES / f"{name}.yaml"
    if not path.exists() or analyze_contacts is None:
        pytest.skip(f"{path.name} or the contact stage not available yet")
    asm = ndbg_cli.load(path)
    cs = list(analyze_contacts(asm).contacts)
    return asm, tw.contact_rows(asm, cs), cs


def test_shipped_hinge():
    """``assemblies/hinge.yaml``: leaf_a's knuckle sits between leaf_b's (x = 10 and 20 faces)
    on the pin: no translation frees it; it turns about the x-axis (the revolute joint, also
    suggested by the pin contacts: one merged line), a sliding motion; the pin slides out
    along +-x."""
    asm, rows, cs = shipped("hinge")
    exp = asm.expect
    a = bit(asm, "leaf_a")
    assert lp.free_motion_rows(rows, a, rows_full(asm) & ~a, translation_only=True,
                               allow_sliding=True) is None
    g = ge.generalized_ndbg(asm, cs, rows=rows)
    rot = [r for r in g.regions if r.motion["type"] == "rotation"]
    assert len(rot) == 2 and "revolute joint leaf_a-pin" in rot[0].motion["source"]
    axis = np.asarray(exp["leaf_a_rotation_with_joint"]["axis"], float)
    for r in rot:
        assert abs(np.dot(r.motion["axis"], axis)) == pytest.approx(1.0, abs=1e-6)
        d = np.asarray(r.motion["point"]) - exp["leaf_a_rotation_with_joint"]["point"]
        assert np.linalg.norm(np.cross(d, axis)) <= 10 * asm.length_tolerance
        assert r.dbg.is_free(a)
    G, _ = lp.split_rows(rows, a, rows_full(asm) & ~a)
    spin = tw.to_scaled(rows, np.asarray(rot[0].motion["twist"]))
    assert np.abs(G @ spin).max() <= rows.slide_tol
    pin = bit(asm, "pin")
    m = lp.free_motion_rows(rows, pin, rows_full(asm) & ~pin, allow_sliding=True)
    assert m is not None and m.type == "translation" and abs(m.axis[0]) == pytest.approx(1)


@pytest.mark.parametrize("name", ["bolt-screw", "bolt-plain"])
def test_shipped_bolts(name):
    """``assemblies/bolt-*.yaml``: with the screw joint the bolt comes out only by the
    unscrewing motion of its ``expect.unscrew`` block (w = +z, advance 1.25 / 2 pi per
    radian); without it, by translation along +z."""
    asm, rows, cs = shipped(name)
    b = bit(asm, "bolt")
    rest = rows_full(asm) & ~b
    thr = ge.threads(asm)
    m = lp.free_motion_rows(rows, b, rest, threads=thr)
    assert m is not None
    if asm.expect["translation_free"]:
        assert m.type == "translation"
        np.testing.assert_allclose(m.axis, asm.expect["removal_directions"][0], atol=1e-6)
        return
    assert lp.free_motion_rows(rows, b, rest, threads=thr, translation_only=True,
                               allow_sliding=True) is None
    un = asm.expect["unscrew"]
    assert m.type == "screw"
    np.testing.assert_allclose(m.axis, un["omega"], atol=1e-6)
    assert m.pitch / (2 * np.pi) == pytest.approx(un["velocity_per_radian"][2], rel=1e-6)
    d = np.asarray(m.point) - un["point"]
    assert np.linalg.norm(np.cross(d, un["omega"])) <= 10 * asm.length_tolerance
    # threads as cylinders: the plain translation is back
    plain = lp.free_motion_rows(rows, b, rest, threads=ge.threads(asm, True))
    assert plain is not None and plain.type == "translation"


# ----------------------------------------------------------------------------- section
def test_section_schema_text_and_partitionings(tmp_path):
    """The report section of the declared bolt validates against the fragment schema, and
    holds the hand-derived facts: the threaded pair, the screw's single arc, the bolt needing
    a (screw) rotation, and the LP-validated candidates {bolt | block} (either side moving)."""
    asm, hand = bolt(tmp_path, screw=True)
    rows = tw.contact_rows(asm, hand)
    g = ge.generalized_ndbg(asm, hand, rows=rows)
    sec = ge.generalized_section(asm, g, rows)
    schema = json.loads(resources.files("ndbg_cli").joinpath(
        "schemas/fragments/generalized.json").read_text())
    jsonschema.validate(json.loads(json.dumps(sec)), schema)
    assert sec["threaded_pairs"] == [["bolt", "block"]]
    screw = [m for m in sec["suggested_motions"] if m["type"] == "screw" and m["sense"] == 1]
    assert screw[0]["arcs"] == [["block", "bolt"]]
    assert [e["parts"] for e in sec["needs_rotation"]] == [["bolt"]]
    assert sec["needs_rotation"][0]["motion"]["type"] == "screw"
    assert sorted(c["moved"] for c in sec["candidates"]) == [["block"], ["bolt"]]
    text = generalized_text(sec)
    assert text[0] == "Generalized motions: 6 suggested, 1 threaded pair(s)"  # 3 lines x 2
    assert any("needs rotation: {bolt} by screw about (+0, +0, +1)" in t for t in text)
    assert any("threaded: bolt on block" in t for t in text)
    valid, rejected = ge.generalized_partitionings(asm, rows, g)
    assert len(valid) == 2 and not rejected
    # both candidates come out by the suggested screw itself (either sense), checked on the
    # rows; the list is complete; the bolt's needs-rotation screw took the LP
    assert sec["candidate_limit"] == ge.DEFAULT_CANDIDATE_LIMIT
    assert sec["candidates_truncated"] is False
    assert {c["motion_source"] for c in sec["candidates"]} == {"suggested"}
    assert {c["motion"]["type"] for c in sec["candidates"]} == {"screw"}
    assert sec["checks"]["lp"] >= 1 and sec["checks"]["witnessed"] >= 2


def test_threaded_infinite_ndbg_keeps_its_blocked_sets():
    """block_threads keeps the infinite NDBG's blocked sets (``NDBG.geometry``; they were
    dropped, so a direction lookup failed and the grasp fell back to the representatives):
    along +z the bolt of bolt-screw.yaml lifts out of its blind hole, unless the declared
    thread blocks it; the lookup then agrees with the regions, and the grasp holds the
    regions' whole extents."""
    from ndbg_cli.ndbg.infinite.build import build_infinite, lookup
    from ndbg_cli.planning.pieces import region_pieces

    asm = ndbg_cli.load(ASSEMBLIES / "bolt-screw.yaml")
    nd = build_infinite(asm)
    bolt, block = asm.index("bolt"), asm.index("block")
    up = np.array([[0.0, 0.0, 1.0]])
    assert not lookup(nd, up)[0].succ[bolt] >> block & 1
    t = ge.block_threads(nd, ge.threaded_pairs(asm))
    assert t.geometry is nd.geometry
    g = lookup(t, up)[0]
    assert g.succ[bolt] >> block & 1 and g.succ[block] >> bolt & 1
    d = np.array([r.direction for r in t.regions if r.dimension == 2])
    assert [x.succ for x in lookup(t, d)] == [r.dbg.succ for r in t.regions if r.dimension == 2]
    assert region_pieces(t) is not None


def test_hybrid_concatenates_families(tmp_path):
    """The paper's hybrid: translational regions (threads blocked) then the suggested ones."""
    asm, hand = bolt(tmp_path, screw=True)
    g = ge.generalized_ndbg(asm, hand)
    t = ge.block_threads(NDBG("infinitesimal_translation", tuple(asm.ids),
                              (Region(0, (0, 0, 1), DBG.from_arcs(2, [(0, 1)])),)),
                         ge.threaded_pairs(asm))
    h = ge.hybrid(t, g)
    assert h.family == "generalized" and len(h.regions) == 1 + len(g.regions)
    assert h.regions[0].direction == (0, 0, 1) and h.regions[1].motion is not None


@pytest.mark.parametrize("screw", [True, False])
def test_unrecognised_facetted_cylinder(tmp_path, screw):
    """The bolt's shank contact given as plain facets (no ``surface``: the contact stage did
    not fit a cylinder): each of the 32 facets contributes the triangle centroids at 1/3 and
    2/3 of its width, with the facet normal. There a turn about z moves a centroid at angle
    t off the facet centre by |w| r sin(t - t_c) along the normal: the facets block every
    turn (the strict polyhedral reading), and the plain bolt still translates out along +z.
    With the declared screw joint the contact is recognised as a surface of revolution about
    the joint's axis (facet normals within 20 degrees of radial there), the points are moved
    onto the facets' centre lines and the screw frees the bolt. The point normals are also
    given reversed (into the block) to check that they are re-oriented to the contact's
    normals."""
    asm, hand = bolt(tmp_path, screw=screw)
    sec = 2 * np.pi / SECTIONS
    r = np.cos(np.pi / SECTIONS)
    pts, nrm = [], []
    for k in range(SECTIONS):
        tc = (k + 0.5) * sec
        for t in (k * sec + sec / 3, k * sec + 2 * sec / 3):
            for z in (0, 10):
                pts.append([np.cos(t) * r / np.cos(t - tc), np.sin(t) * r / np.cos(t - tc), z])
                nrm.append([-np.cos(tc), -np.sin(tc), 0])
    nrm = np.array(nrm)
    facets = C("block", "bolt", "curved", np.unique(np.round(nrm, 12), axis=0), np.array(pts),
               -nrm)
    cs = [facets, hand[1]]
    rows = tw.contact_rows(asm, cs)
    b = bit(asm, "bolt")
    rest = rows_full(asm) & ~b
    G, _ = lp.split_rows(rows, b, rest)
    turn = tw.to_scaled(rows, tw.twist("rotation", (0, 0, 1), (0, 0, 0)))
    m = lp.free_motion_rows(rows, b, rest, threads=ge.threads(asm))
    if screw:
        assert np.abs(G @ turn).max() <= rows.slide_tol
        assert m is not None and m.type == "screw" and m.axis == pytest.approx((0, 0, 1))
    else:
        assert (G @ turn).max() > 0.01 and (G @ -turn).max() > 0.01
        assert m is not None and m.type == "translation" and m.axis == pytest.approx((0, 0, 1))


@pytest.mark.parametrize("factor", [1e-3, 1e3])
def test_answers_do_not_depend_on_the_unit(tmp_path, factor):
    """The Fig. 5 plate and the declared bolt scaled by 1e-3 and 1e3 (as if given in metres
    or micrometres): the same motions, points scaled by the factor, the pitch too; every
    tolerance is relative to the model (``length_tolerance`` and ``L`` scale together)."""
    boxes = {k: tuple(tuple(c * factor for c in v) for v in lohi) for k, lohi in FIG5.items()}
    asm = write(tmp_path / "f", "fig5s", {k: box(*v) for k, v in boxes.items()})
    rows = tw.contact_rows(asm, box_contacts(boxes))
    a = bit(asm, "a")
    m = lp.free_motion(asm, rows, a)
    assert m is not None and m.type == "rotation" and m.axis == pytest.approx((0, 0, 1))
    assert np.array(m.point[:2]) == pytest.approx((5 * factor, 5 * factor), rel=1e-6)
    assert lp.free_motion(asm, rows, a, translation_only=True, allow_sliding=True) is None
    big, hand = bolt(tmp_path / "b", screw=True)
    meshes = {p.id: p.mesh.copy().apply_scale(factor) for p in big.parts}
    joint = dict(BOLT_JOINT, pitch=1.5 * factor)
    asm = write(tmp_path / "s", "bolts", meshes, joints=[joint])
    scaled = [dataclasses.replace(c, points=c.points * factor,
                                  center=None if c.center is None else c.center * factor)
              for c in hand]
    rows = tw.contact_rows(asm, scaled)
    b = bit(asm, "bolt")
    m = lp.free_motion(asm, rows, b)
    assert m is not None and m.type == "screw" and m.pitch == pytest.approx(1.5 * factor)
    g = ge.generalized_ndbg(asm, scaled, rows=rows)
    assert [arcs(asm, r.dbg) for r in g.regions if r.motion["type"] == "screw"] == \
        [{("block", "bolt")}, {("bolt", "block")}]


def test_planar_fig5(tmp_path):
    """The Fig. 5 plate in 2D (dimension 2, polygons, real 2D contacts from
    :func:`ndbg_cli.contacts.contacts2d.find_contacts_2d`): the same pinwheel analysis as in 3D
    without floor and lid: no in-plane translation; the counter-clockwise turn about (5, 5)
    is the only freeing motion (twists stay in the plane: v_z = w_x = w_y = 0)."""
    from ndbg_cli.contacts.contacts2d import find_contacts_2d

    sq = {k: v for k, v in FIG5.items() if k not in ("floor", "lid")}
    parts = [{"id": k, "polygon": [[lo[0], lo[1]], [hi[0], lo[1]], [hi[0], hi[1]],
                                   [lo[0], hi[1]]]} for k, (lo, hi) in sq.items()]
    path = tmp_path / "fig5-2d.yaml"
    path.write_text(yaml.safe_dump({"name": "fig5-2d", "units": "mm", "dimension": 2,
                                    "parts": parts}))
    asm = ndbg_cli.load(path)
    rows = tw.contact_rows(asm, find_contacts_2d(asm))
    assert rows.planar
    a = bit(asm, "a")
    assert lp.free_motion(asm, rows, a, translation_only=True, allow_sliding=True) is None
    m = lp.free_motion(asm, rows, a)
    assert m is not None and m.type == "rotation" and m.axis == pytest.approx((0, 0, 1))
    assert np.array(m.point[:2]) == pytest.approx((5, 5), abs=10 * asm.length_tolerance)
    left = lp.free_motion(asm, rows, bit(asm, "left"))
    assert left is not None and left.type == "translation" and left.axis[0] < 0
    assert abs(left.axis[2]) < 1e-12


# ----------------------------------------------------------------------------- fast paths
def brute_force_candidates(nd: NDBG, nb: list[int], mask: int) -> dict[int, set[int]]:
    """Every proper non-empty subset S of ``mask``, free in some region's DBG inside ``mask``
    and with S and ``mask \\ S`` connected in ``nb``, with the regions where S is free: the
    definition, by exhaustion."""
    from ndbg_cli.ndbg.model import ConnectivityTest

    conn = ConnectivityTest(nb)
    out: dict[int, set[int]] = {}
    members = [i for i in range(nd.n) if mask >> i & 1]
    for k in range(1, 1 << len(members)):
        s = mask_of(members[j] for j in range(len(members)) if k >> j & 1)
        if s == mask or not (conn(s) and conn(mask & ~s)):
            continue
        regs = {r for r, reg in enumerate(nd.regions) if reg.dbg.is_free(s, mask)}
        if regs:
            out[s] = regs
    return out


@pytest.mark.parametrize("seed", range(8))
def test_connected_partitionings_are_the_connected_free_sets(seed):
    """The search of :func:`ge.connected_partitionings` against exhaustion on random DBGs
    (some regions the exact reverse of another, as a motion and its opposite are) over a
    random connected contact graph of 7 parts, for the whole assembly and a subassembly:
    the same sets, each with the same regions, sorted by (size, mask)."""
    rng = np.random.default_rng(seed)
    n = 7
    nb = [0] * n
    for i in range(1, n):  # a random tree plus a few chords: connected
        j = int(rng.integers(i))
        nb[i] |= 1 << j
        nb[j] |= 1 << i
    for _ in range(3):
        i, j = rng.choice(n, 2, replace=False)
        nb[i] |= 1 << int(j)
        nb[j] |= 1 << int(i)
    touching = [(i, j) for i in range(n) for j in range(n) if nb[i] >> j & 1]
    regions = []
    for _ in range(3):
        dbg = DBG.from_arcs(n, [a for a in touching if rng.random() < 0.35])
        regions += [Region(-1, None, dbg), Region(-1, None, dbg.reversed())]
    regions.append(Region(-1, None, DBG.empty(n)))
    nd = NDBG("generalized", tuple(f"p{i}" for i in range(n)), tuple(regions))
    for mask in ((1 << n) - 1, 0b1011011):
        want = brute_force_candidates(nd, nb, mask)
        got, truncated = ge.connected_partitionings(nd, nb, mask, limit=None)
        assert not truncated
        assert {p.moved: set(p.regions) for p in got} == want
        assert all(p.rest == mask & ~p.moved for p in got)
        assert [p.moved for p in got] == sorted(want, key=lambda s: (s.bit_count(), s))


def test_candidate_limit_and_budget_are_reported(tmp_path):
    """A row of 6 parts touching in a chain, with the DBG of pushing along the row (arc
    i -> i+1: part i moving pushes into i+1) and its reverse. The connected splits of a path
    are its prefixes and suffixes, 2 x 5 moving sets, each free in one of the two regions
    (a suffix moves forward, a prefix backward). ``limit`` 3 keeps the free single parts
    (the two ends) first and says the list is cut; a search budget of 1 node cuts too."""
    n = 6
    nb = [0] * n
    for i in range(n - 1):
        nb[i] |= 1 << (i + 1)
        nb[i + 1] |= 1 << i
    fwd = DBG.from_arcs(n, [(i, i + 1) for i in range(n - 1)])
    nd = NDBG("generalized", tuple(f"b{i}" for i in range(n)),
              (Region(-1, None, fwd), Region(-1, None, fwd.reversed())))
    full, _ = ge.connected_partitionings(nd, nb, limit=None)
    assert len(full) == 2 * (n - 1)
    cut, truncated = ge.connected_partitionings(nd, nb, limit=3)
    assert truncated and len(cut) == 3
    assert {1 << 0, 1 << (n - 1)} <= {p.moved for p in cut}
    _, truncated = ge.connected_partitionings(nd, nb, limit=None, budget=1)
    assert truncated


def test_section_reports_a_cut_candidate_list(tmp_path):
    """The declared bolt's section with ``limit=1``: one candidate, ``candidates_truncated``
    and the text says the list is limited."""
    asm, hand = bolt(tmp_path, screw=True)
    rows = tw.contact_rows(asm, hand)
    g = ge.generalized_ndbg(asm, hand, rows=rows)
    sec = ge.generalized_section(asm, g, rows, limit=1)
    assert len(sec["candidates"]) == 1 and sec["candidates_truncated"] is True
    assert sec["candidate_limit"] == 1
    assert any("list limited to 1" in t for t in generalized_text(sec))
    schema = json.loads(resources.files("ndbg_cli").joinpath(
        "schemas/fragments/generalized.json").read_text())
    jsonschema.validate(json.loads(json.dumps(sec)), schema)


#: A unit cube enclosed by six slabs, one on each face (each slab covers the whole face).
CAGE = {
    "cube": ((0, 0, 0), (1, 1, 1)),
    "x0": ((-1, -1, -1), (0, 2, 2)), "x1": ((1, -1, -1), (2, 2, 2)),
    "y0": ((0, -1, -1), (1, 0, 2)), "y1": ((0, 1, -1), (1, 2, 2)),
    "z0": ((0, 0, -1), (1, 1, 0)), "z1": ((0, 0, 1), (1, 1, 2)),
}


def test_locking_certificate_on_hand_cases(tmp_path):
    """The certificate (motion_lp._locked) on configurations analysed by hand:

    * the caged cube: every translation and every twist pushes into a slab (its face
      corners' rows span every direction both ways): both stages are locked;
    * the Fig. 5 plate: no translation frees it (see test_fig5_needs_a_rotation) but the
      counter-clockwise turn does: the translation stage is locked, the general one is not
      (the certificate never claims a lock that a motion breaks);
    * the hinge's pin: radial rows all round both knuckles; it can only slide along x and
      turn about x, breaking nothing: both stages are locked (and the LP's sliding fallback
      then returns the slide along x)."""
    cage = [c for c in box_contacts(CAGE) if "cube" in (c.a, c.b)]
    asm = write(tmp_path / "cage", "cage", {k: box(*v) for k, v in CAGE.items()})
    rows = tw.contact_rows(asm, cage)
    cube = bit(asm, "cube")
    G, _ = lp.split_rows(rows, cube, rows_full(asm) & ~cube)
    assert lp._locked(rows, G, [], False) and lp._locked(rows, G, [], True)
    stats: dict = {}
    assert lp.free_motion_rows(rows, cube, rows_full(asm) & ~cube, allow_sliding=True,
                               stats=stats) is None
    assert stats == {"certified": 1}  # one certificate, no LP

    asm, hand = fig5(tmp_path / "f5")
    rows = tw.contact_rows(asm, hand)
    a = bit(asm, "a")
    G, _ = lp.split_rows(rows, a, rows_full(asm) & ~a)
    assert lp._locked(rows, G, [], False) and not lp._locked(rows, G, [], True)

    asm, hand = hinge(tmp_path / "h")
    rows = tw.contact_rows(asm, hand)
    pin = bit(asm, "pin")
    G, _ = lp.split_rows(rows, pin, rows_full(asm) & ~pin)
    assert lp._locked(rows, G, [], False) and lp._locked(rows, G, [], True)
    m = lp.free_motion_rows(rows, pin, rows_full(asm) & ~pin, allow_sliding=True)
    assert m is not None and m.type == "translation" and m.broken == 0
    assert abs(m.axis[0]) == pytest.approx(1.0)


def test_locking_certificate_never_hides_a_motion(tmp_path, monkeypatch):
    """On every split of random polycube assemblies, each stage the certificate calls locked
    is one where the LP itself (solved anyway) separates no row faster than ``break_tol``;
    and free_motion_rows gives the same verdict with and without certificates."""
    locked = 0
    for seed in range(4):
        locked += _certificate_vs_lp(tmp_path, seed, monkeypatch)
    assert locked > 0


def _certificate_vs_lp(tmp_path: Path, seed: int, monkeypatch) -> int:
    parts = polycubes(seed)
    meshes = {p: boolean("union", *[box(c, np.add(c, 1)) for c in cs]) for p, cs in parts.items()}
    asm = write(tmp_path / str(seed), f"poly{seed}", meshes)
    rows = tw.contact_rows(asm, polycube_contacts(parts))
    full = rows_full(asm)
    locked = 0
    for s in range(1, full):
        G, _ = lp.split_rows(rows, s, full & ~s)
        if not len(G):
            continue
        for rot in (False, True):
            if lp._locked(rows, G, [], rot):
                locked += 1
                x = lp._solve(rows, G, [], rot)
                assert x is None or float((-(G @ x)).max()) <= rows.break_tol, (s, rot)
        fast = lp.free_motion_rows(rows, s, full & ~s, allow_sliding=True)
        with monkeypatch.context() as mp:
            mp.setattr(lp, "_locked", lambda *a, **k: False)
            slow = lp.free_motion_rows(rows, s, full & ~s, allow_sliding=True)
        assert (fast is None) == (slow is None), s
        if fast is not None:
            assert (fast.type, fast.broken > 0) == (slow.type, slow.broken > 0), s
    return locked


@pytest.mark.parametrize("seed", range(3))
def test_locking_certificate_fails_when_a_motion_is_built_in(seed):
    """Rows made to admit a known breaking motion ``u`` (random rows, each flipped so that
    ``g . u <= 0``, and degenerate row sets: rows confined to a subspace, rows repeated)
    are never certified locked in a stage that contains ``u``; the same rows completed by
    their negatives (so every row can neither separate nor push in: ``+-g``) always are,
    whatever the stage."""
    rng = np.random.default_rng(seed)
    rows = math_rows([plane("a", "b", (0, 0, 1), square(0))], ["a", "b"])
    for trial in range(80):
        m = int(rng.integers(3, 80))
        G = rng.normal(size=(m, 6))
        if trial % 4 == 1:  # rows in a 4D subspace (rank-deficient row sets)
            G[:, 4:] = G[:, :2] @ rng.normal(size=(2, 2))
        if trial % 4 == 2:  # repeated rows
            G = np.repeat(G[: max(1, m // 4)], 4, axis=0)
        if trial % 4 == 3:  # many rows in a subspace, a few outside (like a bolt's shank
            G[:, 3:] = 0.0  # and head): the best-aligned rows do not span
            G = np.vstack([G, np.repeat(rng.normal(size=(2, 6)), 3, axis=0)])
        rot = bool(trial % 2)
        u = rng.normal(size=6)
        if not rot:
            u[3:] = 0.0
        u /= np.abs(u).max()
        sign = np.where(G @ u > 0, -1.0, 1.0)
        free = G * sign[:, None]
        if np.all(np.abs(free @ u) <= 1e-3):
            continue
        assert not lp._locked(rows, free, [], rot), trial
        assert lp._locked(rows, np.vstack([free, -free]), [], rot), trial


@pytest.mark.parametrize("seed", range(3))
def test_basis_bounds_hold_against_the_lp(seed):
    """The one-NNLS bounds of the certificate's fast path (``motion_lp._basis_bounds``):
    for random row sets that positively span R^d (locked), each ``A_i`` is at least the
    largest ``|a_i|`` over ``P a <= eps`` found by an LP (sound), and it is finite on
    every such set; on rows confined to a half-space (a motion ``u`` with ``P u <= 0``),
    the bound is infinite or exceeds the LP's, which is unbounded there (``|a| <= sqrt 6``
    caps it)."""
    from scipy.optimize import linprog

    rng = np.random.default_rng(seed)
    eps = 1e-3
    for trial in range(40):
        d = int(rng.integers(1, 7))
        m = int(rng.integers(d + 1, 60))
        P = rng.normal(size=(m, d))
        P = np.vstack([P, -P[: d + 1]])  # +-rows: the set positively spans R^d
        A = lp._basis_bounds(P, eps)
        assert A is not None and np.all(np.isfinite(A)), trial
        for i in range(d):
            for sgn in (1.0, -1.0):
                c = np.zeros(d)
                c[i] = -sgn
                res = linprog(c, A_ub=P, b_ub=np.full(len(P), eps),
                              bounds=[(-np.sqrt(6), np.sqrt(6))] * d, method="highs")
                assert res.status == 0
                assert -res.fun <= A[i] + 1e-12, (trial, i, sgn, -res.fun, A[i])
        u = rng.normal(size=d)
        half = P * np.where(P @ u > 0, -1.0, 1.0)[:, None]  # every row allows u
        B = lp._basis_bounds(half, eps)
        k = int(np.argmax(np.abs(u)))
        assert B is None or not np.all(np.isfinite(B)) or \
            B[k] >= np.sqrt(6) * abs(u[k]) / np.linalg.norm(u) - 1e-9, trial


def test_locking_certificate_on_turned_rows(tmp_path):
    """The plain bolt's rows (it lifts off along +z) and the hinge leaf's (it slides out
    along +x), in 40 random orthonormal frames of the twist space (``G Q``: the motion
    ``Q.T u`` breaks the same contacts): never certified locked. The caged cube's rows (no
    motion at all) in the same frames: always certified."""
    rng = np.random.default_rng(7)
    cases = []
    for build, part in ((lambda f: bolt(f, screw=False), "bolt"), (hinge, "leaf")):
        asm, hand = build(tmp_path / part)
        rows = tw.contact_rows(asm, hand)
        s = bit(asm, part)
        cases.append((rows, lp.split_rows(rows, s, rows_full(asm) & ~s)[0], False))
    asm = write(tmp_path / "cage", "cage", {k: box(*v) for k, v in CAGE.items()})
    rows = tw.contact_rows(asm, [c for c in box_contacts(CAGE) if "cube" in (c.a, c.b)])
    cube = bit(asm, "cube")
    cases.append((rows, lp.split_rows(rows, cube, rows_full(asm) & ~cube)[0], True))
    for rows, G, locked in cases:
        for _ in range(40):
            Q, _ = np.linalg.qr(rng.normal(size=(6, 6)))
            assert lp._locked(rows, G @ Q, [], True) == locked


def test_reversed_motion_is_the_other_side_moving(tmp_path):
    """The Fig. 5 plate turns counter-clockwise (w = +z) about (5, 5) relative to the rest;
    the rest relative to the plate turns the other way about the same line, which the
    rest's rows allow (the same contacts, normals reversed); the clockwise turn of the plate
    itself pushes into the blockers."""
    asm, hand = fig5(tmp_path)
    rows = tw.contact_rows(asm, hand)
    a = bit(asm, "a")
    rest = rows_full(asm) & ~a
    m = lp.free_motion_rows(rows, a, rest)
    r = m.reversed()
    assert r.type == "rotation" and r.axis == pytest.approx((0, 0, -1))
    assert r.point == m.point and r.broken == m.broken and r.pitch == m.pitch
    G_rest, _ = lp.split_rows(rows, rest, a)
    assert (G_rest @ tw.to_scaled(rows, np.asarray(r.twist))).max() <= 1e-9
    G_a, _ = lp.split_rows(rows, a, rest)
    assert (G_a @ tw.to_scaled(rows, np.asarray(r.twist))).max() > 0.01


def test_suggested_motion_witnesses_match_the_lp(tmp_path, monkeypatch):
    """The plain bolt (no thread): the bolt lifts off along +z (head off the block, shank
    sliding in the hole) and the block comes off it along -z; the section reports both with
    the suggested translation along the cylinder's axis, checked on the rows (no LP), and
    nothing needs a rotation. Every candidate verdict equals the plain LP's (certificates
    and witnesses switched off)."""
    asm, hand = bolt(tmp_path, screw=False)
    rows = tw.contact_rows(asm, hand)
    g = ge.generalized_ndbg(asm, hand, rows=rows)
    sec = ge.generalized_section(asm, g, rows)
    got = {tuple(c["moved"]): c for c in sec["candidates"]}
    assert set(got) == {("bolt",), ("block",)}
    for moved, z in ((("bolt",), 1.0), (("block",), -1.0)):
        c = got[moved]
        assert c["motion_source"] == "suggested" and c["motion"]["type"] == "translation"
        assert c["motion"]["axis"] == pytest.approx((0, 0, z), abs=1e-9)
        assert c["motion"]["broken_contacts"] == 4  # the head's four corners
    assert sec["needs_rotation"] == [] and sec["checks"]["lp"] == 0
    with monkeypatch.context() as mp:
        mp.setattr(lp, "_locked", lambda *a, **k: False)
        solver = ge.MotionSolver(rows, ge.threads(asm))
        for c in sec["candidates"]:
            mo = solver(g.mask(c["moved"]), g.mask(c["rest"]))
            assert mo is not None and not (mo.broken == 0 and mo.type == "rotation")


def test_bell_section_matches_the_plain_lp(monkeypatch):
    """On the shipped bell, every verdict of the fast section (candidates valid or rejected,
    subassemblies needing a rotation) equals the plain LP's: each candidate split solved by
    free_motion_rows with the certificates switched off, and needs_rotation redone the same
    way without witnesses."""
    asm, rows, cs = shipped("bell")
    g = ge.generalized_ndbg(asm, cs, rows=rows)
    sec = ge.generalized_section(asm, g, rows)
    assert not sec["candidates_truncated"]
    thr = ge.threads(asm)
    with monkeypatch.context() as mp:
        mp.setattr(lp, "_locked", lambda *a, **k: False)
        for c, ok in [(c, True) for c in sec["candidates"]] + \
                [(c, False) for c in sec["rejected_candidates"]]:
            mo = lp.free_motion_rows(rows, g.mask(c["moved"]), g.mask(c["rest"]), threads=thr,
                                     allow_sliding=True)
            assert (mo is not None and not (mo.broken == 0 and mo.type == "rotation")) == ok
        full = rows_full(asm)
        plain = []
        for i in range(len(asm)):
            s = 1 << i
            mo = lp.free_motion_rows(rows, s, full & ~s, threads=thr, allow_sliding=True)
            if mo is not None and mo.type != "translation" and (
                    mo.type == "screw" if mo.broken == 0 else lp.sliding_motion(
                        rows, s, full & ~s, threads=thr, translation_only=True) is None):
                plain.append(asm.ids[i])
    singles = [e["parts"][0] for e in sec["needs_rotation"] if len(e["parts"]) == 1]
    assert singles == plain

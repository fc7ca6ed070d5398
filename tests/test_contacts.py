"""Contact analysis (issue 3): answers worked out by hand on real meshes.

Conventions checked: normals point out of part A (the lower index) into part B; areas in
unit^2; the default tolerance is 1e-4 x the assembly's bounding-box diagonal.
"""

from __future__ import annotations

import dataclasses
import json
import os
import subprocess
import sys
from pathlib import Path

import fcl
import jsonschema
import manifold3d as m3
import numpy as np
import pytest
import trimesh
from scipy.spatial.transform import Rotation

import ndbg_cli
import ndbg_cli.contacts.contacts3d as contacts_module
from ndbg_cli.contacts.bvh import BoxHierarchy
from ndbg_cli.contacts.contacts3d import _tree_rank, analyze_contacts
from ndbg_cli.contacts.facets import box_pairs, fcl_model, fcl_object, part_geometry, sat_gap
from ndbg_cli.contacts.features import _distinct_points, classify_pairs
from ndbg_cli.contacts.interference import check_interference_policy
from ndbg_cli.core.assembly import Assembly
from ndbg_cli.core.constants import CONTACT_ANGLE_TOL_RAD
from ndbg_cli.core.errors import InterferenceError
from ndbg_cli.geometry.normals import cluster_normals, one_cluster
from ndbg_cli.geometry.vectors import unique_rows
from ndbg_cli.io.validate import make_part
from ndbg_cli.report.contacts import contacts_section, contacts_text

from conftest import ROOT, shared

SCHEMA = Path(__file__).resolve().parents[1] / "ndbg_cli/schemas/fragments/contacts.json"


def assemble(*meshes, units: str = "mm", tolerance: float | None = None) -> Assembly:
    """An assembly of meshes (trimesh or (vertices, faces)) named p0, p1, ..."""
    parts = []
    for k, m in enumerate(meshes):
        v, f = (m.vertices, m.faces) if isinstance(m, trimesh.Trimesh) else m
        parts.append(make_part(f"p{k}", v, f)[0])
    return Assembly("test", tuple(parts), units=units, tolerance=tolerance)


def box(extents, center) -> trimesh.Trimesh:
    b = trimesh.creation.box(extents=extents)
    b.apply_translation(center)
    return b


def manifold_arrays(solid: m3.Manifold) -> tuple[np.ndarray, np.ndarray]:
    mesh = solid.to_mesh64()
    return np.asarray(mesh.vert_properties)[:, :3], np.asarray(mesh.tri_verts)


def shaft_and_block(shaft_radius: float, hole_radius: float = 10.0):
    """A 24-facet shaft (length 60, along z, centred on the origin) through a 64-facet hole in
    a 50 x 50 x 30 block. Both polygons are inscribed in their circles (manifold3d)."""
    shaft = m3.Manifold.cylinder(height=60, radius_low=shaft_radius, radius_high=-1.0,
                                 circular_segments=24).translate((0, 0, -30))
    hole = m3.Manifold.cylinder(height=40, radius_low=hole_radius, radius_high=-1.0,
                                circular_segments=64).translate((0, 0, -20))
    block = m3.Manifold.cube((50, 50, 30)).translate((-25, -25, -15)) - hole
    return manifold_arrays(shaft), manifold_arrays(block)


def moved(arrays, rotation: np.ndarray, translation: np.ndarray, scale: float = 1.0):
    v, f = arrays
    return (scale * v) @ rotation.T + translation, f


def unit_rows(a) -> np.ndarray:
    a = np.asarray(a, dtype=float)
    return a / np.linalg.norm(a, axis=1, keepdims=True)


def same_directions(got: np.ndarray, want, atol: float = 1e-6) -> bool:
    """Whether two sets of unit vectors are equal as sets."""
    want = unit_rows(want)
    if len(got) != len(want):
        return False
    return all(np.min(np.linalg.norm(got - w, axis=1)) < atol for w in want)


# -- planar ---------------------------------------------------------------------------------

def test_boxes_face_to_face_one_planar_contact_exact_area():
    # A: [-2,2] x [-3,3] x [-1,1]; B on top: z in [1,3]. Contact: the 4 x 6 rectangle at z=1.
    asm = assemble(box((4, 6, 2), (0, 0, 0)), box((4, 6, 2), (0, 0, 2)))
    res = analyze_contacts(asm)
    assert res.pairs() == [(0, 1)]
    assert [c.kind for c in res.contacts] == ["planar"]
    c = res.contacts[0]
    assert np.allclose(c.normals, [[0, 0, 1]])  # out of A (below) into B (above)
    assert c.area == pytest.approx(24.0, rel=1e-9)
    assert {tuple(np.round(p, 9)) for p in c.points} == {
        (-2, -3, 1), (2, -3, 1), (2, 3, 1), (-2, 3, 1)}
    assert np.allclose(c.point_normals, [0, 0, 1])
    assert res.interferences == ()


def test_normal_sign_follows_part_order():
    # the same contact with the upper box first: out of the upper box is -z
    asm = assemble(box((4, 6, 2), (0, 0, 2)), box((4, 6, 2), (0, 0, 0)))
    c, = analyze_contacts(asm).contacts
    assert np.allclose(c.normals, [[0, 0, -1]])


def test_boxes_shifted_half_sideways_half_area():
    # B shifted by 2 in x: overlap x in [0,2], y in [-3,3] at z=1: area 12.
    asm = assemble(box((4, 6, 2), (0, 0, 0)), box((4, 6, 2), (2, 0, 2)))
    res = analyze_contacts(asm)
    assert [c.kind for c in res.contacts] == ["planar"]
    c = res.contacts[0]
    assert c.area == pytest.approx(12.0, rel=1e-9)
    pts = {tuple(np.round(p, 9)) for p in c.points}
    assert pts == {(0, -3, 1), (2, -3, 1), (2, 3, 1), (0, 3, 1)}


def test_gap_below_tolerance_touches_above_does_not():
    # gap 0.05 between the boxes; the default tolerance is 1e-4 x diagonal ~ 0.0009
    far = assemble(box((4, 6, 2), (0, 0, 0)), box((4, 6, 2), (0, 0, 2.05)))
    assert analyze_contacts(far).contacts == ()
    near = analyze_contacts(far, tolerance=0.1)
    assert [c.kind for c in near.contacts] == ["planar"]
    assert near.contacts[0].area == pytest.approx(24.0, rel=1e-9)
    # the tolerance may also arrive through the assembly (manifest / --tolerance)
    assert analyze_contacts(far.replace(tolerance=0.1)).pairs() == [(0, 1)]


# -- edge and point ---------------------------------------------------------------------------

def test_box_on_box_along_an_edge():
    # A = [-1,1]^3; B = [1,3] x [-1,1] x [1,3]: they share the segment x=1, z=1, y in [-1,1].
    asm = assemble(box((2, 2, 2), (0, 0, 0)), box((2, 2, 2), (2, 0, 2)))
    res = analyze_contacts(asm)
    assert [c.kind for c in res.contacts] == ["edge"]
    c = res.contacts[0]
    assert c.area == 0.0
    assert {tuple(np.round(p, 9)) for p in c.points} == {(1, -1, 1), (1, 1, 1)}
    # separating normals: the cone between +x and +z; A is blocked iff d.x > 0 and d.z > 0
    assert same_directions(c.normals, [[1, 0, 0], [0, 0, 1]])
    assert c.blocking == "all"


def test_box_on_box_at_a_corner():
    # B = [1,3]^3 touches A = [-1,1]^3 only at (1, 1, 1)
    asm = assemble(box((2, 2, 2), (0, 0, 0)), box((2, 2, 2), (2, 2, 2)))
    res = analyze_contacts(asm)
    assert [c.kind for c in res.contacts] == ["point"]
    c = res.contacts[0]
    assert np.allclose(c.points, [[1, 1, 1]])
    assert same_directions(c.normals, np.eye(3))


def test_separated_boxes_no_contact():
    asm = assemble(box((2, 2, 2), (0, 0, 0)), box((2, 2, 2), (2.5, 0, 0)))
    res = analyze_contacts(asm)
    assert res.contacts == () and res.interferences == ()


# -- curved -----------------------------------------------------------------------------------

AXIS = np.array([1.0, 2.0, 3.0]) / np.sqrt(14.0)


def tilted(arrays):
    """Rotate so that +z goes to AXIS and translate by (5, -7, 11)."""
    rot = Rotation.align_vectors([AXIS], [[0, 0, 1]])[0].as_matrix()
    return moved(arrays, rot, np.array([5.0, -7.0, 11.0]))


def test_shaft_24_in_hole_64_one_curved_contact_axis_and_radius():
    shaft, block = shaft_and_block(10.0)
    asm = assemble(tilted(shaft), tilted(block))
    res = analyze_contacts(asm)
    assert res.interferences == ()  # the 24-gon's edges cross the 64-gon's chords by < sag
    assert len(res.contacts) == 1
    c = res.contacts[0]
    assert (c.kind, c.surface) == ("curved", "cylinder")
    angle = np.degrees(np.arccos(min(1.0, abs(float(c.axis @ AXIS)))))
    assert angle < 0.5
    assert c.radius == pytest.approx(10.0, rel=0.01)
    # the centre lies on the true axis through (5, -7, 11)
    rel = c.center - np.array([5.0, -7.0, 11.0])
    assert np.linalg.norm(rel - (rel @ AXIS) * AXIS) < 0.1
    # normals: out of the shaft, all perpendicular to the axis, all around the circle
    assert np.allclose(c.normals @ AXIS, 0.0, atol=1e-6)
    assert len(c.normals) >= 24
    assert np.allclose(np.linalg.norm(c.normals, axis=1), 1.0)
    # every radial direction is blocked: d.n > 0 for some n
    u = np.cross(AXIS, [1.0, 0, 0])
    u /= np.linalg.norm(u)
    w = np.cross(AXIS, u)
    for t in np.linspace(0, 2 * np.pi, 37):
        assert (c.normals @ (np.cos(t) * u + np.sin(t) * w)).max() > 0.9
    # sliding along the axis and turning about it are free
    assert np.abs(c.normals @ AXIS).max() < 1e-6
    assert c.points.shape == c.point_normals.shape


def test_press_fit_is_an_interference_with_hand_computed_volume():
    # shaft 1% oversize: its 24-gon (apothem 10.1 cos 7.5 deg = 10.0135) contains the
    # 64-gon hole (radius 10), so the overlap is the difference of the polygons' areas
    # (N/2 r^2 sin(2 pi/N)) times the block's thickness 30.
    shaft, block = shaft_and_block(10.1)
    asm = assemble(shaft, block)
    res = analyze_contacts(asm)
    inter, = res.interferences
    want = 30.0 * (12 * 10.1**2 * np.sin(np.pi / 12) - 32 * 10.0**2 * np.sin(np.pi / 32))
    assert (inter.a, inter.b, inter.method) == (0, 1, "volume")
    assert inter.volume == pytest.approx(want, rel=1e-6)
    assert 0.0135 < inter.depth < 0.1  # between the thinnest and thickest overlap
    # a press fit about the shaft's axis (z): planned as a cylindrical contact, the one
    # contact of the pair (radial normals only: the axis alone is free)
    assert inter.kind == "press_fit" and inter.fit.axis == pytest.approx((0, 0, 1))
    assert 9.95 < inter.fit.radius < 10.1  # the facets' mean distance from the axis
    contact, = res.contacts
    assert contact.surface == "cylinder" and np.allclose(contact.normals[:, 2], 0.0)
    # a press fit is no error under any policy; a clash is (see test_fits)
    for policy in ("error", "warn", "ignore"):
        assert check_interference_policy(asm, res, policy) == []
    with pytest.raises(ValueError):
        check_interference_policy(asm, res, "sometimes")


def test_a_deep_overlap_is_a_clash_and_an_error_under_the_error_policy():
    # shaft 20% oversize: a 2 mm radial interference (over 5% of the radius): a clash
    shaft, block = shaft_and_block(12.0)
    asm = assemble(shaft, block)
    res = analyze_contacts(asm)
    inter, = res.interferences
    assert inter.kind == "clash" and res.contacts == ()
    with pytest.raises(InterferenceError) as err:
        check_interference_policy(asm, res, "error")
    assert err.value.exit_code == 2 and "p0" in str(err.value)
    warn, = check_interference_policy(asm, res, "warn")
    assert (warn.level, warn.code) == ("warning", "interference")
    assert "kept together as one unit" in warn.message
    assert check_interference_policy(asm, res, "ignore") == []


def _clash_and_stack() -> Assembly:
    """p0 and p1 clash (a 5 mm deep overlap of 10 mm blocks); p2 rests on both tops, p4 on
    p3's, far from them."""
    return assemble(box((10, 10, 10), (5, 5, 5)), box((10, 10, 10), (10, 5, 5)),
                    box((10, 10, 4), (10, 5, 12)), box((10, 10, 10), (40, 5, 5)),
                    box((10, 10, 4), (40, 5, 12)))


@pytest.mark.parametrize("workers", [1, 2])
def test_units_later_leaves_out_the_contacts_of_clashing_parts_only(monkeypatch, workers):
    # p0 and p1 clash (a 5 mm deep overlap of 10 mm blocks); p2 rests on both tops, p4 on
    # p3's, far from them. With units_later the contacts of p0, p1 (with p2) are not sought
    # (the pipeline finds the unit's again); p3-p4's face contact is the full analysis's,
    # and the clash is listed as before. Two workers take the forked path, where those may
    # be dropped before they start.
    monkeypatch.setattr(contacts_module, "MIN_PARALLEL_TRIANGLES", 0)
    asm = _clash_and_stack()
    full = analyze_contacts(asm, workers=workers)
    later = analyze_contacts(asm, workers=workers, units_later=True)

    def brief(cs):
        return [(c.a, c.b, c.kind, np.round(c.normals, 9).tolist()) for c in cs]
    assert [(x.a, x.b, x.kind) for x in full.interferences] == [(0, 1, "clash")]
    assert [(x.a, x.b, x.kind, x.volume) for x in later.interferences] == \
        [(x.a, x.b, x.kind, x.volume) for x in full.interferences]
    assert {(c.a, c.b) for c in full.contacts} == {(0, 2), (1, 2), (3, 4)}
    assert brief(later.contacts) == brief(c for c in full.contacts if (c.a, c.b) == (3, 4))


def test_units_later_never_seeks_the_surface_contacts_of_a_clashing_part(monkeypatch):
    """The crossing pairs' interference tests come first, their surface contacts later:
    once the tests tell that p0 and p1 clash, the surface contacts of their pairs (with each
    other: it interferes; with p2, resting on both: a clashing part's) are not sought at all,
    only p3-p4's (its test finds no interference). Without units_later every crossing pair
    not interfering gets them. In this process (one worker) the items run in their order."""
    from ndbg_cli.contacts._pair_work import INTERFERENCE, SURFACE, WHOLE

    asm = _clash_and_stack()
    sought, items = [], []
    geo = {id(part_geometry(p, asm.length_tolerance, CONTACT_ANGLE_TOL_RAD)): k
           for k, p in enumerate(asm.parts)}
    real_facets, real_phase = contacts_module.coplanar_facets, contacts_module._narrow_phase
    monkeypatch.setattr(contacts_module, "coplanar_facets", lambda ga, gb, *rest: sought.append(
        (geo[id(ga)], geo[id(gb)])) or real_facets(ga, gb, *rest))
    monkeypatch.setattr(contacts_module, "_narrow_phase", lambda context, item: items.append(
        item) or real_phase(context, item))
    later = analyze_contacts(asm, units_later=True)
    assert [(x.a, x.b, x.kind) for x in later.interferences] == [(0, 1, "clash")]
    assert sought == [(3, 4)]
    # every crossing pair's test first, then its surface contacts where still wanted
    assert [(a, b, part) for a, b, _, part in items] == [
        (0, 1, INTERFERENCE), (0, 2, INTERFERENCE), (1, 2, INTERFERENCE),
        (3, 4, INTERFERENCE), (3, 4, SURFACE)]
    sought.clear(), items.clear()
    analyze_contacts(asm)
    assert sorted(sought) == [(0, 2), (1, 2), (3, 4)]
    assert {part for *_, part in items} == {WHOLE}


def test_a_units_later_run_leaves_no_partial_result_for_a_whole_analysis():
    """The cache a units_later analysis fills holds, for the pairs of clashing parts, their
    interference tests alone, apart from whole results: a whole analysis of the same parts
    on that cache then finds the contacts of those pairs (p2 on p0 and p1) as one without a
    cache does, and a second units_later analysis computes nothing and counts no miss."""
    from ndbg_cli.core.cache import MemoryCache

    asm = _clash_and_stack()
    memo = MemoryCache()
    first = analyze_contacts(asm, units_later=True, cache=memo)
    assert {(c.a, c.b) for c in first.contacts} == {(3, 4)}
    assert memo.stats()["contacts"] == {"hits": 0, "misses": 4}  # the 4 candidate pairs
    again = analyze_contacts(asm, units_later=True, cache=memo)
    assert again.contacts == first.contacts and again.interferences == first.interferences
    assert memo.stats()["contacts"] == {"hits": 4, "misses": 4}
    whole, plain = analyze_contacts(asm, cache=memo), analyze_contacts(asm)
    assert {(c.a, c.b) for c in plain.contacts} == {(0, 2), (1, 2), (3, 4)}
    assert [(c.a, c.b, c.kind, c.normals.tolist(), c.points.tolist()) for c in whole.contacts] \
        == [(c.a, c.b, c.kind, c.normals.tolist(), c.points.tolist()) for c in plain.contacts]
    assert whole.stats["triangle_pairs"] == plain.stats["triangle_pairs"]


def test_units_later_with_a_clash_known_before_any_pair_is_tested():
    # p1 lies wholly inside p0 (no surfaces cross: a nested clash, found before the pairs);
    # p2 rests on p0's top: its pair is left out from the start, p3-p4 away are kept
    asm = assemble(box((10, 10, 10), (5, 5, 5)), box((2, 2, 2), (5, 5, 5)),
                   box((10, 10, 2), (5, 5, 11)), box((10, 10, 10), (40, 5, 5)),
                   box((10, 10, 2), (40, 5, 11)))
    full = analyze_contacts(asm)
    later = analyze_contacts(asm, units_later=True)
    assert [(x.a, x.b, x.kind) for x in full.interferences] == [(0, 1, "clash")]
    assert [(x.a, x.b, x.kind) for x in later.interferences] == [(0, 1, "clash")]
    assert {(c.a, c.b) for c in full.contacts} == {(0, 2), (3, 4)}
    assert {(c.a, c.b) for c in later.contacts} == {(3, 4)}


def test_conical_plug_in_conical_seat():
    # frustum r 10 -> 5 over z in [0, 10] (24 facets) in a 64-facet seat: a cone about +z;
    # the slope 5 in 10 gives outward normals with n.z = 5 / sqrt(10^2 + 5^2) = 1/sqrt(5);
    # the centre is put at mid-height z = 5 where the radius is (10 + 5) / 2 = 7.5
    plug = m3.Manifold.cylinder(height=10, radius_low=10, radius_high=5, circular_segments=24)
    seat = m3.Manifold.cylinder(height=10, radius_low=10, radius_high=5, circular_segments=64)
    block = m3.Manifold.cube((40, 40, 10)).translate((-20, -20, 0)) - seat
    res = analyze_contacts(assemble(manifold_arrays(plug), manifold_arrays(block)))
    assert res.interferences == ()
    c, = res.contacts
    assert (c.kind, c.surface) == ("curved", "cone")
    assert abs(abs(c.axis[2]) - 1.0) < 1e-6
    assert np.allclose(c.center, [0, 0, 5], atol=0.05)
    assert c.radius == pytest.approx(7.5, rel=0.01)
    assert np.allclose(c.normals[:, 2], 1 / np.sqrt(5), atol=0.01)


def test_ball_in_spherical_socket():
    # ball r=5 centred at (0, 0, 10), its lower half in a 64-segment socket cut in a block
    # whose top face is z = 10
    ball = m3.Manifold.sphere(5, circular_segments=32).translate((0, 0, 10))
    socket = m3.Manifold.sphere(5, circular_segments=64).translate((0, 0, 10))
    block = m3.Manifold.cube((20, 20, 10)).translate((-10, -10, 0)) - socket
    res = analyze_contacts(assemble(manifold_arrays(ball), manifold_arrays(block)))
    assert res.interferences == ()
    c, = res.contacts
    assert (c.kind, c.surface) == ("curved", "sphere")
    assert np.allclose(c.center, [0, 0, 10], atol=0.05)
    assert c.radius == pytest.approx(5.0, rel=0.01)
    assert (c.normals[:, 2] <= 0.05).all()  # the ball presses down and sideways only
    assert c.normals[:, 2].min() < -0.99  # straight down is blocked


def test_the_slab_pretest_skips_only_pairs_that_cannot_interfere():
    """``thin_slab`` (which spares the overlap boolean) against answers by hand, with the
    allowance 0.01. A cube on a slab (top face = bottom face): the planes z = 0 separate
    them, width 0. The same cube sunk 0.5 into the slab, side faces flush (no triangle of
    one crosses the other's): width 0.5 along z and more along x and y, so the boolean runs
    and finds the overlap 1 x 1 x 0.5 (mean thickness 2V/S = 1 / (2 + 4 x 0.5) = 0.25). The cube
    sunk 0.005: width 0.005 <= 0.01, skipped, and the boolean agrees (2V/S < 0.01). A peg
    in a hole: no slab along any direction (the hole's walls lie on all sides)."""
    from ndbg_cli.contacts.interference import interference
    from ndbg_cli.contacts.overlap_bounds import thin_slab

    slab = box((3, 3, 1), (0, 0, -0.5))

    def pair(sink):
        asm = assemble(slab, box((1, 1, 1), (0, 0, 0.5 - sink)))
        ga, gb = (part_geometry(p, 1e-4, CONTACT_ANGLE_TOL_RAD) for p in asm.parts)
        return asm, ga, gb

    asm, ga, gb = pair(0.0)
    assert thin_slab(ga, gb, 0.01) and thin_slab(gb, ga, 0.0)
    asm, ga, gb = pair(0.5)
    assert not thin_slab(ga, gb, 0.01) and not thin_slab(ga, gb, 0.49)
    found, _ = interference(0, 1, *asm.parts, ga, gb, 0.01, 1e-4)
    assert found.volume == pytest.approx(0.5) and found.depth == pytest.approx(0.25)
    asm, ga, gb = pair(0.005)
    assert thin_slab(ga, gb, 0.01) and not thin_slab(ga, gb, 0.004)
    found, _ = interference(0, 1, *asm.parts, ga, gb, 0.01, 1e-4)
    assert found is None
    shaft, block = shaft_and_block(10.0)
    asm = assemble(shaft, block)
    ga, gb = (part_geometry(p, 1e-4, CONTACT_ANGLE_TOL_RAD) for p in asm.parts)
    assert not thin_slab(ga, gb, 1.0)


def test_part_wholly_inside_another_is_an_interference():
    # a 2 x 2 x 2 box inside a 10 x 10 x 10 box: the surfaces never meet, the overlap is the
    # small box, volume 8, mean thickness 2V/S = 16/24
    res = analyze_contacts(assemble(box((10, 10, 10), (0, 0, 0)), box((2, 2, 2), (1, 1, 1))))
    assert res.contacts == ()
    inter, = res.interferences
    assert inter.volume == pytest.approx(8.0, rel=1e-9)
    assert inter.depth == pytest.approx(16 / 24, rel=1e-9)


def open_box(center):
    """A 2 x 2 x 2 box without its top face: not watertight, so no manifold."""
    b = box((2, 2, 2), center)
    keep = ~np.isclose(b.triangles_center[:, 2], center[2] + 1)
    return b.vertices, b.faces[keep]


def test_open_meshes_use_the_approximate_interference_test():
    # A = [-1,1]^3 and B = [0,2] x [-0.5,1.5] x [-0.75,1.25] (both open at the top) overlap in
    # [0,1] x [-0.5,1] x [-0.75,1]: A's faces cross B's. The estimate is the reach of a
    # triangle's vertices behind the other's plane: at least the true depth 1 along x (the
    # crossing of A's face x=1 with B's faces) and at most the box size 2.
    asm = assemble(open_box((0, 0, 0)), open_box((1, 0.5, 0.25)))
    assert not any(p.check.watertight for p in asm.parts)
    res = analyze_contacts(asm)
    inter, = res.interferences
    assert (inter.method, inter.volume) == ("fcl-depth", 0.0)
    assert 1.0 - 1e-9 <= inter.depth <= 2.0 + 1e-9
    assert res.stats["interference_approximate_pairs"] == [["p0", "p1"]]
    assert res.contacts == ()


def test_open_meshes_touching_are_not_an_interference():
    # open boxes face to face (B on A's side x=1): touching, not crossing
    asm = assemble(open_box((0, 0, 0)), open_box((2, 0, 0)))
    res = analyze_contacts(asm)
    assert res.interferences == ()
    c, = res.contacts
    assert (c.kind, c.area) == ("planar", pytest.approx(4.0, rel=1e-9))
    assert np.allclose(c.normals, [[1, 0, 0]])


def test_cylinder_lying_on_a_plate_is_a_line_contact():
    # a 32-facet cylinder, radius 1, length 6 along x, one of its edges (y=0) on the plate's
    # top z=0: a line contact from (-3,0,0) to (3,0,0) whose only normal is the plate's +z
    # (the facet normals next to the line, tilted by 360/32/2 degrees, are artefacts)
    cyl = trimesh.creation.cylinder(radius=1, height=6, sections=32)
    cyl.apply_transform(trimesh.transformations.rotation_matrix(np.pi / 2, [0, 1, 0]))
    cyl.apply_translation((0, 0, 1))
    plate = box((10, 10, 1), (0, 0, -0.5))
    res = analyze_contacts(assemble(plate, cyl))
    c, = res.contacts
    assert c.kind == "edge" and c.area == 0.0
    assert np.allclose(c.normals, [[0, 0, 1]])
    assert np.allclose(sorted(c.points.tolist()), [[-3, 0, 0], [3, 0, 0]], atol=1e-9)


def test_ball_on_a_plate_is_a_point_contact():
    # a UV sphere (radius 1) with its pole on the plate's top z=0
    ball = trimesh.creation.uv_sphere(radius=1, count=[16, 16])
    ball.apply_translation((0, 0, 1))
    plate = box((10, 10, 1), (0, 0, -0.5))
    res = analyze_contacts(assemble(plate, ball))
    c, = res.contacts
    assert c.kind == "point"
    assert np.allclose(c.points, [[0, 0, 0]], atol=1e-9)
    assert np.allclose(c.normals, [[0, 0, 1]])


# -- invariance -------------------------------------------------------------------------------

def mixed_assembly(rot=None, shift=None, scale=1.0, units="mm"):
    """Shaft in block, a box on the block, a box touching that box along an edge."""
    rot = np.eye(3) if rot is None else rot
    shift = np.zeros(3) if shift is None else shift
    shaft, block = shaft_and_block(10.0)
    # `top`: x in [-10,10], y in [12,32], z in [15,25], on the block's top face z=15 (overhanging
    # beyond y=25, clear of the shaft, which reaches y=10); `edge`: x in [10,20], z in [25,35],
    # same y: it shares the segment x=10, z=25, y in [12,32] with `top`
    top = box((20, 20, 10), (0, 22, 20))
    edge = box((10, 20, 10), (15, 22, 30))
    items = [shaft, block, (top.vertices, top.faces), (edge.vertices, edge.faces)]
    return assemble(*(moved(m, rot, shift, scale) for m in items), units=units)


def summary(res) -> list[tuple[int, int, str]]:
    return [(c.a, c.b, c.kind) for c in res.contacts]


def test_mixed_assembly_by_hand():
    res = analyze_contacts(mixed_assembly())
    assert summary(res) == [(0, 1, "curved"), (1, 2, "planar"), (2, 3, "edge")]
    planar = res.contacts[1]
    assert planar.area == pytest.approx(20 * 13, rel=1e-9)  # x in [-10,10], y in [12,25]
    assert np.allclose(planar.normals, [[0, 0, 1]])
    edge = res.contacts[2]
    assert same_directions(edge.normals, [[1, 0, 0], [0, 0, 1]])
    assert {tuple(np.round(p, 9)) for p in edge.points} == {(10, 12, 25), (10, 32, 25)}


def test_invariant_under_rigid_motion_and_units():
    base = analyze_contacts(mixed_assembly())
    rng = np.random.default_rng(7)
    rot = Rotation.random(random_state=rng).as_matrix()
    shift = rng.uniform(-500, 500, 3)
    moved_res = analyze_contacts(mixed_assembly(rot, shift))
    assert summary(moved_res) == summary(base)
    for c in base.contacts:
        twin = next(d for d in moved_res.contacts if (d.a, d.b, d.kind) == (c.a, c.b, c.kind))
        assert same_directions(twin.normals, c.normals @ rot.T, atol=1e-6)
        assert twin.area == pytest.approx(c.area, rel=1e-6)
    metres = analyze_contacts(mixed_assembly(scale=1e-3, units="m"))
    assert summary(metres) == summary(base)
    assert metres.tolerance == pytest.approx(base.tolerance * 1e-3, rel=1e-9)
    assert metres.contacts[1].area == pytest.approx(base.contacts[1].area * 1e-6, rel=1e-9)


# -- API and report ---------------------------------------------------------------------------

def test_report_sections_json_and_schema():
    asm = mixed_assembly()
    res = analyze_contacts(asm)
    sec = contacts_section(asm, res)
    again = contacts_section(asm, analyze_contacts(asm))
    for x in (sec, again):
        x["contact_stats"].pop("timings_s")
    assert json.dumps(sec, sort_keys=True) == json.dumps(again, sort_keys=True)
    sec = contacts_section(asm, res)
    schema = json.loads(SCHEMA.read_text())
    for key in ("contacts", "interferences", "contact_stats"):
        jsonschema.validate(sec[key], schema[key])
    assert [(c["a"], c["b"], c["kind"]) for c in sec["contacts"]] == [
        ("p0", "p1", "curved"), ("p1", "p2", "planar"), ("p2", "p3", "edge")]
    assert sec["contact_stats"]["touching_pairs"] == [["p0", "p1"], ["p1", "p2"], ["p2", "p3"]]
    lines = contacts_text(asm, res)
    assert any("cylinder" in x and "p0" in x for x in lines)
    assert lines[-1].startswith("3 touching pairs, 3 contacts, 0 interferences")
    assert res.normals_by_pair()[(1, 2)].shape == (1, 3)
    assert set(res.stats) >= {"bvh_s", "broad_s", "narrow_s"}


def test_bvh_model_is_built_once_per_part():
    asm = assemble(box((2, 2, 2), (0, 0, 0)))
    part = asm.parts[0]
    assert fcl_model(part) is fcl_model(part)
    assert CONTACT_ANGLE_TOL_RAD == pytest.approx(np.radians(1.0))


# -- external data ----------------------------------------------------------------------------

def family(pid: str) -> str:
    return pid.split("_")[0]


@pytest.mark.external
def test_as1_32_touching_pairs_and_no_interference():
    asm = ndbg_cli.load(shared("as1", "as1-oc-214.stp"))
    res = analyze_contacts(asm)
    assert res.interferences == ()
    pairs = [tuple(sorted((asm.ids[a], asm.ids[b]))) for a, b in res.pairs()]
    assert len(pairs) == 32
    counts: dict[tuple[str, str], int] = {}
    for a, b in pairs:
        key = tuple(sorted((family(a), family(b))))
        counts[key] = counts.get(key, 0) + 1
    assert counts == {("bolt", "l-bracket"): 6, ("bolt", "nut"): 6, ("bolt", "plate"): 6,
                      ("nut", "plate"): 6, ("l-bracket", "plate"): 2, ("l-bracket", "rod"): 2,
                      ("nut", "rod"): 2, ("l-bracket", "nut"): 2}
    rod_nuts = sorted(a if b == "rod_1" else b for a, b in pairs if "rod_1" in (a, b)
                      and "nut" in a + b)
    assert rod_nuts == ["nut_1", "nut_2"]
    bracket_nuts = {b for a, b in pairs if a.startswith("l-bracket") and b.startswith("nut")}
    assert bracket_nuts == {"nut_1", "nut_2"}  # the rod nuts clamp the brackets


@pytest.mark.external
def test_as1_in_metres_gives_the_same_pairs():
    asm = ndbg_cli.load(shared("as1", "as1-oc-214.stp"))
    parts = tuple(make_part(p.id, p.mesh.vertices * 1e-3, p.mesh.faces)[0] for p in asm.parts)
    metres = Assembly("as1-m", parts, units="m")
    assert analyze_contacts(metres).pairs() == analyze_contacts(asm).pairs()


@pytest.mark.external
def test_as1_under_a_random_rigid_motion():
    asm = ndbg_cli.load(shared("as1", "as1-oc-214.stp"))
    rng = np.random.default_rng(3)
    rot = Rotation.random(random_state=rng).as_matrix()
    shift = rng.uniform(-1000, 1000, 3)
    parts = tuple(make_part(p.id, p.mesh.vertices @ rot.T + shift, p.mesh.faces)[0]
                  for p in asm.parts)
    base = analyze_contacts(asm)
    moved_res = analyze_contacts(Assembly("as1-moved", parts))
    assert moved_res.pairs() == base.pairs()
    for pair, normals in base.normals_by_pair().items():
        got = moved_res.normals_by_pair()[pair]
        # every rotated normal has a twin within the angular tolerance
        dots = (normals @ rot.T) @ got.T
        assert dots.max(axis=1).min() > np.cos(2 * CONTACT_ANGLE_TOL_RAD)


@pytest.mark.external
def test_beam_four_contacts_no_interference():
    asm = ndbg_cli.load(shared("beam", "assembled"))
    res = analyze_contacts(asm)
    assert res.interferences == ()
    assert [(asm.ids[a], asm.ids[b]) for a, b in res.pairs()] == [
        ("0", "2"), ("1", "3"), ("2", "6"), ("3", "6")]


@pytest.mark.external
def test_engine_glb_completes_with_warnings():
    asm = ndbg_cli.load(shared("engine", "2CylinderEngine.glb"))
    res = analyze_contacts(asm)
    assert res.pairs()
    assert res.stats["interference_approximate_pairs"]  # open meshes: the fallback was used
    warnings = check_interference_policy(asm, res, "warn")
    assert warnings and all(w.code == "interference" for w in warnings)
    json.dumps(contacts_section(asm, res))


# -- the fast paths compute exactly what the straightforward code does ------------------------

def normal_sets(rng):
    """Random normal sets: scattered, jittered around a few directions, both sides of
    tessellated cylinders, chains at about the angle apart, axis-aligned with -0.0."""
    for trial in range(600):
        k = int(rng.integers(1, 120))
        ang = float(rng.choice([np.radians(1), np.radians(5), 0.3, 1.2]))
        kind = trial % 5
        if kind == 0:
            n = rng.normal(size=(k, 3))
        elif kind == 1:
            base = unit_rows(rng.normal(size=(int(rng.integers(1, 6)), 3)))
            n = base[rng.integers(0, len(base), k)] + rng.normal(size=(k, 3)) * ang
        elif kind == 2:
            t = 2 * np.pi * np.arange(int(rng.integers(8, 96))) / 96
            n = np.stack([np.cos(t), np.sin(t), 0 * t], 1)
            n = np.concatenate([n, -n + rng.normal(size=n.shape) * 1e-4])
        elif kind == 3:  # neighbours exactly or almost exactly the angle apart
            t = np.arange(k) * ang * rng.choice([1.0, 0.5, 1 - 1e-15, 1 + 1e-15])
            n = np.stack([np.cos(t), np.sin(t), 0 * t], 1)
            n = n @ np.linalg.qr(rng.normal(size=(3, 3)))[0].T
        else:
            n = np.eye(3)[rng.integers(0, 3, k)] * rng.choice([-1.0, 1.0], size=(k, 1))
            n = n + rng.choice([0.0, 1e-12, -1e-12], size=(k, 3))
        n = unit_rows(n)
        w = None if trial % 2 else rng.choice([0.0, 0.5, 2.0], size=len(n))
        yield n, ang, w


def _same_rows(a, b, atol):
    """Whether ``a`` and ``b`` hold the same rows up to ``atol``, in any order."""
    if a.shape != b.shape:
        return False
    d = np.linalg.norm(a[:, None, :] - b[None, :, :], axis=2)
    return bool((d.min(axis=1) <= atol).all() and (d.min(axis=0) <= atol).all())


def _borderline(n, ang):
    """Whether two normals lie within 1e-7 rad of the tolerance apart (rounding may then
    group them either way)."""
    d = np.arccos(np.clip(n @ n.T, -1, 1))
    return bool((np.abs(d - ang) < 1e-7).any())


def _closed_ring(n, ang):
    """Whether the normals go all round a great circle with no gap of ``ang``: a ring with
    no first member (where the pieces start then follows the frame; documented in
    ``directions._ring_coords``)."""
    m = np.linalg.svd(n)[2][-1]
    if np.abs(n @ m).max() > 1e-3:
        return False
    e1 = np.cross(m, [1.0, 0, 0] if abs(m[0]) < 0.9 else [0, 1.0, 0])
    e1 /= np.linalg.norm(e1)
    s = np.sort(np.mod(np.arctan2(n @ np.cross(m, e1), n @ e1), 2 * np.pi))
    return bool(np.diff(np.r_[s, s[0] + 2 * np.pi]).max() < ang)


def test_cluster_normals_follow_the_set_not_its_order_frame_or_sign():
    """Permuting the rows changes nothing; turning or negating the normals turns or negates
    the clusters (issue 34: a pair's normals flip when the parts are permuted), except
    where the normals are borderline or a closed ring. Unweighted, every normal lies within
    the tolerance of a cluster."""
    rng = np.random.default_rng(11)
    turned = 0
    for n, ang, w in normal_sets(rng):
        got = cluster_normals(n, ang, w)
        perm = rng.permutation(len(n))
        again = cluster_normals(n[perm], ang, None if w is None else w[perm])
        assert np.array_equal(again, got)
        neg = cluster_normals(-n, ang, w)
        assert _same_rows(-neg, got, 1e-9)
        if not (_borderline(n, ang) or _closed_ring(n, ang)):
            rot = Rotation.random(random_state=int(rng.integers(1 << 30))).as_matrix()
            moved = cluster_normals(n @ rot.T, ang, w)
            assert _same_rows(moved @ rot, got, 1e-7)
            turned += 1
        # each piece lies within ang of its plain mean, so its weighted mean (in the same
        # cap) within 2 ang of every member; and within ang of it when no weights (nor
        # repeated rows, which count as weights) pull it
        live = unit_rows(n[np.linalg.norm(n, axis=1) > 0.5])
        if len(live):
            near = (live @ got.T).max(axis=1)
            assert (near >= np.cos(min(2 * ang, np.pi)) - 1e-9).all()
            if w is None and len(unique_rows(np.round(n, 9))[0]) == len(n):
                assert (near >= np.cos(ang) - 1e-9).all()
    assert turned > 300


def test_cluster_normals_by_construction():
    one = np.radians(1.0)
    z = np.array([0.0, 0.0, 1.0])
    # one face's triangles (rounding noise): one normal
    face = unit_rows(z + np.random.default_rng(2).normal(size=(50, 3)) * 1e-10)
    assert np.allclose(cluster_normals(face, one), [z]) and one_cluster(face, one)
    # two faces 3 degrees apart stay two
    t = np.radians([0.0, 3.0])
    two = np.c_[np.sin(t), 0 * t, np.cos(t)]
    assert _same_rows(cluster_normals(two, one), two, 1e-8) and not one_cluster(two, one)
    # a chain 0.5 degree apart over 5 degrees (a fine cylinder): not one meaningless mean,
    # nor one normal per facet; each facet within the degree of a normal
    t = np.radians(np.arange(11) * 0.5)
    chain = np.c_[np.sin(t), 0 * t, np.cos(t)]
    got = cluster_normals(chain, one)
    assert 3 <= len(got) < 11
    assert ((chain @ got.T).max(axis=1) >= np.cos(one) - 1e-12).all()
    # weights pull the mean: two normals 0.4 degree apart, the heavier one dominates
    t = np.radians([0.0, 0.4])
    pair = np.c_[np.sin(t), 0 * t, np.cos(t)]
    m = cluster_normals(pair, one, np.array([3.0, 1.0]))[0]
    assert np.isclose(np.degrees(np.arctan2(m[0], m[2])), 0.1, atol=1e-3)


def test_unique_rows_equals_numpy_unique():
    rng = np.random.default_rng(5)
    for _ in range(50):
        x = np.round(rng.normal(size=(int(rng.integers(1, 300)), 3)), 1)
        x[rng.random(x.shape) < 0.2] = rng.choice([0.0, -0.0])
        _, first, inv = np.unique(x, axis=0, return_index=True, return_inverse=True)
        got_first, got_inv = unique_rows(x)
        assert np.array_equal(got_first, first) and np.array_equal(got_inv, inv.ravel())
        groups = [np.sort(rng.choice(len(x), size=int(rng.integers(1, len(x) + 1)),
                                     replace=False)) for _ in range(3)]
        for got, g in zip(_distinct_points(x, groups), groups):
            want = np.unique(x[g], axis=0)
            assert np.array_equal(got, want) and np.array_equal(np.signbit(got),
                                                                np.signbit(want))


def test_box_pairs_equals_brute_force():
    rng = np.random.default_rng(2)
    for _ in range(30):
        m, n = int(rng.integers(0, 60)), int(rng.integers(0, 300))
        qlo = np.round(rng.uniform(0, 10, (m, 3)), 1)  # coarse grid: boxes that just touch
        qhi = qlo + np.round(rng.uniform(0, 2, (m, 3)), 1)
        tlo = np.round(rng.uniform(0, 10, (n, 3)), 1)
        thi = tlo + np.round(rng.uniform(0, 2, (n, 3)), 1)
        hit = np.all((qlo[:, None] <= thi[None]) & (qhi[:, None] >= tlo[None]), axis=2)
        want_q, want_t = np.nonzero(hit)
        got_q, got_t = box_pairs(qlo, qhi, tlo, thi)
        assert np.array_equal(got_q, want_q) and np.array_equal(got_t, want_t)


def test_the_box_hierarchy_finds_the_pairs_of_boxes_that_meet():
    """Against every pair compared: boxes on a coarse grid (many touch at a face, an edge or
    a corner, which counts as meeting), repeated boxes, points (boxes of no size) and empty
    sets, in sizes around the leaves' (4) and far above."""
    rng = np.random.default_rng(5)
    sizes = [(0, 5), (5, 0), (1, 1), (3, 4), (7, 5), (40, 9), (60, 300), (200, 1000)]
    for m, n in sizes + [tuple(rng.integers(0, 80, 2)) for _ in range(20)]:
        qlo = np.round(rng.uniform(0, 10, (m, 3)), 1)
        qhi = qlo + np.round(rng.uniform(0, 2, (m, 3)), 1) * (rng.random((m, 1)) < 0.8)
        tlo = np.round(rng.uniform(0, 10, (n, 3)), 1)
        thi = tlo + np.round(rng.uniform(0, 2, (n, 3)), 1) * (rng.random((n, 1)) < 0.8)
        if n > 4:  # a few boxes repeated: their centres tie at every split
            tlo[: n // 4], thi[: n // 4] = tlo[0], thi[0]
        hit = np.all((qlo[:, None] <= thi[None]) & (qhi[:, None] >= tlo[None]), axis=2)
        rows, cols = BoxHierarchy.build(tlo, thi).meeting(qlo, qhi)
        assert np.all(np.diff(rows) >= 0)  # grouped by query, ascending
        assert sorted(zip(rows.tolist(), cols.tolist())) == list(zip(*np.nonzero(hit)))


@pytest.mark.skipif(not hasattr(os, "sched_setaffinity") or not Path("/proc/self/task").is_dir(),
                    reason="needs Linux's CPU affinity and /proc")
def test_manifold_booleans_leave_no_thread_for_a_fork_to_lose():
    """A boolean of two 20,000-triangle solids made oneTBB start a worker thread; a process
    forked just after (the contacts' workers, after the parent's nested-part volumes)
    inherited an arena waiting for it, and its next boolean hung (seen on the engine). The
    solids now come from a one-thread scheduler: no thread more after the boolean, and a
    forked child's boolean ends."""
    code = (
        "import os, trimesh\n"
        "from ndbg_cli.contacts.facets import manifold_model\n"
        "from ndbg_cli.io.validate import make_part\n"
        "m = trimesh.creation.icosphere(subdivisions=5)\n"
        "a = make_part('a', m.vertices, m.faces)[0]\n"
        "b = make_part('b', m.vertices + 0.5, m.faces)[0]\n"
        "before = len(os.listdir('/proc/self/task'))\n"
        "assert (manifold_model(a) ^ manifold_model(b)).volume() > 0\n"
        "print(len(os.listdir('/proc/self/task')) - before)\n"
        "pid = os.fork()\n"
        "if pid == 0:\n"
        "    (manifold_model(a) ^ manifold_model(b).translate((0.1, 0, 0))).volume()\n"
        "    os._exit(0)\n"
        "print(os.waitpid(pid, 0)[1])\n")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         timeout=120, cwd=ROOT)
    assert out.stdout.split() == ["0", "0"], out.stderr


def shaft_block_geometry():
    shaft, block = shaft_and_block(9.99)
    asm = assemble(shaft, block)
    tol = asm.length_tolerance
    return asm, tol, [part_geometry(p, tol, CONTACT_ANGLE_TOL_RAD) for p in asm.parts]


def test_r_tree_queries_list_hits_in_tree_rank_order():
    _, _, geos = shaft_block_geometry()
    rng = np.random.default_rng(4)
    for g in geos:
        rank = _tree_rank(g)
        assert np.array_equal(np.sort(rank), np.arange(len(g.lo)))
        k = rng.integers(0, len(g.lo), 200)
        hits, counts = g.tree.intersection_v(g.lo[k] - 2.0, g.hi[k] + 2.0)
        hits = np.asarray(hits, dtype=np.int64)
        owner = np.repeat(np.arange(len(k)), np.asarray(counts, dtype=np.int64))
        for q in range(len(k)):
            got = hits[owner == q]
            assert np.array_equal(got, got[np.argsort(rank[got])])


@pytest.mark.parametrize("skip", [False, True])
def test_triangle_candidates_are_the_r_tree_hits_in_r_tree_order(skip):
    """The pairs the box hierarchy finds, put in R-tree order, are the target part's R-tree
    hits as it lists them (grouped by query triangle, ascending), less the triangles left
    out on either side."""
    c = contacts_module
    _, tol, (ga, gb) = shaft_block_geometry()
    rng = np.random.default_rng(3)
    skips = [rng.random(len(g.lo)) < 0.2 if skip else None for g in (ga, gb)]
    got = c._triangle_candidates(ga, gb, tol, *skips)
    reach = c._reach(ga, gb, tol)
    (lo_a, hi_a), (lo_b, hi_b) = c._tri_box(ga), c._tri_box(gb)
    sa = c._near_box(ga, lo_b - reach, hi_b + reach)
    sb = c._near_box(gb, lo_a - reach, hi_a + reach)
    if skip:
        sa, sb = sa[~skips[0][sa]], sb[~skips[1][sb]]
    swap = len(sa) > len(sb)
    (q, qs, t, t_skip) = (gb, sb, ga, skips[0]) if swap else (ga, sa, gb, skips[1])
    hits, counts = t.tree.intersection_v(q.lo[qs] - reach, q.hi[qs] + reach)
    rows = np.repeat(qs, np.asarray(counts, dtype=np.int64))
    cols = np.asarray(hits, dtype=np.int64)
    if skip:
        rows, cols = rows[~t_skip[cols]], cols[~t_skip[cols]]
    want = (cols, rows) if swap else (rows, cols)
    assert len(want[0]) > 500
    assert all(np.array_equal(g, w) for g, w in zip(got, want))
    if skip:  # a large pair: an R-tree of the others, in its own order; the same pairs
        c._SUBTREE_PAIRS, before = 0, c._SUBTREE_PAIRS
        try:
            big = c._triangle_candidates(ga, gb, tol, *skips)
        finally:
            c._SUBTREE_PAIRS = before
        q_side = big[1] if swap else big[0]
        assert np.all(np.diff(q_side) >= 0)  # grouped by query triangle
        assert sorted(zip(*big)) == sorted(zip(*want))


def _sat_gap_reference(ta, tb):
    """The 11-axis separating gap as first written (min/max over the vertex axis)."""
    ea = np.roll(ta, -1, axis=1) - ta
    eb = np.roll(tb, -1, axis=1) - tb
    cr = np.cross(ea[:, :, None, :], eb[:, None, :, :]).reshape(-1, 9, 3)
    axes = np.concatenate([np.cross(ea[:, 0], ea[:, 1])[:, None],
                           np.cross(eb[:, 0], eb[:, 1])[:, None], cr], axis=1)
    norm = np.linalg.norm(axes, axis=2)
    ok = norm > 1e-9 * np.maximum(norm.max(axis=1, keepdims=True), 1e-300)
    axes = axes / np.where(ok, norm, 1.0)[..., None]
    pa = np.einsum("pkd,pvd->pkv", axes, ta)
    pb = np.einsum("pkd,pvd->pkv", axes, tb)
    gap = np.maximum(pb.min(axis=2) - pa.max(axis=2), pa.min(axis=2) - pb.max(axis=2))
    return np.where(ok, gap, -np.inf).max(axis=1)


def test_sat_gap_and_plane_offsets_equal_the_reference():
    _, tol, (ga, gb) = shaft_block_geometry()
    i, j = contacts_module._triangle_candidates(ga, gb, tol)
    ta, tb = ga.triangles[i], gb.triangles[j]
    assert np.array_equal(sat_gap(ta, tb), _sat_gap_reference(ta, tb))
    rng = np.random.default_rng(8)
    ra, rb = rng.normal(size=(500, 3, 3)), rng.normal(size=(500, 3, 3))
    ra[:50, 2] = ra[:50, 1]  # degenerate triangles
    assert np.array_equal(sat_gap(ra, rb), _sat_gap_reference(ra, rb))
    fi, fj, offsets = contacts_module._plane_filter(ga, gb, i, j, tol)
    assert len(fi) > 100
    with_offsets = classify_pairs(ga, gb, fi, fj, tol, CONTACT_ANGLE_TOL_RAD, offsets)
    without = classify_pairs(ga, gb, fi, fj, tol, CONTACT_ANGLE_TOL_RAD)
    assert all(np.array_equal(a, b) for a, b in zip(with_offsets, without))


def test_apart_is_a_proof_of_distance():
    rng = np.random.default_rng(6)
    far = near = 0
    for _ in range(40):
        shift = rng.uniform(-3, 3, 3)
        asm = assemble(box((2, 2, 2), (0, 0, 0)), box((1, 1, 1), shift))
        tol = asm.length_tolerance
        ga, gb = (part_geometry(p, tol, CONTACT_ANGLE_TOL_RAD) for p in asm.parts)
        gap = 0.3
        d = fcl.distance(fcl_object(asm.parts[0]), fcl_object(asm.parts[1]),
                         fcl.DistanceRequest(), fcl.DistanceResult())
        if contacts_module._apart(ga, gb, (gb.lo.min(axis=0), gb.hi.max(axis=0)), gap):
            assert d > gap
            far += 1
        else:
            near += d <= gap
    assert far and near


def test_near_triangles_equals_the_box_hierarchy_search(monkeypatch):
    import ndbg_cli.contacts.features as features
    _, _, (ga, gb) = shaft_block_geometry()
    rng = np.random.default_rng(9)
    for g in (ga, gb):
        ids = np.sort(rng.choice(len(g.lo), size=len(g.lo) // 3, replace=False))
        pts = g.triangles[rng.integers(0, len(g.lo), 400)].mean(axis=1)
        pts += rng.normal(size=pts.shape) * 0.5
        gap = rng.uniform(0.01, 1.0, len(pts))
        dense = features._near_triangles(pts, gap, g, ids)
        monkeypatch.setattr(features, "_BOX_PAIRS", 0)  # the box hierarchy's query
        hierarchy = features._near_triangles(pts, gap, g, ids)
        monkeypatch.undo()
        assert 0 < dense.sum() < len(pts)
        assert np.array_equal(dense, hierarchy)


@pytest.mark.external
@pytest.mark.parametrize("euler", [(0, 0, 0), (30, 40, 50), (0, 45, 30)])
def test_a_curved_contact_does_not_appear_when_the_model_turns(euler):
    # The engine's crankcase unit (26 parts kept together: they clash) and part 52 are
    # 0.39 mm apart (fcl), their gap allowance is 0.16. The candidate triangle pairs come
    # from boxes grown by the pair's reach (the unit's largest chord sag is 2.9 mm), which a
    # turn enlarges: four facing pairs of the turned model passed the plane test (each
    # triangle crosses the other's slab) and made a curved contact that the model in its
    # own frame does not have (fails on the old code for both turns).
    from ndbg_cli.pipeline.units import merge_units

    asm = ndbg_cli.load(shared("engine", "2CylinderEngine.glb"))
    members = ("27 28 31-2 41 42 45 46 50 54 55 56 57 60 61 62 63 64 65 67 68 69 70 71 72 79 "
               "80").split()
    index = {p.id: k for k, p in enumerate(asm.parts)}
    merged = merge_units(asm, [sorted(index[x] for x in members)])
    unit, other = (p for p in merged.parts if p.id in ("+".join(members), "52"))
    turn = Rotation.from_euler("xyz", euler, degrees=True).as_matrix()
    parts = tuple(make_part(p.id, np.asarray(p.mesh.vertices) @ turn.T,
                            np.asarray(p.mesh.faces))[0] for p in (unit, other))
    pair = Assembly("crankcase-and-52", parts, tolerance=asm.length_tolerance)
    assert analyze_contacts(pair).contacts == ()


def test_the_units_analysis_asks_python_fcl_only_about_the_units(monkeypatch):
    """The second contact analysis (clashing parts merged into a unit) meets the pairs of the
    other parts again: their broad phase is what the first one found, not asked again."""
    from ndbg_cli.pipeline.units import merge_units

    asm = ndbg_cli.load(str(ROOT / "assemblies" / "clash.yaml"))
    first = analyze_contacts(asm)
    clashes = [(x.a, x.b) for x in first.interferences if x.kind == "clash"]
    assert clashes
    merged = merge_units(asm, [sorted(clashes[0])])
    asked = []
    real = contacts_module._confirmed
    monkeypatch.setattr(contacts_module, "_confirmed",
                        lambda a, g, i, j, *r: asked.append((a.ids[i], a.ids[j])) or real(
                            a, g, i, j, *r))
    again = analyze_contacts(merged)
    unit = merged.ids[min(clashes[0])]
    assert asked and all(unit in pair for pair in asked)
    fresh = analyze_contacts(merged.replace(parts=tuple(
        dataclasses.replace(p, hash=p.hash + "-new") for p in merged.parts)))
    assert [(c.a, c.b, c.kind) for c in again.contacts] == [
        (c.a, c.b, c.kind) for c in fresh.contacts]


def test_the_broad_phase_shared_with_a_helper_finds_the_same_pairs(monkeypatch):
    """With a core to spare, a forked helper confirms every other candidate pair (python-fcl
    queries on BVHs it inherits): the pairs, their crossing flags and the nested pairs are
    those found here alone, and this process confirmed only half of them."""
    import os

    import ndbg_cli.contacts.facets as facets

    if not hasattr(os, "fork"):
        pytest.skip("no fork here: the pairs are confirmed in this process")
    asm = ndbg_cli.load(Path(__file__).parent.parent / "assemblies" / "bell.yaml")
    tol = asm.length_tolerance
    calls, confirmed = [], contacts_module._confirmed

    def counting(*args):
        calls.append(1)
        return confirmed(*args)

    monkeypatch.setattr(contacts_module, "_confirmed", counting)
    monkeypatch.setattr(contacts_module, "SHARED_CONFIRMATIONS", 2)
    got = {}
    for workers in (1, 2):
        facets.clear_caches()  # new geometries: nothing memoized from the other run
        calls.clear()
        geos = facets.part_geometries(asm.parts, tol, CONTACT_ANGLE_TOL_RAD)
        got[workers] = (contacts_module._broad_phase(asm, geos, tol, workers), len(calls))
    (pairs, nested), alone = got[1]
    assert len(pairs) > 20 and got[2][0] == (pairs, nested)
    assert got[2][1] == (alone + 1) // 2  # the helper confirmed the other half


def test_part_geometries_found_in_a_forked_child_are_the_same(monkeypatch):
    """The parts' facets, sags and adjacency computed in a forked child while this process
    builds the BVHs (``fork_above``) are the arrays computed here, to the bit; the child, not
    this process, computed them; parts already cached are not computed again."""
    import os

    import ndbg_cli.contacts.facets as facets

    if not hasattr(os, "fork"):
        pytest.skip("no fork here: the geometry is computed in this process")
    asm = ndbg_cli.load(Path(__file__).parent.parent / "assemblies" / "peg-37.yaml")
    tol = asm.length_tolerance
    facets.clear_caches()
    here = [facets.part_geometry(p, tol, CONTACT_ANGLE_TOL_RAD) for p in asm.parts]
    facets.clear_caches()
    calls, derived = [], facets._derived

    def counting(*args):
        calls.append(1)
        return derived(*args)

    monkeypatch.setattr(facets, "_derived", counting)
    built = []
    got = facets.part_geometries(asm.parts, tol, CONTACT_ANGLE_TOL_RAD, fork_above=0,
                                 meanwhile=lambda: built.append(1))
    assert not calls and built == [1]  # the child computed them, this process the BVHs
    for a, b in zip(here, got, strict=True):
        for field in dataclasses.fields(a):
            x, y = getattr(a, field.name), getattr(b, field.name)
            if isinstance(x, np.ndarray):
                assert (x.dtype, x.shape, x.tobytes()) == (y.dtype, y.shape, y.tobytes()), \
                    field.name
    assert facets.part_geometries(asm.parts, tol, CONTACT_ANGLE_TOL_RAD, fork_above=0) == got
    facets.clear_caches()
    facets.part_geometries(asm.parts, tol, CONTACT_ANGLE_TOL_RAD, fork_above=10 ** 9)
    assert len(calls) == len(asm.parts)  # under the threshold: here

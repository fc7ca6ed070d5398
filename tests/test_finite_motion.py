"""Finite rotations and screw motions (``ndbg.generalized.finite``) and the proofs of
generalized plans' steps (``pipeline.motion_proofs``): answers worked out by hand."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import trimesh
from scipy.spatial import Delaunay

import ndbg_cli
from ndbg_cli.core.assembly import Assembly
from ndbg_cli.io.validate import make_part
from ndbg_cli.ndbg.generalized.finite import (
    Screw,
    alignment_angles,
    check_motion,
    cylinder_bands,
)
from ndbg_cli.ndbg.generalized.twist import twist
from ndbg_cli.pipeline.motion_proofs import prove_step

ROOT = Path(__file__).resolve().parents[1]
Z = np.array([0.0, 0.0, 1.0])


def test_a_screw_from_its_twist_and_its_motion():
    """The twist of a right-hand screw about the line x = 1, y = 2 along z, pitch pi (0.5 per
    radian): that line and that advance; (2, 2, 0) turned a quarter turn goes to
    (1, 3, pi / 4)."""
    s = Screw.from_twist(twist("screw", (0, 0, 1), (1, 2, 5), np.pi))
    assert np.allclose(s.axis, Z) and s.advance == pytest.approx(0.5)
    assert np.allclose(s.center[:2], [1, 2])
    assert np.allclose(s.move(np.array([2.0, 2, 0]), np.pi / 2), [1, 3, np.pi / 4])
    with pytest.raises(ValueError):
        Screw.from_twist([1, 0, 0, 0, 0, 0])


def test_the_hull_holds_every_position_over_the_interval():
    """Random triangles, screws and intervals: each triangle, at angles across the interval,
    lies in the convex hull of its :meth:`Screw.hull_points` (scipy's Delaunay test)."""
    rng = np.random.default_rng(3)
    for case in range(40):
        axis = rng.normal(size=3)
        s = Screw(rng.uniform(-2, 2, 3), axis / np.linalg.norm(axis),
                  0.0 if case % 2 else rng.uniform(-1, 1))
        tri = rng.uniform(-3, 3, (1, 3, 3))
        t0 = rng.uniform(-3, 3)
        t1 = t0 + rng.uniform(0.01, 2.5)
        hull = Delaunay(s.hull_points(tri, t0, t1)[0])
        w = rng.dirichlet(np.ones(3), 30)
        for t in np.linspace(t0, t1, 9):
            pts = w @ s.move(tri[0], t)
            assert (hull.find_simplex(pts, tol=1e-9) >= 0).all(), case


def test_a_cube_turning_beside_a_wall():
    """A unit cube turning counter-clockwise about its vertical axis on a floor (sliding):
    free all round. A wall at x = 0.6: the corner from -45 degrees, at sqrt(2) / 2, reaches it
    after ``45 - acos(0.6 sqrt 2)`` = 13.05 degrees; the check stops no later, and not much
    earlier. Turning clockwise the other corner reaches it after as long."""
    cube = trimesh.creation.box((1, 1, 1)).triangles
    floor = trimesh.creation.box((4, 4, 1)).apply_translation((0, 0, -1)).triangles
    wall = trimesh.creation.box((1, 4, 2)).apply_translation((1.1, 0, 0)).triangles
    hit = np.pi / 4 - np.arccos(0.6 * np.sqrt(2))
    for sense in (1.0, -1.0):
        turn = Screw(np.zeros(3), sense * Z, 0.0)
        assert check_motion(turn, cube, floor, 2 * np.pi, 1e-9, 1e-5).free
        got = check_motion(turn, cube, np.concatenate([floor, wall]), np.pi / 2, 1e-9, 1e-5)
        assert not got.free and hit - 0.01 < got.blocked_at <= hit
        assert got.fixed >= len(floor)  # the wall's triangle
        # up to just before the corner meets it, the turn is free
        assert check_motion(turn, cube, np.concatenate([floor, wall]), hit - 0.01, 1e-9,
                            1e-5).free


def test_alignment_angles_by_hand():
    """A face facing +x turned about z onto faces facing +y (90 degrees) and (-1, -1, 0)
    (225 degrees); one facing up and a tilted one are never reached."""
    got = alignment_angles(np.array([[1.0, 0, 0]]),
                           np.array([[0, 1.0, 0], [-1, -1, 0] / np.sqrt(2), [0, 0, 1.0],
                                     [0.6, 0, 0.8]]), Z)
    assert np.allclose(got, [np.pi / 2, 5 * np.pi / 4])


def fig5():
    return ndbg_cli.load(ROOT / "assemblies" / "fig5-rotation.yaml")


def test_the_key_turns_45_degrees_counter_clockwise_then_leaves_upward():
    """fig5-rotation's ``expect``: turning counter-clockwise about z frees the key's sides and
    after 45 degrees it fits the opening and leaves along +z; clockwise its sides push into
    the pads at once."""
    asm = fig5()
    key, housing = asm.index("key"), asm.index("housing")
    ccw = {"type": "rotation", "axis": [0, 0, 1.0], "point": [0, 0, 10.0], "pitch": 0.0}
    proof, why = prove_step(asm, [key], [housing], ccw)
    assert why == "" and proof["motion"] == "rotation"
    assert proof["angle"] == pytest.approx(np.pi / 4, abs=1e-9) and proof["then"] == [0, 0, 1]
    cw = dict(ccw, axis=[0, 0, -1.0])
    proof, why = prove_step(asm, [key], [housing], cw)
    assert proof is None and "after 0 degrees" in why


def test_a_key_under_a_lid_turns_but_never_leaves():
    """The same key with a plate laid over the housing's opening: the turn is still free up
    to 45 degrees (the key's top slides under the plate), where no translation frees it any
    more, and the pocket (the region the key sweeps from 0 to 45 degrees) ends there: the
    key's sides meet its walls."""
    asm = fig5()
    lid = make_part("lid", *_arrays(trimesh.creation.box((60, 60, 2)).apply_translation(
        (0, 0, 21))))[0]
    both = Assembly("lidded", asm.parts + (lid,), units=asm.units,
                    tolerance=asm.length_tolerance)
    ccw = {"type": "rotation", "axis": [0, 0, 1.0], "point": [0, 0, 10.0], "pitch": 0.0}
    proof, why = prove_step(both, [both.index("key")],
                            [both.index("housing"), both.index("lid")], ccw)
    assert proof is None and why == "turning, key meets housing after 45 degrees"


def _arrays(mesh: trimesh.Trimesh) -> tuple[np.ndarray, np.ndarray]:
    return np.array(mesh.vertices), np.array(mesh.faces)


def test_the_bolt_unscrews_twelve_turns_along_its_joint():
    """bolt-screw: its shank (z 5 to 20) leaves the block (top z 20) after 15 mm, 12 turns of
    the 1.25 mm thread (24 pi radians), then lifts off along +z; its own pair follows the
    declared joint. Without the joint, a screw motion is not proven."""
    asm = ndbg_cli.load(ROOT / "assemblies" / "bolt-screw.yaml")
    bolt, block = asm.index("bolt"), asm.index("block")
    screw = {"type": "screw", "axis": [0, 0, 1.0], "point": [0, 0, 0.0], "pitch": 1.25}
    proof, why = prove_step(asm, [bolt], [block], screw)
    assert why == "" and proof["angle"] == pytest.approx(24 * np.pi, abs=1e-6)
    assert proof["then"] == [0, 0, 1] and proof["joints"] == [["bolt", "block"]]
    bare = Assembly(asm.name, asm.parts, units=asm.units, tolerance=asm.length_tolerance)
    proof, why = prove_step(bare, [bolt], [block], screw)
    assert proof is None and "no declared joint" in why


def test_generalized_plans_of_the_examples_are_proven(tmp_path):
    """The CLI's plans of both examples are proven, every step with its proof, and the text
    report says how far each turns."""
    import json

    from helpers import run_cli

    for name, angle in (("fig5-rotation", 45), ("bolt-screw", 4320)):
        out = tmp_path / f"{name}.json"
        got = run_cli("analyze", str(ROOT / "assemblies" / f"{name}.yaml"), "--format", "json",
                      "--no-cache", "--out", str(out))
        assert got.returncode == 0, got.stderr
        plan = json.loads(out.read_text())["plan"]
        assert plan["family"] == "generalized" and plan["verified"]["value"] is True
        (step,) = plan["sequence"]
        assert step["proof"]["test"] == "motion"
        assert np.degrees(step["proof"]["angle"]) == pytest.approx(angle, abs=1e-6)
        text = run_cli("analyze", str(ROOT / "assemblies" / f"{name}.yaml"), "--no-cache")
        assert f"[turned {angle:g} degrees, then along (+0, +0, +1)]" in text.stdout


def _with_jaw(asm: Assembly) -> Assembly:
    """bolt-screw with an arm of the block reaching over the bolt's head (top at z 26): a
    post beside it and a bar 2 mm above it, one solid with the block."""
    import manifold3d as m3

    k = asm.index("block")
    mesh = asm.parts[k].mesh
    block = m3.Manifold(m3.Mesh64(vert_properties=np.asarray(mesh.vertices, dtype=float),
                                  tri_verts=np.asarray(mesh.faces, dtype=np.uint64)))
    arm = (m3.Manifold.cube((4, 6, 30)).translate((10, -3, 0))
           + m3.Manifold.cube((24, 6, 2)).translate((-10, -3, 28)))
    got = (block + arm).to_mesh64()
    jawed = make_part("block", np.array(got.vert_properties)[:, :3],
                      np.array(got.tri_verts))[0]
    parts = tuple(jawed if i == k else p for i, p in enumerate(asm.parts))
    return Assembly(asm.name, parts, units=asm.units, tolerance=asm.length_tolerance,
                    joints=asm.joints)


def test_the_jointed_part_itself_is_checked_and_the_thread_keeps_its_hand():
    """The joint licenses the screw, not the jointed part: with the block's arm 2 mm over
    the head (across the shank's path), the step is refused; the shank is then tested
    against its hole like any surface. Turning the other way along the same thread drives
    the bolt into the hole's bottom at once; a left-hand screw is not the right-hand
    joint's motion."""
    asm = ndbg_cli.load(ROOT / "assemblies" / "bolt-screw.yaml")
    bolt, block = asm.index("bolt"), asm.index("block")
    up = {"type": "screw", "axis": [0, 0, 1.0], "point": [0, 0, 0.0], "pitch": 1.25}
    proof, why = prove_step(_with_jaw(asm), [bolt], [block], up)
    assert proof is None and why.startswith("turning, bolt meets block after")
    proof, why = prove_step(asm, [bolt], [block], dict(up, axis=[0, 0, -1.0]))
    assert proof is None and why.startswith("turning, bolt meets block after 0.0")
    proof, why = prove_step(asm, [bolt], [block], dict(up, pitch=-1.25))
    assert proof is None and "no declared joint" in why


def test_the_check_turns_forward_and_keeps_to_its_budget():
    cube = trimesh.creation.box((1, 1, 1)).triangles
    floor = trimesh.creation.box((4, 4, 1)).apply_translation((0, 0, -1)).triangles
    turn = Screw(np.zeros(3), Z, 0.0)
    with pytest.raises(ValueError):
        check_motion(turn, cube, floor, -1.0, 1e-9, 1e-5)
    got = check_motion(turn, cube, floor, np.pi, 1e-9, 1e-5, budget=10)
    assert not got.free and got.over_budget


def test_two_sectors_of_one_tube_meet_when_one_turns_into_the_other():
    """Sectors 0-60 and 90-150 degrees of one tube (radii 5 to 5.5, 48 facets): turning the
    first by 30 degrees brings its end onto the second's, and further it sweeps through it
    (manifold3d: no overlap at 29.9 degrees, 0.09 at 31). Their walls are facets of
    cylinders about the axis, but a wall never lies across the cylinder from the other
    part's wall here: the check stops at 30 degrees."""
    import manifold3d as m3

    def sector(a0: float, a1: float) -> m3.Manifold:
        tube = (m3.Manifold.cylinder(2, 5.5, -1, 48)
                - m3.Manifold.cylinder(4, 5.0, -1, 48).translate((0, 0, -1)))
        h0 = m3.Manifold.cube((20, 20, 6)).translate((-10, 0, -2)).rotate((0, 0, a0))
        h1 = m3.Manifold.cube((20, 20, 6)).translate((-10, -20, -2)).rotate((0, 0, a1))
        return tube ^ h0 ^ h1

    def tris(solid: m3.Manifold) -> np.ndarray:
        m = solid.to_mesh64()
        return np.array(m.vert_properties)[:, :3][np.array(m.tri_verts)]

    moving, fixed = tris(sector(0, 60)), tris(sector(90, 150))
    turn = Screw(np.zeros(3), Z, 0.0)
    sag = 5.5 * (1 - np.cos(np.pi / 48))
    half = np.pi / 48 + np.radians(1)
    bands = tuple(cylinder_bands(t, turn, np.full(len(t), 1e-3 + sag), np.full(len(t), half))
                  for t in (moving, fixed))
    assert all((b[:, 3] == 1).sum() and (b[:, 3] == -1).sum() for b in bands)
    got = check_motion(turn, moving, fixed, np.radians(60), 1e-5, 1e-5, bands=bands)
    assert not got.free and np.degrees(got.blocked_at) == pytest.approx(30, abs=0.01)


def test_an_oval_cam_in_its_hole_does_not_turn_even_on_a_joint():
    """A prism whose radius is 10 (1 + 0.006 cos 2 theta) (180 facets) in a block's hole of
    its own shape, with a revolute joint declared about z: facet by facet its wall looks
    like a cylinder about z (each facet's radii within the allowance), but as one surface
    it spans 0.12 in radius, so it is tested, and a quarter turn would push it 0.12 into
    the block (manifold3d: 6 mm^3 of overlap at 30 degrees). The step is refused at once."""
    import manifold3d as m3

    from ndbg_cli.core.assembly import Joint

    t = np.linspace(0, 2 * np.pi, 180, endpoint=False)
    r = 10 * (1 + 0.006 * np.cos(2 * t))
    cam = m3.Manifold.extrude(m3.CrossSection([np.column_stack([r * np.cos(t),
                                                                r * np.sin(t)])]), 5.0)
    block = m3.Manifold.cube((30, 30, 5)).translate((-15, -15, 0)) - cam
    assert (cam.rotate((0, 0, 30)) ^ block).volume() > 1.0

    def part(solid: m3.Manifold, name: str):
        m = solid.to_mesh64()
        return make_part(name, np.array(m.vert_properties)[:, :3], np.array(m.tri_verts))[0]

    asm = Assembly("cam", (part(block, "block"), part(cam, "cam")),
                   joints=(Joint("revolute", ("cam", "block"), (0, 0, 1.0), (0, 0, 0.0)),))
    turn = {"type": "rotation", "axis": [0, 0, 1.0], "point": [0, 0, 0.0], "pitch": 0.0}
    proof, why = prove_step(asm, [1], [0], turn)
    assert proof is None and why.startswith("turning, cam meets block after 0")


def _revolve(profile: list[tuple[float, float]], tube: bool, n: int = 96) -> trimesh.Trimesh:
    """A solid of revolution about z from its ``(r, z)`` profile: a closed loop (``tube``)
    or a path from the axis to the axis, ``n`` facets a turn."""
    th = np.linspace(0, 2 * np.pi, n, endpoint=False)
    verts: list = []
    index: dict = {}

    def vid(i: int, j: int) -> int:
        r, z = profile[i]
        key = (i, 0) if r == 0 else (i, j % n)
        if key not in index:
            index[key] = len(verts)
            verts.append((r * np.cos(th[j % n]), r * np.sin(th[j % n]), z))
        return index[key]

    m = len(profile)
    edges = [(i, (i + 1) % m) for i in range(m)] if tube else [(i, i + 1) for i in range(m - 1)]
    faces = []
    for a, b in edges:
        for j in range(n):
            p, q, s, t = vid(a, j), vid(a, j + 1), vid(b, j + 1), vid(b, j)
            faces += [f for f in ((p, q, s), (p, s, t)) if len(set(f)) == 3]
    mesh = trimesh.Trimesh(np.array(verts), np.array(faces), process=True)
    mesh.fix_normals()
    return mesh


def test_a_rod_screwed_through_a_narrower_hole_is_refused():
    """A rod of radius 4 (its end faces ringed at 2.09) screwed along a declared joint
    through a hole of radius 2 (its faces ringed at 3.91): every triangle pair where the
    boundaries cross has one side within the allowance (0.1 + sag) of the other's cylinder,
    but the block lies across the rod's path at radius 2, 2 mm deep (manifold3d: 377 mm^3
    of overlap half way): the rod's wall is tested, and the step refused at once."""
    from ndbg_cli.core.assembly import Joint

    rod = _revolve([(0, 10), (2.09, 10), (4, 10), (4, 20), (2.09, 20), (0, 20)], False)
    block = _revolve([(2, 0), (3.91, 0), (6, 0), (6, 10), (3.91, 10), (2, 10)], True)
    pitch = 320 / 79.5
    asm = Assembly("press", (make_part("block", *_arrays(block))[0],
                             make_part("rod", *_arrays(rod))[0]), tolerance=0.1,
                   joints=(Joint("screw", ("rod", "block"), (0, 0, -1.0), (0, 0, 0.0), pitch),))
    screw = {"type": "screw", "axis": [0, 0, -1.0], "point": [0, 0, 0.0], "pitch": pitch}
    proof, why = prove_step(asm, [1], [0], screw)
    assert proof is None and why.startswith("turning, rod meets block after 0")

"""Bounds on an overlap's mean thickness without a boolean (``contacts.overlap_bounds``):
values worked out by hand on pegs in holes, and never below manifold3d's exact ``2 V / S``."""

from __future__ import annotations

import manifold3d as m3
import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from ndbg_cli.contacts import facets
from ndbg_cli.contacts.facets import part_geometry
from ndbg_cli.contacts.interference import interference
from ndbg_cli.contacts.overlap_bounds import patch_axes, shell_bound, thin_shell
from ndbg_cli.core.constants import CONTACT_ANGLE_TOL_RAD
from ndbg_cli.io.validate import make_part

N = 64
#: Half the angle of a 64-gon's side: its sides lie ``cos(HALF)`` from the centre, its
#: corners 1 (manifold3d's polygons are inscribed).
HALF = np.pi / N
TOL = 1e-3


def cylinder(r: float, z0: float, z1: float) -> m3.Manifold:
    return m3.Manifold.cylinder(z1 - z0, r, -1.0, N).translate((0, 0, z0))


def plate(hole_bottom: float = -3.0) -> m3.Manifold:
    """An 8 x 8 plate, ``z`` from -2 to 0, with a hole of radius 1 down to ``hole_bottom``
    (below -2: through)."""
    return m3.Manifold.cube((8, 8, 2)).translate((-4, -4, -2)) - cylinder(1, hole_bottom, 1)


def pin(r: float = 1.0, tip: float = -4.0) -> m3.Manifold:
    """A pin of radius ``r`` from ``tip`` up, under a head of radius 2 from ``z`` 0 to 1."""
    return cylinder(r, tip, 0.5) + cylinder(2, 0, 1)


def part(solid: m3.Manifold, name: str, motion=None):
    mesh = solid.to_mesh64()
    v = np.array(mesh.vert_properties, dtype=float)[:, :3]
    if motion is not None:
        v = motion(v)
    p = make_part(name, v, np.asarray(mesh.tri_verts))[0]
    return p, part_geometry(p, TOL, CONTACT_ANGLE_TOL_RAD)


def exact_depth(a: m3.Manifold, b: m3.Manifold) -> float:
    overlap = a ^ b
    area = overlap.surface_area()
    return 2 * overlap.volume() / area if area > 0 else 0.0


def test_a_headed_pin_in_its_hole_is_bounded_by_its_band():
    """About the z axis: the pin reaches below the plate's top (z 0) only in its shank, whose
    corners lie at r = 1 (R_s); the plate's triangles over the pin lie below z 0 and at
    least cos(pi / 64) from the axis (R_h, the hole's sides). So the overlap is the band
    between them and no slab: ``R_s - R_h = 1 - cos(pi / 64)``, the chord sag, below the
    allowance ``tol + sag``."""
    (_, peg), (_, hole) = part(pin(), "pin"), part(plate(), "plate")
    band = 1 - np.cos(HALF)
    assert shell_bound(peg, hole, np.zeros(3), np.array([0, 0, 1.0]), 1e-3) == pytest.approx(
        band, abs=2e-8)  # plus the rounding slack, 1e-9 of the extents
    allowance = TOL + (1 - np.cos(HALF))
    assert thin_shell(peg, hole, allowance) and thin_shell(hole, peg, allowance)
    assert not thin_shell(peg, hole, 0.9 * band)
    # the pin's head is toward +z: about -z, its head is not over the plate, no bound
    assert shell_bound(peg, hole, np.zeros(3), np.array([0, 0, -1.0]), 1e-3) > 0.9


def test_a_fat_pin_is_not_hidden_and_the_boolean_finds_it():
    """A pin of radius 1.2 in the hole of radius 1: the band is 1.2 - cos(pi / 64) thick,
    and so is the bound; the exact overlap (a tube of height 2 and the rim
    under the head) is thinner than that and thicker than the allowance."""
    (pa, peg), (pb, hole) = part(pin(1.2), "pin"), part(plate(), "plate")
    c = np.cos(HALF)
    bound = shell_bound(peg, hole, np.zeros(3), np.array([0, 0, 1.0]), 1e-3)
    assert bound == pytest.approx(1.2 - c, abs=2e-8)
    depth = exact_depth(pin(1.2), plate())
    allowance = TOL + (1 - c)
    assert allowance < depth <= bound
    assert not thin_shell(peg, hole, allowance)
    found, approximate = interference(0, 1, pa, pb, peg, hole, allowance, TOL)
    # (the boolean's surface, and so 2V/S, depends a little on how it meets the coincident
    # faces: 0.1436 from the solids built here, 0.1496 from the parts' meshes)
    assert not approximate and allowance < found.depth <= bound


def test_a_pin_on_the_bottom_of_a_blind_hole_adds_a_slab():
    """The hole stops at z -1.5, where the pin's tip rests: the hole's bottom crosses the
    axis but lies at the pin's lowest height, so it is the bottom slab, of width 0, and the
    bound is the band's. Pushed 0.3 deeper, the hole's bottom lies above every cut tried
    (within the width asked, 1e-3, of the pin's end), so it is read as part of the tube,
    down to the axis: ``R_s - R_h = 1 - 0``, above the exact overlap: the 64-gon's disk
    0.3 thick (volume ``0.3 (N / 2) sin(2 pi / N)``) and the zero-volume band round the
    shank, whose surface also counts in ``S``."""
    band = 1 - np.cos(HALF)
    z = np.array([0, 0, 1.0])
    (_, peg), (_, hole) = part(pin(tip=-1.5), "pin"), part(plate(-1.5), "plate")
    assert shell_bound(peg, hole, np.zeros(3), z, 1e-3) == pytest.approx(band, abs=2e-8)
    (_, peg), (_, hole) = part(pin(tip=-1.8), "pin"), part(plate(-1.5), "plate")
    bound = shell_bound(peg, hole, np.zeros(3), z, 1e-3)
    depth = exact_depth(pin(tip=-1.8), plate(-1.5))
    volume = (pin(tip=-1.8) ^ plate(-1.5)).volume()
    assert volume == pytest.approx(0.3 * N / 2 * np.sin(2 * np.pi / N), rel=1e-9)
    assert bound == pytest.approx(1.0, abs=2e-8) and depth <= bound
    assert not thin_shell(peg, hole, 0.2)


def test_the_axes_and_the_proof_do_not_depend_on_the_frame():
    """Turned and moved anywhere, the pin's patches give its axis again and the same bound
    is proven, whichever part comes first."""
    rng = np.random.default_rng(7)
    allowance = TOL + (1 - np.cos(HALF))
    for _ in range(5):
        rot = Rotation.random(random_state=rng)
        shift = rng.uniform(-100, 100, 3)

        def motion(v, rot=rot, shift=shift):
            return rot.apply(v) + shift

        (_, peg), (_, hole) = part(pin(), "pin", motion), part(plate(), "plate", motion)
        axes = patch_axes(peg, hole)
        assert axes, "the shank is a curved patch near the plate"
        center, u = axes[0]
        assert abs(abs(u @ rot.apply([0, 0, 1.0])) - 1) < 1e-9
        off = (center - shift) - ((center - shift) @ rot.apply([0, 0, 1.0])) * rot.apply(
            [0, 0, 1.0])
        assert np.linalg.norm(off) < 1e-9
        assert thin_shell(peg, hole, allowance) and thin_shell(hole, peg, allowance)


def test_the_bound_is_never_below_the_exact_overlap():
    """Random pegs (radius, tip, head or none, off the hole's axis, tilted) in random blind
    or through holes: whatever axis is tried, the bound is at least manifold3d's exact mean
    thickness, and a pair proven thin is one the boolean finds thin."""
    rng = np.random.default_rng(11)
    proven = 0
    for case in range(24):
        r = rng.uniform(0.8, 1.15)
        tip = rng.uniform(-3.5, -1.2)
        peg_solid = cylinder(r, tip, 0.5) + (cylinder(2, 0, 1) if case % 3 else cylinder(r, 0, 1))
        if case % 4 == 0:
            peg_solid = peg_solid.translate((rng.uniform(-0.1, 0.1), 0, 0))
        if case % 5 == 0:
            peg_solid = peg_solid.rotate((rng.uniform(-2, 2), 0, 0))
        hole_solid = plate(rng.choice([-3.0, rng.uniform(-1.9, -1.2)]))
        (_, peg), (_, hole) = part(peg_solid, "peg"), part(hole_solid, "hole")
        depth = exact_depth(peg_solid, hole_solid)
        axes = patch_axes(peg, hole) + patch_axes(hole, peg)
        assert axes
        for center, u in axes:
            for a, b in ((peg, hole), (hole, peg)):
                for s in (1.0, -1.0):
                    assert depth <= shell_bound(a, b, center, s * u, 0.01) + 1e-12, case
        allowance = TOL + (1 - np.cos(HALF))
        if thin_shell(peg, hole, allowance):
            proven += 1
            assert depth <= allowance, case
    assert proven >= 3  # the cases with a head on the plate and a fitting shank


def test_a_proven_pair_builds_no_solid():
    """The bound spares the manifold3d solids, not only their boolean."""
    facets.clear_caches()
    (pa, peg), (pb, hole) = part(pin(), "pin"), part(plate(), "plate")
    allowance = TOL + (1 - np.cos(HALF))
    assert interference(0, 1, pa, pb, peg, hole, allowance, TOL) == (None, False)
    assert pa.hash not in facets._MANIFOLD_CACHE and pb.hash not in facets._MANIFOLD_CACHE


def test_each_parts_largest_patch_comes_before_the_others():
    """A plate whose largest curved patch near the pin is a cross bore (along x, radius
    0.5, 8 long: area 8 pi, against the pin's hole's 4 pi), not the pin's hole: the plate's
    first axis (x) bounds nothing, the pin's own shank (z, the pin's first) proves the band.
    So two axes, one per part, are enough where the plate's alone are not; and the
    interference test, which tries those two before the boolean and the others only
    without one, finds no interference either way."""
    bore = m3.Manifold.cylinder(9, 0.5, -1.0, N).rotate((0, 90, 0)).translate((-4.5, 1.7, -1))
    (pp, peg), (ph, hole) = part(pin(), "pin"), part(plate() - bore, "plate")
    (center, axis), *_ = patch_axes(hole, peg)
    assert abs(axis[0]) == pytest.approx(1.0)  # the cross bore's axis comes first
    allowance = TOL + (1 - np.cos(HALF))
    assert not thin_shell(hole, peg, allowance, stop=1)
    assert thin_shell(hole, peg, allowance, stop=2) and thin_shell(hole, peg, allowance)
    assert thin_shell(hole, peg, allowance, start=1)  # the pin's shank, second
    assert interference(0, 1, ph, pp, hole, peg, allowance, TOL) == (None, False)

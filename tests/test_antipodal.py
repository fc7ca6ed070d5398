"""The antipodal symmetry of the infinite-translation NDBG: ``B_ji = -B_ij``, so the DBG at
``-d`` is the DBG at ``d`` with every arc reversed, and the arrangement on a cube face is the image
of the opposite face's under the exact chart map ``(s, t) -> (-t, -s)``
(:data:`ndbg_cli.ndbg.infinite.chart_union.ANTIPODAL`). The arrangement maps the odd faces' cells
instead of computing them (:func:`ndbg_cli.ndbg.infinite.arrangement.arrangement_cells`): here the
mapped cells are checked against the cells computed directly and against the DBGs read directly at
their directions."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
import shapely

import ndbg_cli
from ndbg_cli.contacts.contacts3d import analyze_contacts
from ndbg_cli.ndbg.dbg import DBG
from ndbg_cli.ndbg.infinite import arrangement
from ndbg_cli.ndbg.infinite.blocked_sets import blocked_sets, succ_from_bits, transposed_bits
from ndbg_cli.ndbg.infinite.build import build_infinite
from ndbg_cli.ndbg.infinite.chart_union import antipodal
from ndbg_cli.ndbg.infinite.cubemap import direction_of
from ndbg_cli.ndbg.infinite.domain import domain_polygons, free_domain
from ndbg_cli.ndbg.infinitesimal.build import contact_pairs


def test_chart_map_by_hand():
    # (s, t) on face f goes to (-t, -s) on face f ^ 1; twice is the identity
    g = shapely.Polygon([(0.1, 0.2), (0.5, 0.2), (0.5, 0.7)])
    img = antipodal(g)
    assert shapely.get_coordinates(img).tolist() == [[-0.2, -0.1], [-0.2, -0.5], [-0.7, -0.5],
                                                     [-0.2, -0.1]]
    assert shapely.equals_exact(antipodal(img), g, tolerance=0.0)
    # the directions agree exactly: face 0 is +x, face 1 is -x
    p = np.array([[0.1, 0.2]])
    q = shapely.get_coordinates(antipodal(shapely.points(p)))
    assert np.array_equal(direction_of(1, q), -direction_of(0, p))


def test_transposed_bits_by_hand():
    # arcs 0 -> 1, 1 -> 2, 2 -> 0 and 0 -> 2 (three parts), reversed: 1 -> 0, 2 -> 1,
    # 0 -> 2 and 2 -> 0; packed rows: bit j of row i set when j blocks i
    g = DBG.from_arcs(3, [(0, 1), (1, 2), (2, 0), (0, 2)])
    bits = np.array([[[0b110], [0b100], [0b001]], [[0], [0], [0]]], dtype=np.uint8)
    got = transposed_bits(bits)
    assert got[0, :, 0].tolist() == [0b100, 0b001, 0b011]
    assert DBG(tuple(succ_from_bits(got)[0])) == g.reversed()
    assert not got[1].any()
    # more parts than a byte, against the arc-by-arc reversal
    rng = np.random.default_rng(3)
    n = 11
    many = [DBG(tuple(int(x) for x in rng.integers(0, 1 << n, n))) for _ in range(40)]
    packed = np.array([[list(m.to_bytes(2, "little")) for m in d.succ] for d in many],
                      dtype=np.uint8)
    back = succ_from_bits(transposed_bits(packed))
    assert all(DBG(r) == d.reversed() for r, d in zip(back, many))


def test_symmetric_domain_polygons_are_exact_images():
    asm = ndbg_cli.load("assemblies/peg-37.yaml")
    ca = analyze_contacts(asm)
    dom = free_domain(len(asm.parts), contact_pairs(asm, ca), ca.angle_tolerance)
    polys = domain_polygons(dom)
    assert any(p is not None for p in polys)
    for f in range(0, 6, 2):
        if polys[f] is None:
            assert polys[f + 1] is None
        else:
            assert shapely.equals_exact(polys[f + 1], antipodal(polys[f]), tolerance=0.0)
    # an asymmetric raster: each face from its own cells
    bad = dom.copy()
    bad[1] = False
    assert domain_polygons(bad)[1] is None


def _cells_both_ways(bs):
    mapped = arrangement.arrangement_cells(bs)
    direct = arrangement.arrangement_cells(dataclasses.replace(bs, paired=False))
    return mapped, direct


@pytest.mark.parametrize("name, restricted", [("hover", False), ("peg-37", False),
                                              ("peg-37", True)])
def test_mapped_cells_match_the_direct_ones(name, restricted):
    asm = ndbg_cli.load(f"assemblies/{name}.yaml")
    dom = None
    if restricted:
        ca = analyze_contacts(asm)
        dom = free_domain(len(asm.parts), contact_pairs(asm, ca), ca.angle_tolerance)
    bs = blocked_sets(asm, domain=dom)
    assert bs.paired
    mapped, direct = _cells_both_ways(bs)
    assert all(c.mirror_of == -1 for c in direct)
    odd = [c for c in mapped if c.face & 1]
    assert odd and all(c.mirror_of >= 0 for c in odd)
    for c in odd:  # an image of the opposite face's cell, exactly
        src = mapped[c.mirror_of]
        assert src.face == c.face ^ 1 and src.dimension == c.dimension
        assert np.array_equal(c.direction, 0.0 - src.direction)
        assert shapely.equals_exact(c.geom, antipodal(src.geom), tolerance=0.0)
    # the even faces are computed as before; each odd face's 2-dimensional cells cover the
    # same chart area as the directly computed ones, cell for cell
    even = [c for c in mapped if not c.face & 1]
    assert [c.direction.tolist() for c in even] == \
        [c.direction.tolist() for c in direct if not c.face & 1]
    for f in {c.face for c in odd}:
        got = [c.geom for c in odd if c.face == f and c.dimension == 2]
        want = [c.geom for c in direct if c.face == f and c.dimension == 2]
        assert len(got) == len(want)
        areas = sorted(shapely.area(got))
        assert np.allclose(areas, sorted(shapely.area(want)), rtol=0, atol=1e-12)
        assert shapely.union_all(got).symmetric_difference(shapely.union_all(want)).area \
            < 1e-12


@pytest.mark.parametrize("name", ["hover", "fig10-latch", "slot-37"])
def test_dbg_at_the_antipode_is_reversed(name):
    """The regions mapped from the opposite face carry the reversed DBG of their source; read
    directly at their (interior) directions, the sets give the same DBG."""
    asm = ndbg_cli.load(f"assemblies/{name}.yaml")
    nd = build_infinite(asm)
    bs = nd.geometry
    two = [r for r in nd.regions if r.dimension == 2]
    d = np.array([r.direction for r in two])
    direct = bs.dbgs(d)
    assert [g.succ for g in direct] == [r.dbg.succ for r in two]
    back = bs.dbgs(-d)
    assert all(b == g.reversed() for b, g in zip(back, direct))

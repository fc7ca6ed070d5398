"""The free domain (:mod:`ndbg_cli.ndbg.infinite.domain`) and the infinite NDBG restricted to it."""

from __future__ import annotations

import json

import numpy as np
import pytest

import ndbg_cli
from ndbg_cli.contacts.contacts3d import analyze_contacts
from ndbg_cli.ndbg.dbg import strong_components
from ndbg_cli.ndbg.infinite.build import boundary_distance, build_infinite, lookup
from ndbg_cli.ndbg.infinite.cover import RASTER
from ndbg_cli.ndbg.infinite.cubemap import face_of, random_directions
from ndbg_cli.ndbg.infinite.domain import (
    cell_directions,
    domain_polygons,
    domain_windows,
    free_domain,
)
from ndbg_cli.ndbg.infinitesimal.build import contact_pairs, dbg_at
from ndbg_cli.ndbg.model import partitionings

from helpers import run_cli


def _domain(name: str):
    asm = ndbg_cli.load(f"assemblies/{name}.yaml")
    ca = analyze_contacts(asm)
    pairs = contact_pairs(asm, ca)
    return asm, pairs, ca.angle_tolerance, free_domain(len(asm.parts), pairs, ca.angle_tolerance)


def _cell(d: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    f, st = face_of(d)
    col = np.clip(np.floor((st[:, 0] + 1.0) * RASTER / 2), 0, RASTER - 1).astype(int)
    row = np.clip(np.floor((st[:, 1] + 1.0) * RASTER / 2), 0, RASTER - 1).astype(int)
    return f, row, col


@pytest.mark.parametrize("name, restricted", [("peg-37", True), ("slot-37", True),
                                              ("stack", False)])
def test_domain_holds_every_direction_where_something_is_free(name, restricted):
    asm, pairs, tol, dom = _domain(name)
    d = np.concatenate([random_directions(3000, seed=5), np.eye(3), -np.eye(3)])
    free = np.array([len(strong_components(dbg_at(len(asm.parts), pairs, x, tol))) > 1
                     for x in d])
    # a real restriction where parts hold each other (a stack of boxes comes apart upwards
    # or downwards: everywhere, and then there is none)
    assert (dom is not None) == restricted
    if dom is None:
        return
    assert dom.mean() < 0.5
    f, row, col = _cell(d)
    assert dom[f, row, col][free].all()
    # symmetric under d -> -d
    f2, row2, col2 = _cell(-d)
    assert (dom[f, row, col] == dom[f2, row2, col2]).all()


@pytest.mark.parametrize("name", ["peg-37", "slot-37", "bolt-screw", "fig11-nonlinear"])
def test_pre_pass_skips_only_cells_the_coarse_test_drops(name, monkeypatch):
    """The :data:`~ndbg_cli.ndbg.infinite.domain.PRE` pass (parents tested with radii over their
    children)
    gives the very domain of the plain coarse-then-fine test, with far fewer cells tested."""
    from ndbg_cli.ndbg.infinite import domain
    asm, pairs, tol, dom = _domain(name)
    tested = []
    plain_may_free = domain._may_free

    def counting(n, pairs, tol, d, rad):
        tested.append(len(d))
        return plain_may_free(n, pairs, tol, d, rad)

    monkeypatch.setattr(domain, "_may_free", counting)
    assert np.array_equal(free_domain(len(asm.parts), pairs, tol), dom)
    with_pre = sum(tested)
    tested.clear()
    monkeypatch.setattr(domain, "PRE", domain.COARSE)  # no pre pass
    assert np.array_equal(free_domain(len(asm.parts), pairs, tol), dom)
    assert with_pre < sum(tested) / 4


def test_peg_domain_is_around_its_axis():
    asm, pairs, tol, dom = _domain("peg-37")
    v = np.asarray(asm.parts[asm.index("peg")].mesh.vertices)
    axis = np.linalg.svd(v - v.mean(axis=0), full_matrices=False)[2][0]  # the long axis
    f, row, col = _cell(np.array([axis, -axis, [1.0, 0.0, 0.0]]))
    inside = dom[f, row, col]
    assert inside[0] and inside[1]
    assert not inside[2]  # across the axis the peg is held


@pytest.mark.parametrize("name", ["peg-37", "slot-37"])
def test_restricted_ndbg_has_the_same_partitionings(name):
    asm, pairs, tol, dom = _domain(name)
    full = build_infinite(asm)
    part = build_infinite(asm, domain=dom)
    assert part.stats["restricted"] and not full.stats["restricted"]
    assert part.stats["domain_area"] < 1.0  # of 24 square chart units: a small window
    got = sorted(p.moved for p in partitionings(part)[0])
    want = sorted(p.moved for p in partitionings(full)[0])
    assert got and got == want
    # inside the domain the blocked sets are the full ones: the same DBG at directions
    # sampled in its cells (away from the B_ij boundaries, where the chart lookup is robust)
    f, row, col = np.nonzero(dom)
    pick = np.random.default_rng(3).choice(len(f), size=min(400, len(f)), replace=False)
    d = cell_directions(RASTER, f[pick], row[pick], col[pick])[0]
    d = d[boundary_distance(full, d) > 1e-6]
    assert len(d) > 50
    assert [g.succ for g in lookup(part, d)] == [g.succ for g in lookup(full, d)]
    assert [g.succ for g in lookup(part, d, exact=True)] == \
        [g.succ for g in lookup(full, d, exact=True)]


def test_analyze_over_budget_reports_the_restricted_section(tmp_path):
    out = tmp_path / "peg.json"
    r = run_cli("analyze", "assemblies/peg-37.yaml", "--motion", "infinite", "--format",
                "json", "--out", out, "--infinite-budget", "1")
    assert r.returncode in (0, 1), r.stderr
    rep = json.loads(out.read_text())
    sec = rep["ndbg"]["infinite_translation"]
    assert sec["domain"]["restricted"] is True and not sec.get("skipped")
    moved = [p["moved"] for p in rep["partitionings"] if p["family"] == "infinite_translation"]
    assert ["peg"] in moved or ["block"] in moved
    assert any(w["code"] == "infinite-restricted" for w in rep["warnings"])
    # the restricted family's regions make no plan or classes; the plan is proposed by the
    # infinitesimal NDBG (not reported) and every step proven by the sweep test, so it is an
    # infinite-translation plan without regions, and it decides the classes it proves
    plan = rep["plan"]
    assert plan["family"] == "infinite_translation" and plan["verified"]["value"] is True
    assert plan["regions_used"] == [] and all(s["region"] is None for s in plan["sequence"])
    assert rep["classes"]["infinite_translation"]["prismatic"]["value"] is True


def test_analyze_over_budget_says_why_no_restriction_helps(tmp_path):
    """The hover example's bridge touches nothing: something is free in every direction, so
    ``--motion infinite`` over the budget skips the NDBG and says so (not "use --motion
    infinite", which was given)."""
    out = tmp_path / "hover.json"
    r = run_cli("analyze", "assemblies/hover.yaml", "--motion", "infinite", "--format",
                "json", "--out", out, "--infinite-budget", "1")
    assert r.returncode in (0, 1), r.stderr
    sec = json.loads(out.read_text())["ndbg"]["infinite_translation"]
    assert sec["skipped"] is True
    assert "frees some subassembly in every direction" in sec["why"]
    assert "--motion infinite computes" not in sec["why"]


def test_domain_windows_bound_the_domain_cells():
    """Each face's window is the box of its domain cells (hand-made cells, cube-edge margin
    where they reach the border); the domain's polygons lie inside their windows."""
    dom = np.zeros((6, 8, 8), dtype=bool)
    dom[0, 2:4, 5] = True  # rows 2..3, column 5: s in [0.25, 0.5], t in [-0.5, 0]
    dom[3, 0, 7] = True  # a corner cell: the margin on two sides
    dom[4] = True
    win = domain_windows(dom)
    assert win[1] is None and win[2] is None and win[5] is None
    assert win[0] == (0.25, -0.5, 0.5, 0.0)
    m = 1.0 + 1e-9
    assert win[3] == (0.75, -m, m, -0.75)
    assert win[4] == (-m, -m, m, m)
    for face, poly in enumerate(domain_polygons(dom)):
        if poly is None:
            continue
        x0, y0, x1, y1 = poly.bounds
        wx0, wy0, wx1, wy1 = win[face]
        assert wx0 <= x0 and wy0 <= y0 and x1 <= wx1 and y1 <= wy1


def test_an_asymmetric_domain_is_refused():
    """The blocked sets make B_ji from B_ij on the opposite face, so a domain must be
    symmetric under d -> -d (free_domain's always is); one that is not is an error."""
    from ndbg_cli.ndbg.infinite.blocked_sets import antipodal_symmetric, blocked_sets

    asm, _, _, dom = _domain("peg-37")
    assert antipodal_symmetric(dom)
    bad = dom.copy()
    f, row, col = (int(x[0]) for x in np.nonzero(dom))
    bad[f, row, col] = False  # its antipode stays in
    assert not antipodal_symmetric(bad)
    with pytest.raises(ValueError, match="symmetric"):
        blocked_sets(asm, domain=bad)


def test_domain_beyond_64_parts_equals_the_short_chain():
    """Any number of parts (successor sets over several 64-bit words): a chain of 70 parts,
    each a pin in the next one's bore (contact normals all round the z axis, so only
    translations along z free anything), has the same domain as the chain of 3, around +-z
    only; an extra part in no contact is free everywhere (no restriction)."""
    ring = [[np.cos(a), np.sin(a), 0.0] for a in np.linspace(0, 2 * np.pi, 12, endpoint=False)]

    def chain(n):
        return [(k, k + 1, ring) for k in range(n - 1)]

    tol = 1e-3
    short, long_ = free_domain(3, chain(3), tol), free_domain(70, chain(70), tol)
    assert short is not None and long_ is not None
    assert np.array_equal(short, long_)
    d, _ = cell_directions(RASTER, *np.nonzero(long_))
    assert np.abs(d[:, 2]).min() > 0.999  # every kept cell is within 2.6 degrees of +-z
    f, row, col = _cell(np.array([[0, 0, 1.0], [0, 0, -1.0], [1.0, 0, 0]]))
    assert long_[f, row, col].tolist() == [True, True, False]
    assert free_domain(71, chain(70), tol) is None


def test_domain_is_everything_at_once_when_the_contact_graph_falls_apart(monkeypatch):
    """Two groups that touch each other nowhere separate in every direction: no restriction,
    decided before any cell is tested (an engine with loose parts spent minutes on them)."""
    import ndbg_cli.ndbg.infinite.domain as domain_mod

    ring = [[np.cos(a), np.sin(a), 0.0] for a in np.linspace(0, 2 * np.pi, 12, endpoint=False)]
    pairs = [(k, k + 1, ring) for k in range(59)] + [(k, k + 1, ring) for k in range(60, 199)]
    real = domain_mod._may_free

    def no_cells(*args):
        raise AssertionError("cells tested")

    monkeypatch.setattr(domain_mod, "_may_free", no_cells)
    assert free_domain(200, pairs, 1e-3) is None
    monkeypatch.setattr(domain_mod, "_may_free", real)
    assert free_domain(200, pairs + [(59, 60, ring)], 1e-3) is not None

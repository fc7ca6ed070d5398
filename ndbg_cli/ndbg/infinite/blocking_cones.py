"""The blocked-direction set ``B_ij`` of one ordered pair of parts, as a union of open cones
(paper section 5.3).

``P_j`` blocks the infinite translation of ``P_i`` along ``d`` when the sweep of ``P_i`` along
``d`` meets the interior of ``P_j``. A generic blocking ray leaves ``P_i`` through a triangle
``t_i`` (``n_i . d > 0``) and enters ``P_j`` through a triangle ``t_j`` (``n_j . d < 0``), so

    B_ij = union over triangle pairs of  cone(t_j - t_i) ∩ {n_i . d > 0} ∩ {n_j . d < 0},

each term an open convex polyhedral cone (:mod:`ndbg_cli.ndbg.infinite.cubemap`).
:func:`pair_cones` lists every term (dense, ``O(t_i t_j)``); :func:`pruned_pair_cones` gives
the same set from far fewer terms.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import trimesh

from ...core.assembly import Assembly
from ...kernels.compiled import loaded
from .chart_union import clipped_pieces
from .cover import Cover, domain_cover, run_offsets
from .cubemap import BOX_EDGE_PAIRS, DIFFERENCE_PAIRS
from .domain import domain_windows
from .erosion import edge_insets
from .tritree import TriTree, tri_tree  # noqa: F401 (tri_tree: part of this API)

#: Triangle pairs whose terms are made per call of the compiled kernel (it allocates room
#: for every pair's cone, 912 bytes each: a dense pair of large parts would need gigabytes).
CHUNK = 20000


def closed_parts(asm: Assembly) -> list[bool]:
    """Whether each part's mesh is watertight and consistently wound (2D parts: extruded
    polygons, always): the convex route needs a closed surface, and an open one faces both
    ways (:func:`part_triangles`)."""
    return [asm.dimension == 2 or (p.check.watertight and p.check.winding_consistent)
            for p in asm.parts]


def part_triangles(asm: Assembly) -> list[tuple[np.ndarray, np.ndarray]]:
    """Per part: triangles ``(t, 3, 3)`` and unit outward normals ``(t, 3)``, in the assembly
    frame (2D parts are extruded to prisms of height ``diagonal``).

    A part whose mesh is not closed and consistently wound (an open shell: a cup, a sheet, a
    surface export) has no outside: its triangles are listed twice, once reversed, so that
    each is a face on both sides. The facing tests above then see the shell's hidden side
    too, and the sweep of a cup over a boss is blocked by the boss, as the solid the shell
    stands for would be (the engine's pins, ``../shared/data/engine``)."""
    out = []
    h = max(asm.diagonal, 1e-9)
    for p, closed in zip(asm.parts, closed_parts(asm)):
        if asm.dimension == 2:
            mesh = trimesh.creation.extrude_polygon(p.polygon, h)
            mesh.apply_translation([0.0, 0.0, -h / 2])
        else:
            mesh = p.mesh
        tri = np.asarray(mesh.triangles, dtype=float)
        nrm = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
        ln = np.linalg.norm(nrm, axis=1, keepdims=True)
        ok = ln[:, 0] > 0
        tri, nrm = tri[ok], nrm[ok] / ln[ok]
        if not closed:
            tri = np.concatenate([tri, tri[:, ::-1]])
            nrm = np.concatenate([nrm, -nrm])
        out.append((tri, nrm))
    return out


# --------------------------------------------------------------------------------------------
# Terms of triangle pairs
# --------------------------------------------------------------------------------------------

def pair_cones(ti: np.ndarray, ni: np.ndarray, tj: np.ndarray, nj: np.ndarray, eps: float
               ) -> tuple[np.ndarray, np.ndarray]:
    """Every term of ``B_ij`` (dense): open cones ``(p, k, 3)`` and the normals ``(c, 3)`` of
    the triangles of near (contact) pairs.

    ``ti`` ``(a, 3, 3)`` / ``ni`` ``(a, 3)`` are the moving part's triangles and normals,
    ``tj`` / ``nj`` the blocker's. The great circles ``d . n = 0`` of the contact normals
    carry the sliding directions, where lower-dimensional free regions lie.
    """
    if not len(ti) or not len(tj):
        return _EMPTY
    ia, jb = np.nonzero(np.ones((len(ti), len(tj)), dtype=bool))
    return terms(ti, ni, tj, nj, ia, jb, eps)


_EMPTY = (np.zeros((0, 1, 3)), np.zeros((0, 3)))


# Tolerance (eps, the assembly's length tolerance). Near triangle pairs (boxes closer than
# 4 eps) are eroded: both triangles move inward by 1.5 eps along their normals, so contact
# never blocks by itself (see ndbg_cli.ndbg.infinite.build); far pairs use the exact triangles.
# Near pairs whose normals are not opposed within 45 degrees also have their edges on convex
# sharp part edges moved inward by 1.5 eps in their planes (ndbg_cli.ndbg.infinite.erosion
# says why); opposed pairs (faces in contact, flat or tessellated) move along their normals
# only. Not eroding angled pairs at all is no cure: tessellation overlaps at nuts' edges then
# block a real assembly everywhere.
# A term's facets are sought among the planes through two of its 9 generators
# t_j[v] - t_i[w] that share v or w (DIFFERENCE_PAIRS, 18 of 36).
def terms(ti: np.ndarray, ni: np.ndarray, tj: np.ndarray, nj: np.ndarray, ia: np.ndarray,
          jb: np.ndarray, eps: float, boxes: tuple[np.ndarray, ...] | None = None,
          cover: Cover | None = None,
          skip: Callable[[np.ndarray, np.ndarray], np.ndarray] | None = None,
          raw_circles: bool = False) -> tuple[np.ndarray, np.ndarray]:
    """The terms of the triangle pairs ``(ti[ia[k]], tj[jb[k]])`` that can face each other: open
    cones ``(p, k, 3)`` and the contact normals ``(c, 3)`` of the near pairs. ``boxes``: the
    triangles' bounding boxes ``(lo_i, hi_i, lo_j, hi_j)`` (each ``(n, 3)``), when the caller has
    them (a walk calls this hundreds of times on the same parts). ``cover``: what is kept so far (a
    non-empty :class:`~ndbg_cli.ndbg.infinite.cover.Cover`); the terms that miss every cell it
    leaves open are left out early, by its quick tests on the generators
    (:meth:`~ndbg_cli.ndbg.infinite.cover.Cover.misses_spanned_open`) before the facets are
    computed, then on the facets (:meth:`~ndbg_cli.ndbg.infinite.cover.Cover.misses_open`), made
    pair by pair in :func:`ndbg_cli.kernels._term_kernels.terms`. ``skip``: a function of
    ``(ia, jb)`` giving the pairs to keep (after the contact normals are taken); ``raw_circles``:
    the contact normals as they are, not deduplicated (a walk deduplicates them once, at its
    end)."""
    term_kernels = loaded("_term_kernels")
    if not len(ia):
        return _EMPTY
    # Facing prune: some vertex of t_j in front of t_i's plane and some vertex of t_i in front
    # of t_j's plane (lenient by 2 eps; an empty cone is harmless). Near: boxes within 4 eps.
    lo_i, hi_i, lo_j, hi_j = boxes if boxes is not None else triangle_boxes(ti, tj)
    ok, near = term_kernels.facing_pairs(ti, ni, tj, nj, ia, jb, eps, lo_i, hi_i, lo_j,
                                         hi_j)
    ia, jb, near = ia[ok], jb[ok], near[ok]
    if not len(ia):
        return _EMPTY
    circles = np.concatenate([ni[ia[near]], nj[jb[near]]])
    circles = circles if raw_circles else unique_circles(circles)
    if skip is not None:
        keep = skip(ia, jb)
        ia, jb, near = ia[keep], jb[keep], near[keep]
        if not len(ia):
            return _EMPTY[0], circles
    # the far pairs first, then the near ones (the order the cones are listed in)
    order = np.concatenate([np.nonzero(~near)[0], np.nonzero(near)[0]])
    ia, jb, near = ia[order], jb[order], near[order]
    if cover is not None:
        corners, sides = cover.pyramids()
    else:
        corners = sides = np.zeros((0, 4, 3))
    pa, pb = DIFFERENCE_PAIRS
    di, gi = insets(ti, ni, 1.5 * eps)
    dj, gj = insets(tj, nj, 1.5 * eps)
    cones = stack_cones([
        term_kernels.terms(ti, ni, tj, nj, ia[s:s + CHUNK], jb[s:s + CHUNK], near[s:s + CHUNK],
                           eps, pa, pb, 1e-9, FLAT, cover is not None, corners, sides, di, gi,
                           dj, gj)[0]
        for s in range(0, len(ia), CHUNK)])
    return cones, circles


#: Parts whose :func:`insets` and triangle boxes are kept (a walk asks for the same two parts
#: hundreds of times, and every pair's walk for its two parts').
INSET_MEMO = 64
_INSETS: dict[int, tuple] = {}
_BOXES: dict[int, tuple] = {}


def _kept_for(memo: dict, arrays: tuple, extra: object, make: Callable[[], object]
              ) -> object:
    """``make()``, kept in ``memo`` for the same ``arrays`` (by identity: do not change
    them in place) and ``extra``, up to :data:`INSET_MEMO` entries."""
    got = memo.get(id(arrays[0]))
    if got is not None and all(a is b for a, b in zip(got[0], arrays)) and got[1] == extra:
        return got[2]
    if len(memo) >= INSET_MEMO:
        memo.clear()
    out = make()
    memo[id(arrays[0])] = (arrays, extra, out)
    return out


def insets(tri: np.ndarray, nrm: np.ndarray, r: float) -> tuple[np.ndarray, np.ndarray]:
    """:func:`ndbg_cli.ndbg.infinite.erosion.edge_insets` of one part's triangles, kept for the same
    arrays (by identity) and ``r``."""
    return _kept_for(_INSETS, (tri, nrm), r, lambda: edge_insets(tri, nrm, r))


def _boxes(tri: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The bounding boxes ``(lo, hi)`` of one part's triangles, kept for the same array."""
    return _kept_for(_BOXES, (tri,), None, lambda: (tri.min(axis=1), tri.max(axis=1)))


def triangle_boxes(ti: np.ndarray, tj: np.ndarray) -> tuple[np.ndarray, ...]:
    """``(lo_i, hi_i, lo_j, hi_j)``: the bounding boxes ``(n, 3)`` of two triangle sets."""
    return ti.min(axis=1), ti.max(axis=1), tj.min(axis=1), tj.max(axis=1)


#: Two rows of a cone at least this anti-parallel (``m . m' <= -1 + FLAT``) make it flat:
#: its open set lies in a wedge narrower than ``sqrt(2 FLAT)`` (1.4e-7 rad), where the open
#: test (``OPEN_TOL`` = 1e-6 inside every facet) accepts no direction.
FLAT = 1e-14


def flat(cones: np.ndarray) -> np.ndarray:
    """``(p,)`` whether each cone ``(p, k, 3)`` (unit or zero rows) has two anti-parallel rows
    within :data:`FLAT`: an empty open set. Coplanar faces of two parts make such terms (the
    generators of ``t_j - t_i`` in one plane, or ``n_i = n_j``); they can be about half of
    all terms, and being lines across a whole face, the cover could never prune them."""
    kernels = loaded("_cone_kernels")
    if not len(cones):
        return np.zeros(0, dtype=bool)
    return kernels.flat(np.ascontiguousarray(cones, dtype=float), FLAT)


def stack_cones(parts: list[np.ndarray]) -> np.ndarray:
    """Concatenate cone batches of different widths, zero-padded (a single batch is
    returned as it is)."""
    parts = [p for p in parts if len(p)]
    if not parts:
        return np.zeros((0, 1, 3))
    if len(parts) == 1:
        return parts[0]
    width = max(p.shape[1] for p in parts)
    out = np.zeros((sum(len(p) for p in parts), width, 3))
    at = 0
    for p in parts:
        out[at:at + len(p), :p.shape[1]] = p
        at += len(p)
    return out


def unique_circles(normals: np.ndarray) -> np.ndarray:
    """Deduplicate great circles given by normals ``(c, 3)`` (``n`` and ``-n`` are one)."""
    if not len(normals):
        return np.zeros((0, 3))
    n = normals / np.linalg.norm(normals, axis=1, keepdims=True)
    first = np.argmax(np.abs(n) > 1e-12, axis=1)
    sign = np.sign(n[np.arange(len(n)), first])
    n = n * sign[:, None]
    # each rounded row's first occurrence, as np.unique(axis=0, return_index=True) finds it
    # (a stable sort on the three columns; unique's structured-row sort is slower)
    q = np.round(n, 9)
    order = np.lexsort((q[:, 2], q[:, 1], q[:, 0]))
    qs = q[order]
    new = np.r_[True, np.any(qs[1:] != qs[:-1], axis=1)]
    return n[np.sort(order[new])]


def pruned_pair_cones(ti: np.ndarray, ni: np.ndarray, tree_i: TriTree, tj: np.ndarray,
                      nj: np.ndarray, tree_j: TriTree, eps: float, stats: dict | None = None,
                      domain: np.ndarray | None = None, pieces: list | None = None
                      ) -> tuple[np.ndarray, np.ndarray]:
    """The terms of ``B_ij`` that the union needs: the same set as :func:`pair_cones`, as
    open cones ``(p, k, 3)``, and the same contact normals.

    Pruning is exact. Each part's triangles are in a bounding-box tree (:func:`tri_tree`).
    Every term of a node pair lies in the cone spanned by ``box_j - box_i`` (grown by the
    erosion margin; its facets among the 12 box edges, ``BOX_EDGE_PAIRS``); if that cone is
    inside the union of the kept terms, each eroded by
    :data:`~ndbg_cli.ndbg.infinite.cover.SHRINK` chart units, the node pair adds nothing.
    "Inside" is decided conservatively on a raster per cube face
    (:class:`~ndbg_cli.ndbg.infinite.cover.Cover`), at a cost independent of the number of
    kept terms; a new term inside it is dropped the same way on the whole sphere. So the
    kept terms' union equals ``B_ij``, both as a closed chart set and as a union of open cones
    (which the open-set re-test of ``BlockedSets`` relies on). Node pairs within ``4 eps``
    (contacts) are never pruned, so the contact circles are complete. The walk is
    breadth-first; each surviving node pair first contributes the term of its two largest
    triangles (filling the union from inside), surviving leaf pairs (at most
    :data:`~ndbg_cli.ndbg.infinite.tritree.LEAF` triangles a side) all their terms. Flat terms
    (:func:`flat`) are dropped as they are made.

    With a domain, the cells outside it count as covered from the start (near node pairs included),
    and the union is right inside the domain only. Its near leaf pairs are emitted before the walk;
    most terms there miss every open cell and are dropped by the cover's quick tests before their
    facets are computed or clipped; the unions are made in the domain's windows, where
    :func:`_new_pieces_of` and :meth:`_Walk._open_sides` drop terms and triangles that add nothing
    (the trees have larger leaves, :data:`ndbg_cli.ndbg.infinite.pair_workers.DOMAIN_LEAF`).

    ``stats`` (if given) receives counts of node pairs tested and terms computed and kept. With
    ``domain`` (``(6, c, c)`` bool cells of the cube map, :mod:`ndbg_cli.ndbg.infinite.domain`) the
    union is right only inside the domain cells: nothing is computed for the others; then ``pieces``
    (a list, if given) receives per face the kept terms' chart pieces in the domain's window
    (``None`` where there is none), as :func:`~ndbg_cli.ndbg.infinite.chart_union.union_pieces`
    takes them: the walk clipped them already."""
    if not len(ti) or not len(tj):
        return _EMPTY
    walk = _Walk(ti, ni, tree_i, tj, nj, tree_j, eps, domain)
    # With a domain (small caps around the directions where contacts leave something free),
    # the near leaf pairs go first: they are pruned only when wholly outside it, and their
    # terms (a contact's lunes and half-spaces) block whole caps, so most far pairs are then
    # pruned (see benchmarks/NOTES.md). On the whole sphere their terms are mostly slivers
    # along the contact circles that cover no cell, and the breadth-first order prunes as well.
    near_first = domain is not None
    if near_first:
        a, b = _near_leaves(tree_i, tree_j, eps)
        for s in range(0, len(a), LEAF_CHUNK):
            walk.emit(*_leaf_pairs(tree_i, tree_j, *walk.prune(a[s:s + LEAF_CHUNK],
                                                               b[s:s + LEAF_CHUNK])))
    a = np.zeros(1, dtype=np.int64)
    b = np.zeros(1, dtype=np.int64)
    while len(a):
        a, b = walk.prune(a, b)
        # the two largest triangles of every node pair first: they fill the union from inside
        walk.emit(np.repeat(tree_i.big[a], 2, axis=1).ravel(),
                  np.tile(tree_j.big[b], (1, 2)).ravel())
        a, b = walk.prune(a, b)
        leaf = (tree_i.left[a] < 0) & (tree_j.left[b] < 0)
        if near_first:  # those are done
            leaf_todo = leaf & (_gap(tree_i, tree_j, a, b) > 4 * eps)
        else:
            leaf_todo = leaf
        la, lb = a[leaf_todo], b[leaf_todo]
        for s in range(0, len(la), LEAF_CHUNK):
            ca, cb = walk.prune(la[s:s + LEAF_CHUNK], lb[s:s + LEAF_CHUNK])
            walk.emit(*_leaf_pairs(tree_i, tree_j, ca, cb))
        a, b = _split(tree_i, tree_j, a[~leaf], b[~leaf])
    if stats is not None:
        stats.update(walk.stats)
    if pieces is not None and walk.windows is not None:
        pieces.extend(None if rect is None else kp.arrays()
                      for rect, kp in zip(walk.windows, walk.pieces))
    cones = stack_cones(walk.kept)
    circ = unique_circles(np.concatenate(walk.circles)) if walk.circles else np.zeros((0, 3))
    return cones, circ


def _gap(tree_i: TriTree, tree_j: TriTree, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """``(p,)`` the gap between the boxes of the node pairs ``(a[k], b[k])`` (the largest
    separation along an axis; ``<= 0`` when they overlap), model units."""
    return np.maximum(tree_j.lo[b] - tree_i.hi[a], tree_i.lo[a] - tree_j.hi[b]).max(axis=1)


def _split(tree_i: TriTree, tree_j: TriTree, a: np.ndarray, b: np.ndarray
           ) -> tuple[np.ndarray, np.ndarray]:
    """The children of the inner node pairs ``(a[k], b[k])``: the node with the larger box is
    split (a leaf never is)."""
    size_i = np.linalg.norm(tree_i.hi[a] - tree_i.lo[a], axis=1)
    size_j = np.linalg.norm(tree_j.hi[b] - tree_j.lo[b], axis=1)
    split_i = (tree_i.left[a] >= 0) & ((size_i >= size_j) | (tree_j.left[b] < 0))
    return (np.concatenate([tree_i.left[a[split_i]], tree_i.right[a[split_i]],
                            a[~split_i], a[~split_i]]),
            np.concatenate([b[split_i], b[split_i],
                            tree_j.left[b[~split_i]], tree_j.right[b[~split_i]]]))


def _near_leaves(tree_i: TriTree, tree_j: TriTree, eps: float
                 ) -> tuple[np.ndarray, np.ndarray]:
    """The leaf pairs whose boxes are within ``4 eps`` of each other (every ancestor pair of
    such a pair is as near)."""
    a = np.zeros(1, dtype=np.int64)
    b = np.zeros(1, dtype=np.int64)
    out_a, out_b = [], []
    while len(a):
        near = _gap(tree_i, tree_j, a, b) <= 4 * eps
        a, b = a[near], b[near]
        leaf = (tree_i.left[a] < 0) & (tree_j.left[b] < 0)
        out_a.append(a[leaf])
        out_b.append(b[leaf])
        a, b = _split(tree_i, tree_j, a[~leaf], b[~leaf])
    return np.concatenate(out_a), np.concatenate(out_b)


#: Leaf pairs whose terms are computed between two updates of the cover.
LEAF_CHUNK = 64


class _Walk:
    """State of one pruning walk: the kept terms, the contact normals and the :class:`Cover`
    of the kept terms."""

    def __init__(self, ti, ni, tree_i, tj, nj, tree_j, eps: float,
                 domain: np.ndarray | None = None) -> None:
        self.ti, self.ni, self.tree_i = ti, ni, tree_i
        self.tj, self.nj, self.tree_j = tj, nj, tree_j
        self.eps = eps
        self.boxes = (*_boxes(ti), *_boxes(tj))
        self.kept: list[np.ndarray] = []
        self.circles: list[np.ndarray] = []
        self.cover = Cover(domain=domain)
        # with a domain, each kept term's chart pieces in its windows (what the union takes):
        # a new term whose pieces all lie inside single kept pieces adds nothing there
        self.windows = None if domain is None else domain_windows(domain)
        self.pieces: list = [_Pieces() for _ in range(6)]
        # the domain alone (never updated): near node pairs wholly outside it are dropped too
        self.outside = None if domain is None else domain_cover(domain)
        self.stats = {"node_pairs": 0, "terms": 0, "kept": 0, "side_skipped": 0}
        # per triangle: its facing half-space's window pieces lie inside kept pieces
        # (True stays True), and the number of kept pieces when that was last tested
        self.side_in = (np.zeros(len(ti), dtype=bool), np.zeros(len(tj), dtype=bool))
        self.side_at = (np.zeros(len(ti), dtype=np.int64), np.zeros(len(tj), dtype=np.int64))

    def _open_sides(self, ia: np.ndarray, jb: np.ndarray) -> np.ndarray:
        """``(p,)`` whether each triangle pair ``(ia[k], jb[k])`` may still add to the unions
        in the windows: neither facing half-space (``n_i . d > 0``, ``-n_j . d > 0``, which
        hold the pair's term) has all its window pieces inside single kept pieces. A term
        lies in its two facing half-spaces, so such a triangle adds nothing with any partner:
        its pairs are left out before their terms are made (the contact faces' far pairs made
        tens of thousands of terms whose window piece was the same half-window)."""
        total = sum(kp.n for kp in self.pieces)
        if not total:
            return np.ones(len(ia), dtype=bool)
        for side, (idx, nrm, sign) in enumerate(((ia, self.ni, 1.0), (jb, self.nj, -1.0))):
            inside, at = self.side_in[side], self.side_at[side]
            seen = np.zeros(len(inside), dtype=bool)
            seen[idx] = True
            # tested again once the kept pieces have doubled since
            u = np.flatnonzero(seen & ~inside & (total >= 2 * at))
            if len(u):
                inside[u] = _window_pieces(self, sign * nrm[u][:, None, :])[0]
                at[u] = total
        keep = ~(self.side_in[0][ia] | self.side_in[1][jb])
        self.stats["side_skipped"] += len(keep) - int(keep.sum())
        return keep

    def prune(self, a: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Drop the node pairs ``(a[k], b[k])`` whose box cone is inside the cover. Boxes around the
        origin are kept, and so are near node pairs (gap <= 4 eps) unless the box cone lies wholly
        outside the domain (:func:`~ndbg_cli.kernels._term_kernels.prune_pairs`)."""
        term_kernels = loaded("_term_kernels")
        if not len(a) or self.cover.empty:
            return a, b
        ti, tj = self.tree_i, self.tree_j
        # near pairs' terms and contact circles only matter inside the domain: a seam there
        # lies between terms there, whose near pairs are kept
        use_out = self.outside is not None and not self.outside.empty
        cover = self.cover._windows()
        keep, nfar = term_kernels.prune_pairs(
            a, b, ti.lo, ti.hi, tj.lo, tj.hi, self.eps, *BOX_EDGE_PAIRS, cover, True,
            self.outside._windows() if use_out else cover, use_out)
        self.stats["node_pairs"] += nfar
        return a[keep], b[keep]

    def emit(self, ia: np.ndarray, jb: np.ndarray) -> None:
        """Compute the terms of the triangle pairs ``(ia[k], jb[k])``; keep those not already
        inside the cover (on the whole sphere) or inside single kept pieces in the windows
        (with a domain, :func:`_new_pieces_of`), and add them to the cover."""
        cones, circ = terms(self.ti, self.ni, self.tj, self.nj, ia, jb, self.eps,
                            boxes=self.boxes, cover=None if self.cover.empty else self.cover,
                            skip=None if self.windows is None else self._open_sides,
                            raw_circles=True)
        self.stats["terms"] += len(cones)
        if len(circ):
            self.circles.append(circ)
        if not len(cones):
            return
        if not self.cover.empty and self.windows is None:
            cones = cones[~self.cover.covers(cones)]
            if not len(cones):
                return
        if self.windows is not None:
            cones = _new_pieces_of(self, cones)
            if not len(cones):
                return
        self.kept.append(cones)
        self.stats["kept"] += len(cones)
        self.cover.add(cones)


class _Pieces:
    """The chart pieces ``(n, w, 2)`` (counter-clockwise), vertex counts, areas, boxes and
    cone indices (among the kept terms) of the terms a walk kept, on one face's window, in
    arrays grown by doubling."""

    WIDTH = 48

    def __init__(self) -> None:
        self.n = 0
        self.poly = np.zeros((0, self.WIDTH, 2))
        self.cnt = np.zeros(0, dtype=np.int64)
        self.area = np.zeros(0)
        self.boxes = np.zeros((0, 4))
        self.index = np.zeros(0, dtype=np.int64)

    def add(self, poly: np.ndarray, cnt: np.ndarray, area: np.ndarray, boxes: np.ndarray,
            index: np.ndarray) -> None:
        m = self.n + len(cnt)
        if m > len(self.cnt):
            size = max(m, 2 * len(self.cnt), 64)
            grown = np.zeros((size, self.WIDTH, 2))
            grown[:self.n] = self.poly[:self.n]
            self.poly = grown
            self.cnt, self.area, self.boxes, self.index = (
                np.concatenate([a[:self.n], np.zeros((size - self.n, *a.shape[1:]), a.dtype)])
                for a in (self.cnt, self.area, self.boxes, self.index))
        self.poly[self.n:m, :poly.shape[1]] = poly
        self.cnt[self.n:m] = cnt
        self.area[self.n:m] = area
        self.boxes[self.n:m] = boxes
        self.index[self.n:m] = index
        self.n = m

    def arrays(self) -> tuple[np.ndarray, ...]:
        """``(poly, cnt, area, boxes, index)`` of the pieces, as
        :func:`~ndbg_cli.ndbg.infinite.chart_union.union_pieces` takes them."""
        n = self.n
        return self.poly[:n], self.cnt[:n], self.area[:n], self.boxes[:n], self.index[:n]


def _window_pieces(walk: _Walk, cones: np.ndarray) -> tuple[np.ndarray, list]:
    """The chart pieces of ``cones`` in the walk's windows: ``(inside, found)``, whether each
    cone's pieces all lie inside single pieces kept so far (or have area at most
    ``GRID**2``), and per face with some piece ``(face, poly, cnt, area, boxes, has)``
    (:func:`~ndbg_cli.ndbg.infinite.chart_union.clipped_pieces`)."""
    kernels = loaded("_union_kernels")
    inside = np.ones(len(cones), dtype=bool)
    found = []
    for face, rect in enumerate(walk.windows):
        if rect is None:
            continue
        poly, cnt, area, boxes, has = clipped_pieces(cones, face, rect, _Pieces.WIDTH)
        if not has.any():
            continue
        kp = walk.pieces[face]
        inside &= ~has | kernels.inside_kept(poly, cnt, boxes, has, kp.poly, kp.cnt,
                                             kp.boxes, kp.n)
        found.append((face, poly, cnt, area, boxes, has))
    return inside, found


def _new_pieces_of(walk: _Walk, cones: np.ndarray) -> np.ndarray:
    """The terms among ``cones`` with a chart piece (of area above ``GRID**2``) in some
    window of the walk's domain that lies inside no single piece kept so far; their pieces
    are kept. The others add nothing to the unions, which are made in those windows only
    (:func:`~ndbg_cli.ndbg.infinite.chart_union.cones_to_face_geoms`). Without this test a
    contact's fan of wedges round a free axis keeps several times more terms (numbers in
    benchmarks/NOTES.md)."""
    inside, found = _window_pieces(walk, cones)
    keep = ~inside
    # the kept terms' indices among all those the walk keeps
    index = walk.stats["kept"] + np.cumsum(keep) - 1
    for face, poly, cnt, area, boxes, has in found:
        sel = has & keep
        if sel.any():
            walk.pieces[face].add(poly[sel], cnt[sel], area[sel], boxes[sel], index[sel])
    return cones[keep]


def _leaf_pairs(tree_i: TriTree, tree_j: TriTree, a: np.ndarray, b: np.ndarray
                ) -> tuple[np.ndarray, np.ndarray]:
    """All triangle index pairs of the leaf pairs ``(a[k], b[k])``."""
    if not len(a):
        return np.zeros(0, dtype=np.int64), np.zeros(0, dtype=np.int64)
    na = tree_i.stop[a] - tree_i.start[a]
    nb = tree_j.stop[b] - tree_j.start[b]
    pair, off = run_offsets(na * nb)
    ka, kb = off // nb[pair], off % nb[pair]
    return (tree_i.perm[tree_i.start[a][pair] + ka], tree_j.perm[tree_j.start[b][pair] + kb])

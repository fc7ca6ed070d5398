"""The compiled kernels (:mod:`ndbg_cli.kernels._cone_kernels`,
:mod:`ndbg_cli.kernels._cover_kernels`) against the numpy code they replaced, kept here as the
reference: the same counts, flags and bits (vertices up to each polygon's count; sign bits of zeros
included where the values are outputs)."""

from __future__ import annotations

import numpy as np
import pytest

from ndbg_cli.kernels import _cover_kernels as cover_kernels
from ndbg_cli.kernels._cone_kernels import FACES
from ndbg_cli.ndbg.infinite.arrangement import circle_crossings
from ndbg_cli.ndbg.infinite.blocking_cones import unique_circles
from ndbg_cli.ndbg.infinite.cover import Cover, run_offsets
from ndbg_cli.ndbg.infinite.cubemap import (
    BOX_EDGE_PAIRS,
    DIFFERENCE_PAIRS,
    SQUARE_MARGIN,
    clip_halfplanes,
    compact,
    cone_normals,
)


def _same(a: np.ndarray, b: np.ndarray) -> bool:
    return a.shape == b.shape and np.array_equal(a, b) and \
        np.array_equal(np.signbit(a), np.signbit(b))


# --- the numpy references -------------------------------------------------------------------

def _ref_clip(normals, face, max_vertices=48, shrink=0.0, rect=None):
    e, u, v = FACES[face]
    r = 1.0 + SQUARE_MARGIN
    x0, y0, x1, y1 = (-r, -r, r, r) if rect is None else rect
    sq = np.array([[x0, y0], [x1, y0], [x1, y1], [x0, y1]])
    coef = np.stack([normals @ u, normals @ v, normals @ e], axis=2)
    if shrink > 0.0:
        coef[:, :, 2] -= shrink * np.hypot(coef[:, :, 0], coef[:, :, 1])
    at = coef[:, :, :1] * sq[:, 0] + coef[:, :, 1:2] * sq[:, 1] + coef[:, :, 2:3]
    hit = np.nonzero(~np.any(np.all(at < 0.0, axis=2), axis=1))[0]
    coef = coef[hit]
    p = len(coef)
    poly = np.broadcast_to(sq, (p, 4, 2)).copy()
    count = np.full(p, 4, dtype=np.int64)
    for k in range(coef.shape[1]):
        c = coef[:, k]
        idx = np.nonzero(np.any(c != 0.0, axis=1) & (count >= 3))[0]
        pi, ci = poly[idx], c[idx]
        f = pi[:, :, 0] * ci[:, :1] + pi[:, :, 1] * ci[:, 1:2] + ci[:, 2:3]
        valid = np.arange(pi.shape[1])[None, :] < count[idx][:, None]
        out = ~np.any(valid & (f >= 0), axis=1)
        count[idx[out]] = 0
        cut = ~out & np.any(valid & (f < 0), axis=1)
        if not cut.any():
            continue
        pc, cc, fa = pi[cut], count[idx[cut]], f[cut]
        m = pc.shape[1]
        kk = np.arange(m)[None, :]
        ok_v = kk < cc[:, None]
        nxt = np.where(kk + 1 < cc[:, None], kk + 1, 0)
        q = np.take_along_axis(pc, nxt[:, :, None].repeat(2, axis=2), axis=1)
        fb = np.take_along_axis(fa, nxt, axis=1)
        keep_a = ok_v & (fa >= 0)
        cross = ok_v & (((fa >= 0) & (fb < 0)) | ((fa < 0) & (fb >= 0)))
        w = np.where(cross, fa / np.where(cross, fa - fb, 1.0), 0.0)
        x = pc + w[:, :, None] * (q - pc)
        cand = np.stack([pc, x], axis=2).reshape(len(pc), 2 * m, 2)
        ok = np.stack([keep_a, cross], axis=2).reshape(len(pc), 2 * m)
        order = np.argsort(~ok, axis=1, kind="stable")
        cand = np.take_along_axis(cand, order[:, :, None].repeat(2, axis=2), axis=1)
        cnt = ok.sum(axis=1)
        sub = cand[:, :max(int(cnt.max()), 1)]
        i2 = idx[cut]
        if sub.shape[1] > poly.shape[1]:
            poly = np.concatenate([poly, np.zeros((p, sub.shape[1] - poly.shape[1], 2))], 1)
        poly[i2, :sub.shape[1]] = sub
        poly[i2, sub.shape[1]:] = 0.0
        count[i2] = cnt
        poly = poly[:, :max_vertices]
    full = np.zeros((len(normals), poly.shape[1], 2))
    cnt_full = np.zeros(len(normals), dtype=np.int64)
    full[hit], cnt_full[hit] = poly, count
    return full, cnt_full


def _ref_cone_normals(gens, pairs):
    a, b = pairs
    n = np.cross(gens[:, a], gens[:, b])
    norm = np.linalg.norm(n, axis=2, keepdims=True)
    scale = np.linalg.norm(gens, axis=2)
    big = scale.max(axis=1)[:, None, None]
    valid = norm > 1e-12 * big * big
    n = np.where(valid, n / np.where(valid, norm, 1.0), 0.0)
    dots = np.einsum("pqk,pgk->pqg", n, gens)
    lim = 1e-9 * scale[:, None, :]
    pos, neg = np.all(dots >= -lim, axis=2), np.all(dots <= lim, axis=2)
    out = n * np.where(pos, 1.0, np.where(neg, -1.0, 0.0))[:, :, None]
    both = pos & neg & valid[:, :, 0]
    if both.any():
        out = np.concatenate([out, np.where(both[:, :, None], -n, 0.0)], axis=1)
    return out


def _ref_compact(normals):
    nonzero = np.any(normals != 0.0, axis=2)
    width = max(int(nonzero.sum(axis=1).max()), 1)
    if width < normals.shape[1]:
        first = np.argsort(~nonzero, axis=1, kind="stable")[:, :width]
        normals = np.take_along_axis(normals, first[:, :, None].repeat(3, axis=2), axis=1)
    key = np.round(normals @ np.array([1.0, np.pi, np.e]) * 1e9)
    q = np.round(normals * 1e9)
    order = np.lexsort((q[:, :, 2], q[:, :, 1], q[:, :, 0], key), axis=1)
    key = np.take_along_axis(key, order, axis=1)
    q = np.take_along_axis(q, order[:, :, None].repeat(3, axis=2), axis=1)
    nm = np.take_along_axis(normals, order[:, :, None].repeat(3, axis=2), axis=1)
    dup = np.zeros_like(key, dtype=bool)
    dup[:, 1:] = (key[:, 1:] == key[:, :-1]) & np.all(q[:, 1:] == q[:, :-1], axis=2)
    drop = dup | ~np.any(nm != 0.0, axis=2)
    order = np.argsort(drop, axis=1, kind="stable")
    nm = np.take_along_axis(nm, order[:, :, None].repeat(3, axis=2), axis=1)
    width = max(int((~drop).sum(axis=1).max()), 1)
    keep = np.take_along_axis(~drop, order, axis=1)[:, :width]
    return np.where(keep[:, :, None], nm[:, :width], 0.0)


def _gens(rng: np.random.Generator, p: int, flat_share: bool) -> np.ndarray:
    """Generators of triangle-pair terms ``(p, 9, 3)``; with ``flat_share`` integer-valued
    and partly coplanar (the degenerate facets of an axis-aligned assembly)."""
    ti = rng.normal(size=(p, 3, 3))
    tj = rng.normal(size=(p, 3, 3)) + 2.0 * rng.normal(size=3)
    if flat_share:
        ti, tj = np.round(ti), np.round(tj)
        ti[:, :, 2] = 0.0
        tj[:, :, 2] = np.where(rng.random((p, 1)) < 0.5, 0.0, 1.0)
    return (tj[:, :, None, :] - ti[:, None, :, :]).reshape(p, 9, 3)


# --- the tests --------------------------------------------------------------------------------

@pytest.mark.parametrize("seed", range(4))
def test_clip_matches_numpy(seed: int) -> None:
    rng = np.random.default_rng(seed)
    for trial in range(30):
        p, k = int(rng.integers(1, 150)), int(rng.integers(1, 12))
        n = rng.normal(size=(p, k, 3))
        n /= np.linalg.norm(n, axis=2, keepdims=True)
        n[rng.random((p, k)) < 0.2] = 0.0
        if trial % 3 == 0:  # repeated and opposite rows, rounded: degenerate cuts
            n[:, 1:] = np.where(rng.random((p, k - 1, 1)) < 0.3, -n[:, :1], n[:, 1:])
            n = np.round(n, 3)
        kw = {"max_vertices": [48, k + 4][trial % 2], "shrink": [0.0, 1e-5][trial % 2],
              "rect": None if trial % 4 else (-0.3, -1.0, 0.7, 0.2)}
        face = int(rng.integers(6))
        a, ca = _ref_clip(n, face, **kw)
        b, cb = clip_halfplanes(n, face, **kw)
        assert a.shape == b.shape and np.array_equal(ca, cb)
        for i in np.flatnonzero(ca):
            assert np.array_equal(a[i, :ca[i]], b[i, :cb[i]])


@pytest.mark.parametrize("k", [1, 3, 7, 8, 9, 16, 27, 40])
def test_fused_clip_matches_numpy_products(k: int) -> None:
    """The cone-by-cone chart half-planes of :func:`ndbg_cli.kernels._cone_kernels.clip_cones`
    (three products and a hypot per row) against the whole-array matmuls of the numpy reference,
    for cones of every width the walk makes: the same clipped polygons, bit for bit."""
    rng = np.random.default_rng(k)
    n = rng.normal(size=(300, k, 3))
    n /= np.linalg.norm(n, axis=2, keepdims=True)
    n[rng.random((300, k)) < 0.2] = 0.0
    for face in range(6):
        for shrink in (0.0, 1e-5):
            kw = {"shrink": shrink, "rect": (-0.4, -0.3, 0.5, 0.6)}
            a, ca = _ref_clip(n, face, **kw)
            b, cb = clip_halfplanes(n, face, **kw)
            assert np.array_equal(ca, cb)
            for i in np.flatnonzero(ca):
                assert _same(a[i, :ca[i]], b[i, :cb[i]])


@pytest.mark.parametrize("flat_share", [False, True])
def test_cone_normals_and_compact_match_numpy(flat_share: bool) -> None:
    rng = np.random.default_rng(int(flat_share))
    for _ in range(10):
        gens = _gens(rng, int(rng.integers(1, 2000)), flat_share)
        m = cone_normals(gens, pairs=DIFFERENCE_PAIRS)
        assert _same(m, _ref_cone_normals(gens, DIFFERENCE_PAIRS))
        assert _same(compact(m), _ref_compact(m))


def test_cover_tests_match_numpy() -> None:
    """covers, covers_spanned and misses_spanned_open against their numpy versions on a
    cover filled step by step (the flags that decide which terms the walk keeps)."""
    rng = np.random.default_rng(7)
    corners = np.array([[x, y, z] for x in (0, 1) for y in (0, 1) for z in (0, 1)], bool)
    seen = [0, 0]
    for t in range(12):
        cover = Cover(domain=rng.random((6, 8, 8)) < rng.random() if t % 2 else None)
        for _ in range(4):
            gens = _gens(rng, int(rng.integers(1, 300)), False)
            cones = compact(cone_normals(gens, pairs=DIFFERENCE_PAIRS))
            if not cover.empty:
                ref = np.ones(len(cones), dtype=bool)
                for face in range(6):
                    if cover.window(face) is None:
                        continue
                    poly, cnt = _ref_clip(cones, face, rect=cover.window(face))
                    for i in np.flatnonzero(cnt >= 3):
                        lo, hi = poly[i, :cnt[i]].min(axis=0), poly[i, :cnt[i]].max(axis=0)
                        ref[i] &= _box_ref(cover, face, lo, hi)
                got = cover.covers(cones)
                assert np.array_equal(got, ref)
                seen[0] += got.sum()
                lo = rng.normal(size=(len(cones), 3)) * 3
                hi = lo + rng.random((len(cones), 3)) * rng.random() * 3
                box = np.where(corners[None], hi[:, None], lo[:, None])
                got = cover.covers_spanned(box, pairs=BOX_EDGE_PAIRS)
                assert np.array_equal(got, _ref_spanned(cover, box))
                seen[1] += got.sum()
                facing = rng.normal(size=(len(gens), 2, 3))
                ref = np.ones(len(gens), dtype=bool)
                for face in range(6):
                    pyr = cover._window_pyramid(face)
                    if pyr is not None:
                        miss = (gens @ pyr[1].T < 0.0).all(axis=1).any(axis=1)
                        ref &= miss | (facing @ pyr[0].T <= 0.0).all(axis=2).any(axis=1)
                assert np.array_equal(cover.misses_spanned_open(gens, facing), ref)
            cover.add(cones)
    assert min(seen) > 0  # some cones are covered: the tests can fail


def _ref_terms(ti, ni, tj, nj, ia, jb, eps, near, cover):
    """The batched path the fused term kernel replaced: generators, the cover's quick tests,
    facets, compaction and the flat test, far pairs first; each cone's nonzero rows."""
    from ndbg_cli.ndbg.infinite.blocking_cones import flat

    out = []
    for sel in (np.nonzero(~near)[0], np.nonzero(near)[0]):
        if not len(sel):
            continue
        a, b = ia[sel], jb[sel]
        gens = (tj[b][:, :, None, :] - ti[a][:, None, :, :]).reshape(len(sel), 9, 3)
        if near[sel[0]]:
            gens = gens + (1.5 * eps * (ni[a] - nj[b]))[:, None, :]
        facing = np.stack([ni[a], -nj[b]], axis=1)
        if cover is not None:
            fresh = ~cover.misses_spanned_open(gens, facing)
            gens, facing = gens[fresh], facing[fresh]
        if not len(gens):
            continue
        m = cone_normals(gens, pairs=DIFFERENCE_PAIRS)
        if cover is not None:
            fresh = ~cover.misses_open(np.concatenate([m, facing], axis=1))
            m, facing = m[fresh], facing[fresh]
        if not len(m):
            continue
        cone = np.concatenate([compact(m), facing], axis=1)
        cone = cone[~flat(cone)]
        out.extend(c[np.any(c != 0.0, axis=1)] for c in cone)
    return out


@pytest.mark.parametrize("with_cover", [False, True])
def test_fused_terms_match_the_batched_path(with_cover: bool) -> None:
    """:func:`ndbg_cli.kernels._term_kernels.terms` against the batched kernels it replaced:
    the same cones in the same order, each with the same nonzero rows, bit for bit (touching,
    coplanar and parallel triangles included: flat terms and erosion)."""
    from ndbg_cli.kernels import _term_kernels as term_kernels
    from ndbg_cli.ndbg.infinite.blocking_cones import FLAT

    rng = np.random.default_rng(11 + with_cover)
    kept = 0
    for trial in range(6):
        ti = rng.normal(size=(40, 3, 3))
        tj = ti[rng.permutation(40)] + rng.normal(size=(40, 1, 3)) * [0.0, 0.5, 3.0][trial % 3]
        tj[:10] = ti[:10] + np.array([0.0, 0.0, 1e-3])  # nearly coplanar, nearly touching
        # translated copies (a row of identical bolts): parallel faces facing the same way,
        # flat terms the kernel drops before their facets
        tj[10:15] = ti[10:15] + rng.normal(size=(5, 1, 3))
        ni = np.cross(ti[:, 1] - ti[:, 0], ti[:, 2] - ti[:, 0])
        ni /= np.linalg.norm(ni, axis=1, keepdims=True)
        nj = np.cross(tj[:, 1] - tj[:, 0], tj[:, 2] - tj[:, 0])
        nj /= np.linalg.norm(nj, axis=1, keepdims=True)
        nj[:10] = -ni[:10]
        ia, jb = np.nonzero(np.ones((40, 40), dtype=bool))
        near = rng.random(len(ia)) < 0.3
        near[:40] = True
        cover = None
        if with_cover:
            cover = Cover(domain=rng.random((6, 8, 8)) < 0.4)
            cover.add(compact(cone_normals(_gens(rng, 50, False), pairs=DIFFERENCE_PAIRS)))
        want = _ref_terms(ti, ni, tj, nj, ia, jb, 1e-3, near, cover)
        order = np.concatenate([np.nonzero(~near)[0], np.nonzero(near)[0]])
        # no in-plane insets (ndbg_cli.ndbg.infinite.erosion): the reference moves triangles along
        # normals
        still = (np.zeros_like(ti), np.zeros(len(ti), dtype=bool), np.zeros_like(tj),
                 np.zeros(len(tj), dtype=bool))
        corners, sides = cover.pyramids() if cover is not None else (np.zeros((0, 4, 3)),) * 2
        got, p = term_kernels.terms(ti, ni, tj, nj, ia[order], jb[order], near[order], 1e-3,
                                    *DIFFERENCE_PAIRS, 1e-9, FLAT, cover is not None,
                                    corners, sides, *still)
        assert p == len(want) == len(got)
        for g, w in zip(got, want):
            assert _same(g[np.any(g != 0.0, axis=1)], w)
        kept += p
    assert kept > 0


def _box_ref(cover: Cover, face: int, lo: np.ndarray, hi: np.ndarray) -> bool:
    """Every raster cell meeting the chart box is covered (direct scan)."""
    r, h = cover.r, cover.h
    c0 = np.clip(np.floor((lo + 1.0) / h), 0, r - 1).astype(int)
    c1 = np.clip(np.floor((hi + 1.0) / h), 0, r - 1).astype(int)
    return bool(cover.covered[face, c0[1]:c1[1] + 1, c0[0]:c1[0] + 1].all())


def _ref_spanned(cover: Cover, gens: np.ndarray) -> np.ndarray:
    se = gens @ FACES[:, 0].T
    front = se > 0.0
    faces = [f for f in range(6) if cover.window(f) is not None]
    fw = front[:, :, faces]
    mixed = (fw.any(axis=1) & ~fw.all(axis=1)).any(axis=1)
    ok = np.ones(len(gens), dtype=bool)
    if mixed.any():
        m = _ref_compact(_ref_cone_normals(gens[mixed], BOX_EDGE_PAIRS))
        sub = np.ones(len(m), dtype=bool)
        for face in faces:
            poly, cnt = _ref_clip(m, face, rect=cover.window(face))
            for i in np.flatnonzero(cnt >= 3):
                lo, hi = poly[i, :cnt[i]].min(axis=0), poly[i, :cnt[i]].max(axis=0)
                sub[i] &= _box_ref(cover, face, lo, hi)
        ok[mixed] = sub
    for face in faces:
        e, u, v = FACES[face]
        for i in np.flatnonzero(~mixed & front[:, :, face].all(axis=1)):
            st = np.stack([gens[i] @ u, gens[i] @ v], axis=1) / se[i, :, face, None]
            lo, hi = st.min(axis=0), st.max(axis=0)
            if (hi >= -1.0).all() and (lo <= 1.0).all():
                ok[i] &= _box_ref(cover, face, lo, hi)
    return ok


def test_box_covered_reads_the_block_table() -> None:
    """A box's cells are all covered when its part in the block is (every cell outside the
    block is): the block's own summed-area table against the raster itself."""
    rng = np.random.default_rng(4)
    r, h = 64, 2.0 / 64
    block = np.array([20, 31, 7, 40])  # rows 20..30, columns 7..39
    cov = np.ones((r, r), dtype=bool)
    cov[20:31, 7:40] = rng.random((11, 33)) < 0.9
    sat = np.zeros((12, 34), dtype=np.int32)
    cover_kernels.update_sat(cov[20:31, 7:40], sat, 0)
    for _ in range(3000):
        lo = rng.uniform(-1.2, 1.0, size=2)
        hi = lo + rng.uniform(0.0, 0.4, size=2) ** 2
        c0, r0 = np.clip(np.floor((lo + 1.0) / h), 0, r - 1).astype(int)
        c1, r1 = np.clip(np.floor((hi + 1.0) / h), 0, r - 1).astype(int)
        want = cov[r0:r1 + 1, c0:c1 + 1].all()
        assert cover_kernels.box_covered(sat, block, lo[0], lo[1], hi[0], hi[1], h, r) == want


def test_window_kernels_match_numpy() -> None:
    """The windows of uncovered cells (:func:`~ndbg_cli.kernels._cover_kernels.open_window`)
    against :func:`~ndbg_cli.ndbg.infinite.cover.cells_window`, and their cones
    (:func:`~ndbg_cli.kernels._cover_kernels.window_pyramid`) against the numpy expressions
    they replaced, bit for bit."""
    from ndbg_cli.ndbg.infinite.cover import cells_window
    rng = np.random.default_rng(6)
    r = 64
    m = 1.0 + SQUARE_MARGIN
    for t in range(200):
        cov = np.ones((r, r), dtype=bool)
        b = np.sort(rng.integers(0, r + 1, size=2)), np.sort(rng.integers(0, r + 1, size=2))
        (r0, r1), (c0, c1) = b
        cov[r0:r1, c0:c1] = rng.random((r1 - r0, c1 - c0)) < (0.99 if t % 3 else 0.5)
        got = cover_kernels.open_window(cov, r0, r1, c0, c1, m)
        want = cells_window(~cov[r0:r1, c0:c1], r0, c0, r)
        assert (got[1:] if got[0] else None) == want
        if want is None:
            continue
        face = t % 6
        e, u, v = FACES[face]
        x0, y0, x1, y1 = want
        corners = np.array([e + x0 * u + y0 * v, e + x1 * u + y0 * v,
                            e + x1 * u + y1 * v, e + x0 * u + y1 * v])
        sides = np.cross(corners, np.roll(corners, -1, axis=0))
        centre = e + 0.5 * (x0 + x1) * u + 0.5 * (y0 + y1) * v
        sides = sides * np.sign(sides @ centre)[:, None]
        kc, ks = cover_kernels.window_pyramid(face, *want)
        assert _same(kc, corners) and _same(ks, sides)


def test_sat_updates_in_place() -> None:
    rng = np.random.default_rng(3)
    cov = rng.random((64, 64)) < 0.7
    sat = np.zeros((65, 65), dtype=np.int32)
    cover_kernels.update_sat(cov, sat, 0)
    cov[40:] = rng.random((24, 64)) < 0.5
    cover_kernels.update_sat(cov, sat, 40)
    ref = np.zeros_like(sat)
    ref[1:, 1:] = cov.cumsum(axis=0).cumsum(axis=1)
    assert np.array_equal(sat, ref)


def _ref_mark(covered, poly, cnt, h):
    """The numpy rasterisation :func:`ndbg_cli.kernels._cover_kernels.mark_cells` replaced."""
    r = covered.shape[0]
    m = poly.shape[1]
    k = np.arange(m)[None, :]
    valid = k < cnt[:, None]
    nxt = np.where(k + 1 < cnt[:, None], k + 1, 0)
    a = poly
    b = np.take_along_axis(poly, nxt[:, :, None].repeat(2, axis=2), axis=1)
    # A convex polygon holding a cell has inradius >= h / 2, and its inradius is at most
    # 2 area / perimeter: slivers, most of the terms, cover no cell and are skipped.
    area = 0.5 * np.abs(np.where(valid, a[:, :, 0] * b[:, :, 1] - a[:, :, 1] * b[:, :, 0],
                                 0.0).sum(axis=1))
    perim = np.where(valid, np.linalg.norm(b - a, axis=2), 0.0).sum(axis=1)
    fat = 4.0 * area >= h * perim
    if not fat.all():
        a, b, valid, poly = a[fat], b[fat], valid[fat], poly[fat]
        if not len(poly):
            return r
    ys = np.where(valid, poly[:, :, 1], np.nan)
    g0 = np.ceil((np.nanmin(ys, axis=1) + 1.0) / h).astype(np.int64)
    g1 = np.floor((np.nanmax(ys, axis=1) + 1.0) / h).astype(np.int64)
    g0, g1 = np.maximum(g0, 0), np.minimum(g1, r)
    nlines = np.maximum(g1 - g0 + 1, 0)
    if not (nlines >= 2).any():  # a band needs two grid lines inside the polygon
        return r
    owner, line = run_offsets(nlines)
    base = np.cumsum(nlines) - nlines
    left = np.full(len(owner), np.inf)
    right = np.full(len(left), -np.inf)
    # Each grid line meets a convex polygon in one edge going down (the left chain of a
    # counter-clockwise polygon) and one going up (the right chain): intersect per edge.
    pe, ke = np.nonzero(valid & (a[:, :, 1] != b[:, :, 1]))
    ya, yb = a[pe, ke, 1], b[pe, ke, 1]
    xa, xb = a[pe, ke, 0], b[pe, ke, 0]
    e0 = np.maximum(np.ceil((np.minimum(ya, yb) + 1.0) / h).astype(np.int64), g0[pe])
    e1 = np.minimum(np.floor((np.maximum(ya, yb) + 1.0) / h).astype(np.int64), g1[pe])
    edge, k = run_offsets(np.maximum(e1 - e0 + 1, 0))
    g = e0[edge] + k
    y = -1.0 + g * h
    x = xa[edge] + (y - ya[edge]) * ((xb - xa) / (yb - ya))[edge]
    slot = base[pe[edge]] + g - g0[pe[edge]]
    down = (yb < ya)[edge]
    np.minimum.at(left, slot[down], x[down])
    np.maximum.at(right, slot[~down], x[~down])
    g = g0[owner] + line
    # band [y_g, y_g+1] of one polygon: rows of consecutive lines of the same owner; a
    # convex polygon's cross-section there contains the intersection of the two ends'
    same = owner[1:] == owner[:-1]
    lo = np.maximum(left[1:], left[:-1])[same]
    hi = np.minimum(right[1:], right[:-1])[same]
    row = g[:-1][same]
    fin = np.isfinite(lo) & np.isfinite(hi) & (lo < hi)
    lo, hi, row = lo[fin], hi[fin], row[fin]
    c0 = np.ceil((lo + 1.0) / h).astype(np.int64)
    c1 = np.floor((hi + 1.0) / h).astype(np.int64)  # one past the last whole cell
    c0, c1 = np.maximum(c0, 0), np.minimum(c1, r)
    ok = (c1 > c0) & (row < r)
    if not ok.any():
        return r
    rows, slot = np.unique(row[ok], return_inverse=True)
    w = r + 1
    spans = np.bincount(slot * w + c0[ok], minlength=len(rows) * w) \
        - np.bincount(slot * w + c1[ok], minlength=len(rows) * w)
    inside = np.cumsum(spans.reshape(len(rows), w), axis=1)[:, :r] > 0
    covered[rows] |= inside
    return int(rows[0])
def test_mark_cells_by_hand() -> None:
    # an 8 x 8 raster (cells 0.25 wide): a square on grid lines holds its 4 x 4 cells
    cov = np.zeros((8, 8), dtype=bool)
    sq = np.array([[[-0.5, -0.5], [0.5, -0.5], [0.5, 0.5], [-0.5, 0.5]]])
    assert cover_kernels.mark_cells(sq, np.array([4]), 0.25, cov) == 2
    want = np.zeros((8, 8), dtype=bool)
    want[2:6, 2:6] = True
    assert np.array_equal(cov, want)
    # a diamond round the centre holds the four cells at its middle only
    cov[:] = False
    dia = np.array([[[0.0, -0.6], [0.6, 0.0], [0.0, 0.6], [-0.6, 0.0]]])
    cover_kernels.mark_cells(dia, np.array([4]), 0.25, cov)
    assert np.flatnonzero(cov.ravel()).tolist() == [27, 28, 35, 36]


@pytest.mark.parametrize("seed", range(3))
def test_mark_cells_match_numpy(seed: int) -> None:
    rng = np.random.default_rng(seed)
    normals = rng.normal(size=(400, 4, 3))
    normals[rng.random((400, 4)) < 0.3] = 0.0
    normals /= np.maximum(np.linalg.norm(normals, axis=2, keepdims=True), 1e-300)
    for face in range(6):
        for rect in (None, (-0.3, -0.2, 0.5, 0.4)):
            poly, cnt = _ref_clip(normals, face, shrink=1e-5, rect=rect)
            poly, cnt = poly[cnt >= 3], cnt[cnt >= 3]  # as Cover.add passes them
            for r in (64, 512):
                got, ref = np.zeros((r, r), dtype=bool), np.zeros((r, r), dtype=bool)
                first = cover_kernels.mark_cells(poly, cnt, 2.0 / r, got)
                assert first == _ref_mark(ref, poly, cnt, 2.0 / r)
                assert np.array_equal(got, ref)
                assert got.any() or rect is not None


def test_circle_crossings_match_numpy() -> None:
    """The crossings of axis-aligned and nearly concurrent circles against the numpy
    computation: the same points in the same order, zeros' signs included."""
    import shapely

    rng = np.random.default_rng(2)
    n = rng.normal(size=(200, 3))
    n[:60] = np.round(n[:60])
    ang = rng.random(60) * 6.28
    n[60:120] = np.stack([np.cos(ang), np.sin(ang), 1e-3 * rng.normal(size=60)], axis=1)
    n = n[np.linalg.norm(n, axis=1) > 0]
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    dom = [shapely.Point(0.1 * f - 0.2, 0.05).buffer(0.5) for f in range(6)]
    for domain in (None, dom):
        got = circle_crossings(n, 0.01, domain)
        for face, want in enumerate(_crossings_reference(n, 0.01, domain)):
            assert _same(got[face], want)


def _crossings_reference(n: np.ndarray, q: float, domain: list | None) -> list[np.ndarray]:
    """Per face, the crossings of the circles ``n`` in pair order (``+d`` then ``-d``), inside
    ``domain`` (shapely's ``contains_xy``), the first of each rounded key."""
    import shapely

    a, b = np.triu_indices(len(n), k=1)
    d = np.cross(n[a], n[b])
    ln = np.linalg.norm(d, axis=1)
    d = d[ln > 1e-12] / ln[ln > 1e-12, None]
    d = np.concatenate([d, -d])
    owner = np.argmax(d @ FACES[:, 0].T, axis=1)
    out = []
    for face in range(6):
        e, u, v = FACES[face]
        df = d[owner == face]
        st = np.stack([(df @ u) / (df @ e), (df @ v) / (df @ e)], axis=1)
        st = st[(np.abs(st) < 1.0 - 1e-7).all(axis=1)]
        if domain is not None:
            if domain[face] is None:
                out.append(np.zeros((0, 2)))
                continue
            st = st[shapely.contains_xy(domain[face], st[:, 0], st[:, 1])]
        _, idx = np.unique(np.round(st / q), axis=0, return_index=True)
        out.append(st[np.sort(idx)])
    return out


def test_first_crossings_on_a_raster_domain() -> None:
    """The one-pass kernel (a domain made of raster cells) against the reference: the same
    points in the same order, including crossings exactly on the cells' edges (the axes are
    a corner of four cells: inside where all four are in the domain, outside where one is
    missing), and the chunked path gives them too."""
    from ndbg_cli.ndbg.infinite import arrangement
    from ndbg_cli.ndbg.infinite.domain import domain_polygons

    rng = np.random.default_rng(5)
    axes = np.eye(3)
    # circles through the axes and through points on the cells' edges (grid lines)
    tilt = rng.normal(size=(40, 3)) * np.array([1.0, 1.0, 0.0]) + np.array([0.0, 0.0, 1.0])
    n = np.concatenate([axes, np.round(rng.normal(size=(40, 3)) * 4), tilt,
                        rng.normal(size=(60, 3))])
    n = n[np.linalg.norm(n, axis=1) > 0]
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    r = 64
    dom = np.zeros((6, r, r), dtype=bool)
    dom[:, 20:44, 20:44] = True  # around every axis: its chart point (0, 0) a corner inside
    dom[2:4, 32, 32] = False  # faces 2 and 3: one of the four cells round the axis missing
    polys = domain_polygons(dom)
    for q in (1e-3, 0.05):
        assert arrangement._fused_inputs([(np.ones(len(n), dtype=bool), tuple(range(6)))],
                                         np.array([p.bounds for p in polys]), polys, q,
                                         len(n)) is not None
        got = circle_crossings(n, q, polys)
        want = _crossings_reference(n, q, polys)
        for face in range(6):
            assert _same(got[face], want[face]), (q, face)
        centre = [bool(((got[f] == 0.0).all(axis=1)).any()) for f in range(6)]
        assert centre == [True, True, False, False, True, True]
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(arrangement, "_fused_inputs", lambda *a: None)
        chunked = circle_crossings(n, 1e-3, polys)
    assert all(_same(a, b) for a, b in zip(chunked, circle_crossings(n, 1e-3, polys)))


def test_unique_circles_first_occurrences() -> None:
    rng = np.random.default_rng(4)
    base = np.round(rng.normal(size=(20, 3)))
    base = base[np.abs(base).sum(axis=1) > 0]
    x = base[rng.integers(0, len(base), 500)] * np.where(rng.random((500, 1)) < 0.5, -1, 1)
    n = x / np.linalg.norm(x, axis=1, keepdims=True)
    first = np.argmax(np.abs(n) > 1e-12, axis=1)
    n = n * np.sign(n[np.arange(len(n)), first])[:, None]
    _, idx = np.unique(np.round(n, 9), axis=0, return_index=True)
    assert _same(unique_circles(x), n[np.sort(idx)])

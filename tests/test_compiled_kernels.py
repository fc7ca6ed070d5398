"""The sweep test's kernels compiled ahead of time (:mod:`ndbg_cli.kernels.compiled`):
the same results as numba's just-in-time kernels to the bit, on random triangle sets where
every branch is taken (blocking pairs, narrow pairs, empty overlaps); a stale or switched-off
build is not used."""

import os
import subprocess
import sys

import numpy as np
import pytest

from ndbg_cli.kernels import _sweep_kernels as jit
from ndbg_cli.kernels import compiled as _compiled

built = _compiled._compiled("_sweep_kernels") is not None
#: CI sets NDBG_REQUIRE_AOT (.ci/run): there a missing or stale build fails these tests
needs_build = pytest.mark.skipif(
    not built and not os.environ.get("NDBG_REQUIRE_AOT"),
    reason="kernels not compiled ahead of time here (make bytecode builds them; without a C "
    "compiler they run just in time)")
compiled = _compiled.kernels("_sweep_kernels")


def _same(a, b) -> None:
    """Equal to the bit: the same types, shapes and bytes (tuples element by element)."""
    if isinstance(a, tuple):
        assert isinstance(b, tuple) and len(a) == len(b)
        for x, y in zip(a, b, strict=True):
            _same(x, y)
    elif isinstance(a, np.ndarray):
        assert a.dtype == b.dtype and a.shape == b.shape and a.tobytes() == b.tobytes()
    else:
        assert type(a) is type(b) and np.array(a).tobytes() == np.array(b).tobytes()


def _triangles(rng: np.random.Generator, n: int, z: float) -> np.ndarray:
    """``n`` projected triangles (u, v, z) of sizes from slivers to a fifth of the unit
    square, at depths around ``z``."""
    centres = rng.uniform(0, 1, (n, 1, 3))
    size = rng.choice([1e-4, 0.02, 0.2], size=(n, 1, 1))
    t = centres + size * rng.normal(size=(n, 3, 3))
    t[:, :, 2] = z + 0.01 * rng.normal(size=(n, 3))
    return np.ascontiguousarray(t)


@needs_build
@pytest.mark.parametrize("seed", range(6))
def test_compiled_kernels_equal_the_just_in_time_ones_to_the_bit(seed):
    rng = np.random.default_rng(seed)
    pi, pj = _triangles(rng, 60, 0.0), _triangles(rng, 50, 0.005 * (seed - 2))
    eps, amin, tiny = 10.0 ** -rng.integers(2, 5), 1e-12, 1e-9
    bi, bj = jit.boxes(pi), jit.boxes(pj)
    _same(compiled.boxes(pi), bi)
    _same(compiled.wide_triangles(pi, eps), jit.wide_triangles(pi, eps))
    got = compiled.first_blocking(pi, pj, bi, bj, eps, amin, tiny)
    want = jit.first_blocking(pi, pj, bi, bj, eps, amin, tiny)
    _same(got[:2] + (got[3],), want[:2] + (want[3],))
    _same(got[2][:got[3]], want[2][:want[3]])  # rows past the count are padding
    pairs = np.ascontiguousarray(np.stack([rng.integers(0, 60, 400),
                                           rng.integers(0, 50, 400)], axis=1))
    coords, counts = jit.front_polygons(pi, pj, pairs, amin, 1e-3 * eps)
    assert counts.any() and not counts.all()  # both kinds of pair are met
    _same(compiled.front_polygons(pi, pj, pairs, amin, 1e-3 * eps), (coords, counts))
    kept = np.flatnonzero(counts)
    starts = np.concatenate([[0], np.cumsum(counts[kept])[:-1]]).astype(np.int64)
    ring = np.ascontiguousarray(counts[kept])
    idx = np.arange(len(kept), dtype=np.int64)
    window = [float(x) for x in (*rng.uniform(0, 0.5, 2), *rng.uniform(0.5, 1, 2))]
    _same(compiled.clipped_areas(coords, starts, ring, idx, *window),
          jit.clipped_areas(coords, starts, ring, idx, *window))
    for a, b in pairs[:50]:
        _same(compiled.overlap_centroid(pi[a], pj[b]), jit.overlap_centroid(pi[a], pj[b]))
        _same(compiled.plane(pj[b]), jit.plane(pj[b]))
    n = rng.normal(size=(60, 3))
    n /= np.linalg.norm(n, axis=1)[:, None]
    n[:10] = [0.0, 0.0, 1.0]  # facing the frame's d exactly, or (its first half) sliding
    frame = np.eye(3)[[1, 2, 0]] if seed % 2 else np.eye(3)
    for sense in (1, -1):
        _same(compiled.facing(pi, n, frame, sense, 1e-9, eps),
              jit.facing(pi, n, frame, sense, 1e-9, eps))


def test_facing_selects_projects_and_picks_the_wide_triangles():
    """:func:`facing` against numpy: the triangles facing the frame's third row (sliding ones,
    ``n . d`` within the tolerance, left out on both sides), projected on its rows, their
    boxes, and the wide ones among them."""
    rng = np.random.default_rng(7)
    tris = _triangles(rng, 200, 0.3)
    c, s = np.cos(0.3), np.sin(0.3)
    frame = np.array([[c, 0.0, -s], [0.0, 1.0, 0.0], [s, 0.0, c]])
    n = rng.normal(size=(200, 3))
    n[::7] = np.cross(frame[2], n[::7])  # sliding along d
    n /= np.linalg.norm(n, axis=1)[:, None]
    sliding = np.arange(200) % 7 == 0
    for sense in (1, -1):
        t, b, wt, wb = compiled.facing(tris, n, frame, sense, 1e-9, 1e-2)
        sd = n @ frame[2]
        keep = sd > 1e-9 if sense > 0 else sd < -1e-9
        assert keep.sum() > 50 and not (keep & sliding).any()
        np.testing.assert_allclose(t, tris[keep] @ frame.T, rtol=0, atol=1e-15)
        _same(b, jit.boxes(t))
        wide = jit.wide_triangles(t, 1e-2)
        assert 0 < wide.sum() < len(t)  # both kinds are met
        _same((wt, wb), (np.ascontiguousarray(t[wide]), np.ascontiguousarray(b[wide])))


def test_wide_triangles_is_the_inradius_test():
    """Its shortcut (a triangle narrower than its longest side says is not measured further)
    gives the test as written, ``2 A > (eps / 2) P``, on slivers, fat triangles and ones at
    the threshold."""
    rng = np.random.default_rng(3)
    t = _triangles(rng, 3000, 0.0)
    side = 0.01  # equilateral triangles of side 0.01: inradius side / (2 sqrt 3)
    eq = np.array([[0.0, 0.0, 0.0], [side, 0.0, 0.0], [side / 2, side * np.sqrt(3) / 2, 0.0]])
    t = np.concatenate([t, np.broadcast_to(eq, (3, 3, 3))])
    for eps in (1e-4, 1e-3, side / np.sqrt(3), 1e-2):
        want = [2 * jit.polygon_area.py_func(x[:, 0], x[:, 1], 3)
                > 0.5 * eps * jit.polygon_perimeter.py_func(x[:, 0], x[:, 1], 3) for x in t]
        assert compiled.wide_triangles(t, eps).tolist() == want


@needs_build
def test_first_blocking_finds_a_blocking_pair_in_the_random_sets():
    """The comparison above is not vacuous: the sets hold blocking pairs."""
    rng = np.random.default_rng(0)
    pi, pj = _triangles(rng, 60, 0.0), _triangles(rng, 50, 0.01)
    ki, kj, _, _ = compiled.first_blocking(pi, pj, compiled.boxes(pi), compiled.boxes(pj),
                                           1e-3, 1e-12, 1e-9)
    assert ki >= 0 and kj >= 0


@needs_build
def test_the_sweep_test_runs_the_compiled_kernels():
    from ndbg_cli.ndbg.infinite import sweep

    assert built and compiled.compiled and sweep._kernels.compiled and sweep.kernels_loaded()


@needs_build
def test_a_stale_build_is_not_used(monkeypatch):
    """A build from another source (its recorded digest differs) is left for numba's."""
    monkeypatch.setattr(_compiled, "_digest", lambda source: 12345)
    got = _compiled.kernels("_sweep_kernels")
    assert not got.compiled and got.boxes is jit.boxes


@needs_build
def test_arrays_of_another_type_or_layout_are_converted_and_other_dimensions_refused():
    """The compiled functions read memory as declared: float32, Fortran order or int input
    must give what numba's dispatcher gives (it compiles a version for them)."""
    t = np.random.default_rng(1).normal(size=(5, 3, 3))
    want = jit.boxes(t)
    for other in (t.astype(np.float32), np.asfortranarray(t), t[:, :, ::-1][:, :, ::-1]):
        _same(compiled.boxes(other), jit.boxes(np.ascontiguousarray(other, np.float64)))
    _same(compiled.boxes(np.asfortranarray(t)), want)
    with pytest.raises(TypeError, match="dimensions"):
        compiled.boxes(t[0])
    assert _compiled._arguments(jit.EXPORTS["first_blocking"]) == [
        (np.dtype(np.float64), 3), (np.dtype(np.float64), 3), (np.dtype(np.float64), 2),
        (np.dtype(np.float64), 2), None, None, None]


def test_every_kernel_the_sweep_test_uses_is_exported():
    """So that a machine with the build and one without take the same kernels."""
    assert _compiled._exports(_compiled._source("_sweep_kernels").decode()) == jit.EXPORTS
    assert set(jit.EXPORTS) == {
        "facing", "boxes", "wide_triangles", "first_blocking", "front_polygons",
        "clipped_areas", "overlap_centroid", "plane"}


def test_numba_disable_jit_runs_the_python_source():
    code = ("from ndbg_cli.kernels.compiled import kernels; "
            "k = kernels('_sweep_kernels'); print(k.compiled, type(k.boxes).__name__)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         env={**os.environ, "NUMBA_DISABLE_JIT": "1"}, check=True)
    assert out.stdout.split() == ["False", "function"]  # the plain Python source


@needs_build
def test_a_fresh_build_is_not_built_again():
    assert _compiled.build() == []


@pytest.mark.skipif(_compiled._compiled("_box_kernels") is None
                    and not os.environ.get("NDBG_REQUIRE_AOT"),
                    reason="kernels not compiled ahead of time here (make bytecode builds them)")
@pytest.mark.parametrize("n", [0, 3, 9, 500])
def test_the_box_hierarchys_compiled_kernels_equal_the_just_in_time_ones(n):
    """The hierarchy (node boxes, children, order) and the pairs it finds, to the bit, on
    boxes of a coarse grid (ties of centres, touching boxes)."""
    from ndbg_cli.kernels import _box_kernels as jit_boxes

    rng = np.random.default_rng(n)
    lo = np.round(rng.uniform(0, 10, (n, 3)), 1)
    hi = lo + np.round(rng.uniform(0, 2, (n, 3)), 1)
    qlo = np.round(rng.uniform(0, 10, (50, 3)), 1)
    qhi = qlo + 1.0
    aot = _compiled.loaded("_box_kernels")
    assert aot.compiled
    tree = aot.hierarchy(lo, hi)
    _same(tree, jit_boxes.hierarchy(lo, hi))
    _same(aot.meeting_pairs(*tree, lo, hi, qlo, qhi),
          jit_boxes.meeting_pairs(*tree, lo, hi, qlo, qhi))


@pytest.mark.skipif(_compiled._compiled("_triangle_kernels") is None
                    and not os.environ.get("NDBG_REQUIRE_AOT"),
                    reason="kernels not compiled ahead of time here (make bytecode builds them)")
def test_the_triangle_predicates_compiled_kernels_equal_the_just_in_time_ones():
    """Closest points, segment points, triangle distances, separating gaps and the plane
    filter, to the bit, on random triangles, on triangles of a coarse grid (shared vertices
    and edges, coplanar and touching pairs, signed zeros) and on degenerate ones."""
    from ndbg_cli.kernels import _triangle_kernels as jit

    rng = np.random.default_rng(5)
    grid = np.round(rng.uniform(-2, 2, (400, 3, 3))) * rng.choice([1.0, -1.0], (400, 3, 3))
    ta = np.concatenate([rng.normal(size=(400, 3, 3)), grid, grid[:, [0, 0, 1]]])
    tb = np.concatenate([rng.normal(size=(400, 3, 3)), grid[::-1], rng.normal(size=(400, 3, 3))])
    p = np.ascontiguousarray(tb[:, 0] + rng.normal(size=(len(tb), 3)))
    ends = [np.ascontiguousarray(x) for x in (ta[:, 0], ta[:, 1], tb[:, 0], tb[:, 1])]
    aot = _compiled.loaded("_triangle_kernels")
    assert aot.compiled
    _same(aot.closest_on_triangle(p, ta), jit.closest_on_triangle(p, ta))
    _same(aot.segment_closest(*ends), jit.segment_closest(*ends))
    _same(aot.triangle_gap(ta, tb), jit.triangle_gap(ta, tb))
    _same(aot.sat_gap(ta, tb), jit.sat_gap(ta, tb))
    normals = rng.normal(size=(len(ta), 3))
    sag = rng.uniform(0, 0.1, len(ta))
    pairs = rng.integers(0, len(ta), (2, 5000))
    args = (ta, normals, sag, tb, normals[::-1].copy(), sag[::-1].copy(), *pairs, 0.5)
    _same(aot.plane_filter(*args), jit.plane_filter(*args))


#: The exact infinite family's kernel modules, built ahead of time too.
EXACT = ("_cone_kernels", "_cover_kernels", "_term_kernels", "_union_kernels")
exact_built = all(_compiled._compiled(m) is not None for m in EXACT)
needs_exact_build = pytest.mark.skipif(
    not exact_built and not os.environ.get("NDBG_REQUIRE_AOT"),
    reason="kernels not compiled ahead of time here (make bytecode builds them)")


def _record(monkeypatch, calls: list) -> None:
    """Every exported kernel of the exact family, as its callers get it
    (:func:`~ndbg_cli.kernels.compiled.loaded`), records its calls: the arguments
    before and after it ran (kernels may write into them) and what it returned."""

    for module in EXACT:
        space = _compiled.loaded(module)
        for name in _compiled._exports(_compiled._source(module).decode()):
            monkeypatch.setattr(space, name, _recorder(getattr(space, name), (module, name),
                                                       calls))


def _recorder(fn, key: tuple, calls: list):
    import copy

    def call(*args):
        before = copy.deepcopy(args)
        out = fn(*args)
        calls.append((key, before, copy.deepcopy(args), out))
        return out
    return call


def _exact_family_work() -> None:
    """The exact family's kernels at work: the whole-sphere NDBG of two examples, the
    restricted one (a free-motion domain) of two more, and the cone and window helpers on
    random cones (as tests/test_cover.py makes them)."""
    import ndbg_cli
    from ndbg_cli.contacts.contacts3d import analyze_contacts
    from ndbg_cli.ndbg.infinite.blocking_cones import flat
    from ndbg_cli.ndbg.infinite.build import build_infinite
    from ndbg_cli.ndbg.infinite.cover import Cover
    from ndbg_cli.ndbg.infinite.cubemap import compact, cone_normals
    from ndbg_cli.ndbg.infinite.domain import free_domain
    from ndbg_cli.ndbg.infinitesimal.build import contact_pairs

    for name in ("hover", "stack"):
        build_infinite(ndbg_cli.load(f"assemblies/{name}.yaml"))
    for name in ("peg-37", "slot-37"):
        asm = ndbg_cli.load(f"assemblies/{name}.yaml")
        ca = analyze_contacts(asm)
        build_infinite(asm, domain=free_domain(len(asm), contact_pairs(asm, ca),
                                               ca.angle_tolerance))
    rng = np.random.default_rng(0)
    domain = np.zeros((6, 64, 64), dtype=bool)
    domain[4, 28:36, 20:44] = domain[5, 20:44, 28:36] = True
    cover = Cover(domain=domain)
    gens = rng.normal(size=(300, 1, 3)) + 0.4 * rng.normal(size=(300, 9, 3))
    facing = rng.normal(size=(300, 2, 3))
    facing /= np.linalg.norm(facing, axis=2, keepdims=True)
    cover.misses_spanned_open(gens, facing)
    cones = compact(cone_normals(gens[:, :4]))
    flat(cones)
    cover.add(cones[:40])
    cover.covers_spanned(gens[40:])
    cover.misses_open(cones[40:])


@needs_exact_build
def test_the_exact_familys_compiled_kernels_equal_the_just_in_time_ones(monkeypatch):
    """On the calls the exact family makes (the first 30 of each kernel): the same values,
    and the same writes into the arguments, to the bit; every exported kernel is met."""
    import importlib

    calls: list = []
    _record(monkeypatch, calls)
    _exact_family_work()
    met: dict = {}
    for (module, name), before, after, out in calls:
        met[module, name] = met.get((module, name), 0) + 1
        if met[module, name] > 30:
            continue
        assert _compiled.loaded(module).compiled
        jit_fn = getattr(importlib.import_module(f"ndbg_cli.kernels.{module}"), name)
        args = [np.array(a) if isinstance(a, np.ndarray) else a for a in before]
        _same(jit_fn(*args), out)
        for a, b in zip(args, after, strict=True):
            if isinstance(a, np.ndarray):
                _same(a, b)
    assert set(met) == {(m, n) for m in EXACT
                        for n in _compiled._exports(_compiled._source(m).decode())}


@needs_exact_build
def test_a_kernel_writing_into_a_view_writes_into_the_callers_array():
    """``update_sat`` brings a window of a summed-area table up to date in place: given a
    view that is not contiguous, the compiled kernel (which reads a contiguous copy) still
    writes into the caller's table, as the just-in-time one does."""
    from ndbg_cli.kernels import _cover_kernels as jit_cover

    covered = np.random.default_rng(2).random((6, 9)) < 0.5
    tables = [np.zeros((3, 8, 12), dtype=np.int32) for _ in range(2)]
    for fn, table in zip((_compiled.loaded("_cover_kernels").update_sat,
                          jit_cover.update_sat), tables, strict=True):
        window = table[1, :7, :10]
        assert not window.flags.c_contiguous
        fn(covered, window, 0)
    _same(tables[0], tables[1])
    want = np.zeros((7, 10), dtype=np.int64)
    want[1:, 1:] = covered.cumsum(axis=0).cumsum(axis=1)
    assert (tables[0][1, :7, :10] == want).all() and not tables[0][[0, 2]].any()


def test_signatures_with_tuples_and_int32_arrays_are_read():
    """A tuple argument is read element by element (``prune_pairs`` takes the cover's
    windows as one), and ``i4`` arrays are int32."""
    from ndbg_cli.kernels import _term_kernels as jit_terms

    got = _compiled._arguments(jit_terms.EXPORTS["prune_pairs"])
    window = [(np.dtype(np.int64), 1), (np.dtype(np.float64), 3), (np.dtype(np.float64), 2),
              (np.dtype(np.int32), 3), (np.dtype(np.int64), 2), None, None]
    assert got[9] == window and got[11] == window and got[10] is None and len(got) == 13


def test_a_build_holds_the_source_of_the_kernels_it_compiles_in():
    """A module's build digest covers the kernel modules it imports (their kernels are
    compiled into it): editing ``_cone_kernels`` makes ``_term_kernels``' build stale."""
    text = _compiled._built_from("_term_kernels")
    for module in ("_term_kernels", "_cover_kernels", "_cone_kernels", "cube_faces"):
        assert _compiled._source(module) in text
    assert _compiled._built_from("_sweep_kernels") == _compiled._source("_sweep_kernels")


@needs_exact_build
def test_only_the_arguments_a_kernel_writes_are_written():
    """``WRITES`` names what each kernel writes into: an argument only read and copied for
    its type (float counts where int64 are declared) is left as the caller gave it, and a
    kernel refuses to write into a read-only array or one of another type, as numba's
    dispatcher does (it compiles no such version)."""
    from ndbg_cli.kernels import _cover_kernels as jit_cover

    assert _compiled._writes(_compiled._source("_cover_kernels").decode()) == jit_cover.WRITES
    assert _compiled._writes(_compiled._source("_union_kernels").decode()) == {}
    poly = np.zeros((2, 4, 2))
    poly[:, :, 0] = [0.0, 1.0, 1.0, 0.0]
    poly[:, :, 1] = [0.0, 0.0, 1.0, 1.0]
    cnt = np.array([4.0, 3.0])
    from ndbg_cli.kernels import _union_kernels as jit_union

    _same(_compiled.loaded("_union_kernels").piece_boxes(poly, cnt),
          jit_union.piece_boxes(poly, cnt.astype(np.int64)))
    assert cnt.dtype == np.float64 and cnt.tolist() == [4.0, 3.0]
    mark = _compiled.loaded("_cover_kernels").mark_cells
    covered = np.zeros((8, 8), dtype=bool)
    covered.flags.writeable = False
    with pytest.raises(TypeError, match="writeable"):
        mark(poly, np.array([4, 4]), 0.25, covered)
    with pytest.raises(TypeError, match="writeable"):
        mark(poly, np.array([4, 4]), 0.25, np.zeros((8, 8), dtype=np.int64))
    mine = np.zeros((8, 8), dtype=bool)
    assert mark(poly, np.array([4, 4]), 0.25, mine) < 8 and mine.any()


def test_a_module_that_fails_to_build_leaves_the_others_built(monkeypatch, tmp_path):
    """Each kernel module is built on its own: one failing is marked (not tried again for
    the same source) and named, the others are built."""
    built = []

    def build_one(module, name, digest):
        if module == "_cover_kernels":
            raise RuntimeError("no compiler today")
        built.append(name)

    monkeypatch.setattr(_compiled, "_HERE", tmp_path)
    monkeypatch.setattr(_compiled, "_built_from", lambda module: module.encode())
    monkeypatch.setattr(_compiled, "_build_one", build_one)
    with pytest.raises(_compiled.BuildError) as err:
        _compiled.build(force=True)
    assert err.value.failed == ["_cover_kernels_aot: no compiler today"]
    assert err.value.done == built == [n for m, n in _compiled.BUILT.items()
                                       if m != "_cover_kernels"]
    assert [p.name for p in tmp_path.iterdir()] == ["_cover_kernels_aot.failed"]


def test_the_package_imports_a_build_holds_are_read_in_every_form(monkeypatch, tmp_path):
    """``from .x import ...``, ``from . import x as y``, indented or parenthesized over
    lines: each module of the package named is in the build's source; names of no module
    (a package's function, a module elsewhere) are not."""
    (tmp_path / "_a.py").write_text(
        "from . import _b as b, _c\n"
        "def f():\n"
        "    from ._d import g\n"
        "from . import (\n    _e,\n    nothing_here,\n)\n"
        "from .._elsewhere import h\n")
    for name in ("_b", "_c", "_d", "_e", "_f"):
        (tmp_path / f"{name}.py").write_text(f"# {name}\n" + (
            "from ._f import x\n" if name == "_e" else ""))
    monkeypatch.setattr(_compiled, "_HERE", tmp_path)
    assert _compiled._local_imports("_a") == {"_b", "_c", "_d", "_e"}
    # layouts the pattern does not read plainly: the module is parsed instead
    for text, want in (("from . import (\n    _b,  # a comment, _c\n    _d,\n)\n", {"_b", "_d"}),
                       ("from . import _b, \\\n    _c\n", {"_b", "_c"}),
                       ("from ._b \\\n    import x\n", {"_b"}),
                       ("from ._b import(x)\nfrom ._c import*\n", {"_b", "_c"}),
                       ("x = 1; from . import _d\nif x: from ._e import y\n", {"_d", "_e"})):
        (tmp_path / "_g.py").write_text(text)
        assert _compiled._local_imports("_g") == want, text
    text = _compiled._built_from("_a")
    assert text.startswith(b"from . import _b") and all(
        f"# {n}\n".encode() in text for n in ("_b", "_c", "_d", "_e", "_f"))

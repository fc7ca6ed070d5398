"""The infinite-translation NDBG of a 2D assembly on S^1, exactly, from the open cones.

2D parts are extruded to prisms (:func:`ndbg_cli.ndbg.infinite.blocking_cones.part_triangles`) and their
blocked sets ``B_ij`` computed as for 3D parts: unions of open cones. The directions of the
plane are the equator ``z = 0``. A cone meets it in an open arc: each facet normal ``m`` gives
the open half-circle ``m . (cos phi, sin phi, 0) > 0``, i.e. ``|phi - atan2(m_y, m_x)| <
pi / 2``, and a facet normal along ``z`` (the prisms' caps) none: such a cone only *touches*
the equator, which its open set does not contain. (Reading the equator off the cones' closed
chart polygons instead took those touching cones for blocking: the cap terms of the two sides
``z > 0`` and ``z < 0`` meet along it.)

So ``B_ij`` on S^1 is a union of open arcs (:func:`cone_arcs`), each shrunk by
:data:`~ndbg_cli.ndbg.infinite.build.OPEN_TOL` radians at both ends, as the 3D exact test does with a
cone's facets. The arcs' endpoints cut the circle into points and open intervals, each with
one DBG (a direction is blocked by a pair when strictly inside one of its arcs); neighbouring
pieces with the same DBG are one region (:func:`equator_regions`).

Dimension and representative direction
--------------------------------------
A region shorter than the angular tolerance ``eta`` (radians, ``ANGULAR_FACTOR * eps /
diagonal`` of :mod:`ndbg_cli.ndbg.infinite.blocked_sets`: 5e-3 rad at the default tolerance) is 0-dimensional;
longer regions are 1-dimensional. A region's direction is its middle, except near the sliding
directions of the contacts (perpendicular to a contact normal), where the erosion (both parts
moved ``1.5 eps`` inward, :mod:`ndbg_cli.ndbg.infinite.build`) widens the single free direction of a
zero-clearance slot or pocket into a band reaching ``3 eps / L`` radians past it on the side of
a contact ``L`` long: ``6 eps / L`` wide for two walls ``L`` long, i.e. ``0.12 diagonal / L``
``eta``. Inside that band but off the sliding direction, the sweep penetrates a wall by up to
``3 eps``: the direct sweep test (:mod:`ndbg_cli.ndbg.infinite.sweep`, no erosion; ``ndbg query``) blocks
there. So:

* a 0-dimensional region takes the sliding direction within its extent (ends included) nearest
  its middle, when there is one;
* a 1-dimensional region at most :data:`BAND_ETA` ``eta`` wide takes the sliding direction
  nearest its middle among those *in* it (strictly inside, or at a closed end: its DBG there,
  read from the arcs, is the region's); it stays 1-dimensional and its DBG is unchanged. That
  covers the bands of contacts down to ``0.12 / BAND_ETA`` of the diagonal (0.24 %, 24
  ``eps``) long. A wider region keeps its middle: it is wide because the parts leave a real range of
  directions free there (a block against one wall of a wide pocket comes out anywhere between
  along that wall and over the far wall's top), and its middle is the direction farthest from
  the region's ends.

Angles and widths are in radians and ``eta`` is a fixed multiple of the relative length
tolerance: turning or scaling the assembly changes neither which regions are represented by a
sliding direction nor, up to the turn, their directions. Besides these bands, the erosion
leaves regions *next to* a sliding direction, on one side of it, where the sweep also
penetrates a wall by less than ``3 eps`` (their DBG holds nowhere without erosion): they keep
their middles, within the length tolerance like every region of the eroded parts.

Thin regions
------------
Such a one-sided band is ``3 eps / L`` radians, ``0.06 diagonal / L`` ``eta``, wide: within
:data:`BAND_ETA` ``eta`` for contacts down to 0.12 % of the diagonal. So every 1-dimensional
region at most :data:`BAND_ETA` ``eta`` wide (:func:`narrow`, the bound of the rule above) is
*thin* (:attr:`ndbg_cli.ndbg.model.Region.thin`): :func:`ndbg_cli.planning.plans.pick_region` ranks it
with the 0-dimensional regions (by the contacts its direction slides along, then dimension),
after the wider 1-dimensional regions, whose middles lie more than ``BAND_ETA / 2`` ``eta``
from their ends (past the band of any contact down to 0.24 % of the diagonal). A step free
in a band and in the region at its sliding direction, or in a wide region beside it, is
reported along the latter, which the direct test frees. A thin region need not be a band
(at the default tolerance ``BAND_ETA eta`` is 0.25 rad, 14 degrees, e.g. fig3-2d's arc from
0.1 to 14 degrees above +x): it is only ranked later. The thin regions' dimension,
direction and DBG are unchanged. On 3,000 random 2D assemblies (``benchmarks/fuzz_pick2d.py``)
the direct test blocked the picked direction of 2,929 of 26,030 partitionings before this
ranking, none after.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from ..dbg import DBG

#: Endpoints closer than this (radians) are one (floating-point noise of the cones' normals).
MERGE_TOL = 1e-12
#: A facet normal whose component in the plane is below this fraction of its length is along
#: ``z``: its open half-space misses the equator.
FLAT_TOL = 1e-12

TWO_PI = 2.0 * np.pi

#: A 1-dimensional region at most this many ``eta`` wide that holds a contact's sliding
#: direction is represented by it (module docstring): the erosion's band round a sliding
#: direction is ``0.12 diagonal / L`` ``eta`` wide for walls ``L`` long (50: ``L`` down to 0.24 %
#: of the diagonal, 24 ``eps``). On 1,600 random 2D box assemblies (half turned), no region
#: holding a sliding direction whose middle the direct sweep test blocked was wider than 37
#: ``eta``; without a bound, 8 times as many regions whose middle it freed moved too (e.g. out
#: of a wide pocket, to along its wall, near the region's end). Every 1-dimensional region
#: at most this wide is thin (ranked after the wider ones; module docstring): on 3,000 random
#: 2D assemblies no picked region whose direction the direct test blocked was wider than 25.2
#: ``eta`` (before thin regions were ranked later).
BAND_ETA = 50.0  # not infinite.SNAP_ETA (3D: how far from a thin cell circles are sought)


def cone_arcs(cones: np.ndarray, shrink: float) -> np.ndarray:
    """The open arcs ``(q, 2)`` (``lo`` in ``[0, 2 pi)``, ``lo < hi <= lo + 2 pi``, radians)
    in which the open cones ``(p, k, 3)`` (zero rows: no constraint) meet the equator, each
    shrunk by ``shrink`` at both ends; the cones that miss it, or whose arc is shorter than
    ``2 shrink``, give none."""
    if not len(cones):
        return np.zeros((0, 2))
    m = np.asarray(cones, dtype=float)
    length = np.linalg.norm(m, axis=2)
    real = length > 0
    h = np.linalg.norm(m[:, :, :2], axis=2)
    flat = real & (h <= FLAT_TOL * length)
    ok = ~flat.any(axis=1)
    alpha = np.arctan2(m[:, :, 1], m[:, :, 0])
    # each half-circle relative to the cone's first one, in (-pi, pi]
    first = np.argmax(real, axis=1)
    a0 = alpha[np.arange(len(m)), first]
    delta = np.mod(alpha - a0[:, None] + np.pi, TWO_PI) - np.pi
    lo = np.where(real, delta - np.pi / 2, -np.inf).max(axis=1)
    hi = np.where(real, delta + np.pi / 2, np.inf).min(axis=1)
    whole = ~real.any(axis=1)  # no facet: every direction
    lo = np.where(whole, -np.pi, lo) + shrink
    hi = np.where(whole, np.pi, hi) - shrink
    keep = ok & (hi > lo)
    start = np.mod((a0 + lo)[keep], TWO_PI)
    return np.column_stack([start, start + (hi - lo)[keep]])


def inside(arcs: np.ndarray, phi: np.ndarray) -> np.ndarray:
    """``(m,)`` whether each angle of ``phi`` lies strictly inside one of the open ``arcs``."""
    phi = np.mod(np.asarray(phi, dtype=float), TWO_PI)
    out = np.zeros(len(phi), dtype=bool)
    step = max(1, 4_000_000 // max(len(phi), 1))
    for s in range(0, len(arcs), step):
        a = arcs[s:s + step]
        t = np.mod(phi[None, :] - a[:, :1], TWO_PI)
        out |= ((t > 0) & (t < a[:, 1:] - a[:, :1])).any(axis=0)
    return out


def arc_dbgs(arcs: Mapping[tuple[int, int], np.ndarray], n: int, phi: np.ndarray
             ) -> list[DBG]:
    """The DBG at each angle of ``phi`` (radians): arc ``i -> j`` where ``phi`` is strictly
    inside one of ``arcs[(i, j)]``."""
    succ = [[0] * n for _ in range(len(phi))]
    for (i, j), a in sorted(arcs.items()):
        for k in np.flatnonzero(inside(a, phi)):
            succ[k][i] |= 1 << j
    return [DBG(tuple(s)) for s in succ]


def _ends(arcs: Mapping[tuple[int, int], np.ndarray]) -> np.ndarray:
    """Every arc's two ends, as angles in ``[0, 2 pi)``."""
    return np.mod(np.concatenate([a.reshape(-1) for a in arcs.values()] + [np.zeros(0)]),
                  TWO_PI)


def equator_regions(arcs: Mapping[tuple[int, int], np.ndarray], n: int, eta: float,
                    sliding: np.ndarray) -> list[tuple[int, float, DBG]]:
    """The regions of S^1: ``(dimension, angle, DBG)``, by increasing start angle.

    ``arcs``: each ordered pair's open arcs (:func:`cone_arcs`); ``eta``: the angular
    tolerance (radians; shorter regions are 0-dimensional); ``sliding``: angles of the
    contacts' sliding directions (a thin region's direction, see the module docstring)."""
    return [r[:3] for r in equator_extents(arcs, n, eta, sliding)]


def equator_extents(arcs: Mapping[tuple[int, int], np.ndarray], n: int, eta: float,
                    sliding: np.ndarray) -> list[tuple[int, float, DBG, tuple]]:
    """:func:`equator_regions` with each region's extent: ``(dimension, angle, DBG,
    (lo, hi, lo_closed, hi_closed))``, the region being the angles from ``lo`` to ``hi``
    counter-clockwise (radians, ``lo`` in ``[0, 2 pi)``, ``lo < hi <= lo + 2 pi``), each end
    included when ``*_closed``; the whole circle is ``(0, 2 pi, True, False)``. A run of
    pieces with one DBG starts (ends) at an arc endpoint, included when the run's first
    (last) piece is that point rather than the open interval next to it."""
    whole = (0.0, TWO_PI, True, False)
    ends = np.sort(_ends(arcs))
    if len(ends):
        gap = np.diff(np.r_[ends, ends[0] + TWO_PI])
        ends = ends[gap > MERGE_TOL]
    if not len(ends):
        g = arc_dbgs(arcs, n, np.zeros(1))[0]
        return [(1, 0.0, g, whole)]
    # pieces around the circle: endpoint k, then the open interval to endpoint k + 1
    nxt = np.r_[ends[1:], ends[0] + TWO_PI]
    starts = np.column_stack([ends, ends]).reshape(-1)
    stops = np.column_stack([ends, nxt]).reshape(-1)
    probe = np.column_stack([ends, 0.5 * (ends + nxt)]).reshape(-1)
    dbgs = arc_dbgs(arcs, n, probe)
    keys = [g.succ for g in dbgs]
    # merge runs of equal DBGs, starting after a change so that no run wraps round
    m = len(keys)
    change = [k for k in range(m) if keys[k] != keys[k - 1]]
    if not change:
        return [(1, 0.0, dbgs[0], whole)]
    out = []
    runs = [(c, change[(q + 1) % len(change)]) for q, c in enumerate(change)]
    for a, b in runs:
        b_idx = b if b > a else b + m  # the run is pieces a .. b - 1 (mod m)
        lo = starts[a]
        hi = stops[(b_idx - 1) % m] + (TWO_PI if b_idx - 1 >= m else 0.0)
        # even pieces are the endpoints themselves, odd ones the open intervals
        span = (float(lo), float(hi), a % 2 == 0, (b_idx - 1) % 2 == 0)
        length = hi - lo
        dim = 0 if length < eta else 1
        phi = _representative(arcs, n, sliding, lo, hi, dbgs[a], dim, eta)
        out.append((dim, phi, dbgs[a], span))
    return sorted(out, key=lambda r: r[1])


def narrow(length: float, eta: float) -> bool:
    """Whether a region ``length`` radians long is at most :data:`BAND_ETA` ``eta`` (radians)
    wide: the bound of the erosion's bands (module docstring)."""
    return length <= BAND_ETA * eta


def _representative(arcs: Mapping[tuple[int, int], np.ndarray], n: int, sliding: np.ndarray,
                    lo: float, hi: float, g: DBG, dim: int, eta: float) -> float:
    """The direction (angle in ``[0, 2 pi)``) of the region of dimension ``dim`` and DBG ``g``
    from ``lo`` to ``hi`` (counter-clockwise, radians): its middle, or a sliding direction of
    ``sliding`` in it (see the module docstring)."""
    mid, length = 0.5 * (lo + hi), hi - lo
    if dim == 0 or narrow(length, eta):
        t = np.mod(sliding - lo, TWO_PI)
        within = sliding[(t >= 0) & (t <= length)]
        if len(within):
            off = np.abs(np.mod(within - mid + np.pi, TWO_PI) - np.pi)
            within = within[np.argsort(off, kind="stable")]
            if dim == 0:
                return float(np.mod(within[0], TWO_PI))
            same = [k for k, h in enumerate(arc_dbgs(arcs, n, within)) if h.succ == g.succ]
            if same:
                return float(np.mod(within[same[0]], TWO_PI))
    return float(np.mod(mid, TWO_PI))


def in_plane(normals: np.ndarray) -> np.ndarray:
    """``(c,)`` whether each normal ``(c, 3)`` has a component in the plane (above
    :data:`FLAT_TOL` of its length): the others are along ``z`` (the prisms' caps)."""
    nm = np.asarray(normals, dtype=float).reshape(-1, 3)
    return np.linalg.norm(nm[:, :2], axis=1) > FLAT_TOL * np.maximum(
        np.linalg.norm(nm, axis=1), 1e-300)


def sliding_angles(normals: np.ndarray) -> np.ndarray:
    """Angles (radians, ``[0, 2 pi)``) of the directions of the plane perpendicular to the
    contact normals ``(c, 3)`` (both senses; normals along ``z`` give none)."""
    nm = np.asarray(normals, dtype=float).reshape(-1, 3)
    nm = nm[in_plane(nm)]
    a = np.arctan2(nm[:, 1], nm[:, 0])
    return np.unique(np.mod(np.concatenate([a + np.pi / 2, a - np.pi / 2]), TWO_PI))


def direction(phi: float) -> tuple[float, float]:
    """The unit vector of angle ``phi``, components below 1e-15 set to zero (an axis comes
    out exact)."""
    c, s = np.cos(phi), np.sin(phi)
    return (float(c) if abs(c) > 1e-15 else 0.0, float(s) if abs(s) > 1e-15 else 0.0)


def boundary_distance(arcs: Mapping[tuple[int, int], np.ndarray], phi: np.ndarray
                      ) -> np.ndarray:
    """Angle ``(m,)`` (radians) from each of ``phi`` to the nearest arc endpoint: where the
    lookup is robust (``inf`` without arcs)."""
    out = np.full(len(phi), np.inf)
    for e in _ends(arcs):
        off = np.abs(np.mod(np.asarray(phi) - e + np.pi, TWO_PI) - np.pi)
        out = np.minimum(out, off)
    return out

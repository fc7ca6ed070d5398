"""The infinite-translation NDBG of a 2D assembly on S^1, exactly, from the open cones
(paper section 5.3).

2D parts are extruded to prisms and their blocked sets ``B_ij`` computed as for 3D parts;
the plane's directions are the equator ``z = 0``. Each open cone meets it in an open arc
(:func:`cone_arcs`); the arcs' endpoints cut the circle into points and open intervals with
one DBG each, and neighbouring pieces with the same DBG are one region
(:func:`equator_regions`). A region's direction is its middle, or a contact's sliding
direction inside it (:func:`_representative`).
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
#: direction is represented by it (:func:`_representative`): the erosion's band round a
#: sliding direction is ``0.12 diagonal / L`` ``eta`` wide for walls ``L`` long (50: ``L`` down
#: to 0.24 % of the diagonal, 24 ``eps``). Without a bound, regions whose middle the direct
#: sweep test frees would move too (e.g. out of a wide pocket, to along its wall). Every
#: 1-dimensional region at most this wide is thin (:func:`narrow`). The random-assembly
#: figures that chose 50 are in benchmarks/NOTES.md.
BAND_ETA = 50.0  # not infinite.SNAP_ETA (3D: how far from a thin cell circles are sought)


def cone_arcs(cones: np.ndarray, shrink: float) -> np.ndarray:
    """The open arcs ``(q, 2)`` (``lo`` in ``[0, 2 pi)``, ``lo < hi <= lo + 2 pi``, radians)
    in which the open cones ``(p, k, 3)`` (zero rows: no constraint) meet the equator, each
    shrunk by ``shrink`` at both ends; the cones that miss it, or whose arc is shorter than
    ``2 shrink``, give none.

    Each facet normal ``m`` gives the open half-circle ``|phi - atan2(m_y, m_x)| < pi / 2``;
    a facet normal along ``z`` (the prisms' caps) gives none: such a cone only *touches* the
    equator, which its open set does not contain. (The closed chart polygons would take
    those cones for blocking: the cap terms of ``z > 0`` and ``z < 0`` meet along it.) The
    callers shrink by :data:`~ndbg_cli.ndbg.infinite.build.OPEN_TOL`, as the 3D exact test
    does with a cone's facets; a direction is blocked when strictly inside an arc."""
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
    contacts' sliding directions (a thin region's direction, see :func:`_representative`)."""
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
    wide: the bound of the erosion's bands (:func:`_representative`).

    Such a region is *thin* (:attr:`ndbg_cli.ndbg.model.Region.thin`):
    :func:`ndbg_cli.planning.plans.pick_region` ranks it with the 0-dimensional regions (by
    the contacts its direction slides along, then dimension), after the wider 1-dimensional
    regions, whose middles lie more than ``BAND_ETA / 2`` ``eta`` from their ends (past the
    band of any contact down to 0.24 % of the diagonal). A one-sided band beside a sliding
    direction (``3 eps / L`` radians, ``0.06 diagonal / L`` ``eta``) is thin for contacts down
    to 0.12 % of the diagonal, so a step free in a band and in the region at its sliding
    direction, or in a wide region beside it, is reported along the latter, which the direct
    sweep test frees. A thin region need not be a band (at the default tolerance
    ``BAND_ETA eta`` is 0.25 rad, 14 degrees, e.g. fig3-2d's arc from 0.1 to 14 degrees above
    +x): it is only ranked later; its dimension, direction and DBG are unchanged."""
    return length <= BAND_ETA * eta


def _representative(arcs: Mapping[tuple[int, int], np.ndarray], n: int, sliding: np.ndarray,
                    lo: float, hi: float, g: DBG, dim: int, eta: float) -> float:
    """The direction (angle in ``[0, 2 pi)``) of the region of dimension ``dim`` and DBG ``g``
    from ``lo`` to ``hi`` (counter-clockwise, radians): its middle, or a sliding direction of
    ``sliding`` in it.

    A region shorter than ``eta`` (``ANGULAR_FACTOR * eps / diagonal``, 5e-3 rad at the
    default tolerance) is 0-dimensional. Near a contact's sliding direction the erosion (both
    parts moved ``1.5 eps`` inward) widens a zero-clearance slot's single free direction into
    a band ``3 eps / L`` radians past it on the side of a contact ``L`` long, where the direct
    sweep test (:mod:`ndbg_cli.ndbg.infinite.sweep`, no erosion; ``ndbg query``) blocks. So:

    * a 0-dimensional region takes the sliding direction within its extent (ends included)
      nearest its middle, when there is one;
    * a 1-dimensional region at most :data:`BAND_ETA` ``eta`` wide takes the sliding direction
      nearest its middle among those *in* it (strictly inside, or at a closed end whose DBG,
      read from the arcs, is the region's); its dimension and DBG are unchanged;
    * a wider region keeps its middle: the parts leave a real range of directions free there,
      and the middle is the direction farthest from its ends.

    Angles are in radians and ``eta`` a fixed multiple of the relative length tolerance, so
    turning or scaling the assembly changes neither choice. Regions *next to* a sliding
    direction, on one side, where the sweep also penetrates a wall by less than ``3 eps``,
    keep their middles, within the length tolerance like every region of the eroded parts."""
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

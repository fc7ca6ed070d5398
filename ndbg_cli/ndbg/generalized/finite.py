"""Finite rotations and screw motions: whether one side of a subassembly follows a motion of
the generalized family over a whole angle without crossing the rest.

The generalized NDBG (paper section 5.2) names the motions that are free *infinitesimally*
(an LP over the contacts' twists): a necessary condition for a plan's step. A step is proven
when its moved side follows the motion for a finite angle and then leaves by a translation to
infinity; this module checks the first part, the direct sweep test
(:mod:`ndbg_cli.ndbg.infinite.sweep`) the second.

The check. A screw motion about the line through ``c`` along the unit ``a``, advancing ``h``
per radian (``h = 0``: a rotation), moves a point ``x`` to
``c + R(a, t) (x - c) + h t a``. Over an angle interval of width ``D < pi`` a point's path is
an arc (shifted along ``a`` for a screw), which lies in the triangle of its two ends and the
point where the arc's end tangents meet (at ``1 / cos(D / 2)`` of the radius, mid-angle), and
for a screw in that triangle swept over the interval's advance. So every position of a moving
triangle over the interval lies in the convex hull of those 9 (or 18) points per vertex
(:meth:`Screw.hull_points`). A hull and a fixed triangle whose projections on some axis
overlap by at most ``eps`` have no position that crosses the triangle by more than ``eps``
along that axis (:func:`_separated`: the axes are the fixed triangle's normal, the moving
triangle's at both ends of the interval and mid-way, and the cross products of their edges,
which separate two triangles whenever any axis does). ``eps`` is a rounding allowance, far
below the length tolerance: faces that slide on each other (a key turning on its floor) pass,
and faceted cylinders turning in faceted bores (which cross by their chord sag) do not. A pair
that fails is tested again with its moving triangle cut in two and its interval in two (the
parts' hulls lie in the whole's), down to intervals of ``min_step``; the motion is free when
every pair passes, and otherwise blocked, as far as this test knows, from the start of the
first interval that fails.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ...contacts.facets import box_tree, origin_distance_2d
from ...geometry.vectors import cross, plane_basis

__all__ = ["Screw", "MotionCheck", "check_motion", "alignment_angles"]


@dataclass(frozen=True)
class Screw:
    """A screw motion: about the line through ``center`` along the unit ``axis``, advancing
    ``advance`` (unit per radian) along it; a rotation when ``advance`` is 0."""

    center: np.ndarray
    axis: np.ndarray
    advance: float

    @classmethod
    def from_twist(cls, twist) -> Screw:
        """The screw of the twist ``(v, w)`` (a point ``p`` moves at ``v + w x p``,
        :mod:`ndbg_cli.ndbg.generalized.twist`), ``w`` not zero: per radian about
        ``w / |w|``, through ``w x v / |w|^2``, advancing ``w . v / |w|^2``.

        >>> s = Screw.from_twist([0, 0, 0.5, 0, 0, 2.0])
        >>> s.axis.tolist(), s.advance
        ([0.0, 0.0, 1.0], 0.25)
        """
        x = np.asarray(twist, dtype=float)
        v, w = x[:3], x[3:]
        ww = float(w @ w)
        if ww <= 0:
            raise ValueError("a translation is not a screw motion")
        return cls(cross(w, v) / ww, w / np.sqrt(ww), float(w @ v) / ww)

    def cylindrical(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``(along, radial)`` of ``points`` (any shape ending in 3): each point's coordinate
        along the axis from ``center``, and its offset square to the axis (which the motion
        turns and keeps the length of)."""
        rel = np.asarray(points, dtype=float) - self.center
        along = rel @ self.axis
        return along, rel - along[..., None] * self.axis

    def move(self, points: np.ndarray, angle: float) -> np.ndarray:
        """``points`` (any shape ending in 3) after turning by ``angle`` radians."""
        along, radial = self.cylindrical(points)
        return (self.center + (along + self.advance * angle)[..., None] * self.axis
                + self._turn(radial, angle))

    def _turn(self, radial: np.ndarray, angle: float) -> np.ndarray:
        return radial * np.cos(angle) + cross(self.axis, radial) * np.sin(angle)

    def hull_points(self, tris: np.ndarray, t0: float, t1: float) -> np.ndarray:
        """``(k, m, 3)`` points whose convex hull holds every position of each triangle of
        ``tris`` ``(k, 3, 3)`` for angles in ``[t0, t1]`` (``t1 - t0 < pi``): per vertex its
        two ends and the meeting point of its arc's end tangents (``m = 9``), each at both
        ends of the interval's advance for a screw (``m = 18``)."""
        along, radial = self.cylindrical(tris)
        half = (t1 - t0) / 2.0
        arc = [self._turn(radial, t0), self._turn(radial, t1),
               self._turn(radial, t0 + half) / np.cos(half)]
        shifts = (t0, t1) if self.advance else (t0,)
        pts = [self.center + (along + self.advance * s)[..., None] * self.axis + p
               for s in shifts for p in arc]
        return np.concatenate(pts, axis=1)


@dataclass(frozen=True)
class MotionCheck:
    """What :func:`check_motion` found: ``free`` over ``[0, angle]``; otherwise ``blocked_at``
    (the start of the first interval it could not clear) and the triangle pair there
    (``moving``, ``fixed`` indices), or ``over_budget``; ``intervals`` tested, ``pairs``
    tested."""

    free: bool
    angle: float
    blocked_at: float | None = None
    moving: int | None = None
    fixed: int | None = None
    intervals: int = 0
    pairs: int = 0
    over_budget: bool = False


#: Widest angle interval first tested (radians): hulls of wider arcs are coarse.
FIRST_STEP = np.pi / 8


def check_motion(screw: Screw, moving: np.ndarray, fixed: np.ndarray, angle: float,
                 eps: float, min_step: float, budget: int = 20_000_000,
                 start: float = 0.0, bands: tuple[np.ndarray, np.ndarray] | None = None
                 ) -> MotionCheck:
    """Whether triangles ``moving`` ``(k, 3, 3)`` follow ``screw`` from ``start`` to
    ``angle`` (radians, ``angle > start``) without crossing any of ``fixed`` ``(q, 3, 3)`` by
    more than ``eps`` (see the module docstring), halving failing intervals down to
    ``min_step``. Over ``budget`` pair tests the answer is "not free", at the interval
    reached.

    ``bands`` (:func:`cylinder_bands` of the moving and the fixed triangles): a pair is not
    tested when it is a facet of a cylinder about the screw's axis with its part inside
    against a facet with its part outside, or a face square to the axis, lying no nearer the
    axis than the first's band less its allowance (a shank in its hole, the hole's rim), or
    the same the other way round (a bore round a shaft, the shaft's end). The motion keeps
    every point's distance from the axis, so such a pair only ever meets across that
    cylinder, within the band where the polygons depart from the surface of revolution they
    stand for (the chord sag), which the motion slides along itself. Every other pair is
    tested, the parts' shoulders and ends included.

    Examples
    --------
    A unit cube turning about the vertical axis through its centre, on a floor it slides on:
    free. Beside a wall at ``x = 0.6``: its corner (at ``sqrt(2) / 2`` from the axis, from
    -45 degrees) reaches the wall after ``45 - acos(0.6 sqrt(2)) = 13.1`` degrees.

    >>> import trimesh
    >>> cube = trimesh.creation.box((1, 1, 1)).triangles
    >>> floor = trimesh.creation.box((4, 4, 1)).apply_translation((0, 0, -1)).triangles
    >>> wall = trimesh.creation.box((1, 4, 2)).apply_translation((1.1, 0, 0)).triangles
    >>> turn = Screw(np.zeros(3), np.array([0, 0, 1.0]), 0.0)
    >>> check_motion(turn, cube, floor, np.pi / 2, 1e-9, 1e-4).free
    True
    >>> got = check_motion(turn, cube, np.concatenate([floor, wall]), np.pi / 2, 1e-9, 1e-4)
    >>> got.free, round(float(np.degrees(got.blocked_at)), 1)
    (False, 13.1)
    """
    if not angle > start:
        raise ValueError(f"the motion must turn forward (from {start} to {angle})")
    fixed = np.asarray(fixed, dtype=float)
    moving = np.asarray(moving, dtype=float)
    tree = box_tree(fixed.min(axis=1) - eps, fixed.max(axis=1) + eps)
    n = max(1, int(np.ceil((angle - start) / FIRST_STEP)))
    edges = np.linspace(start, angle, n + 1)
    # intervals to test, in angle order: (t0, t1, moving (sub)triangles still to clear, the
    # index of the triangle of ``moving`` each comes from)
    whole = np.arange(len(moving))
    todo = [(float(edges[k]), float(edges[k + 1]), moving, whole) for k in range(n)][::-1]
    intervals = pairs = 0
    while todo:
        t0, t1, tris, origin = todo.pop()
        intervals += 1
        hull = screw.hull_points(tris, t0, t1)
        ids, counts = tree.intersection_v(hull.min(axis=1), hull.max(axis=1))
        counts = np.asarray(counts, dtype=np.int64)
        if pairs + int(counts.sum()) > budget:  # before the pairs' arrays are built
            return MotionCheck(False, angle, t0, int(origin[0]), None, intervals, pairs, True)
        rows = np.repeat(np.arange(len(tris)), counts)
        cols = np.asarray(ids, dtype=np.int64)
        if bands is not None:
            keep = ~_in_band(bands[0][origin[rows]], bands[1][cols])
            rows, cols = rows[keep], cols[keep]
        pairs += len(rows)
        bad = np.zeros(len(rows), dtype=bool)
        for s in range(0, len(rows), _CHUNK):  # memory: (chunk, m, 3) hull points at a time
            r, c = rows[s:s + _CHUNK], cols[s:s + _CHUNK]
            bad[s:s + _CHUNK] = ~_separated(hull[r], screw, tris[r], t0, t1, fixed[c], eps)
        if not bad.any():
            continue
        if t1 - t0 < 2 * min_step:
            k = int(np.flatnonzero(bad)[0])
            return MotionCheck(False, angle, t0, int(origin[rows[k]]), int(cols[k]),
                               intervals, pairs)
        # a failing triangle is split in two and its interval in two: both shrink its hull
        # (a part of a triangle turns inside the triangle's hull, over a part of the interval)
        keep = np.unique(rows[bad])
        tris, origin = _split(tris[keep]), np.repeat(origin[keep], 2)
        mid = (t0 + t1) / 2
        todo += [(mid, t1, tris, origin), (t0, mid, tris, origin)]
    return MotionCheck(True, angle, intervals=intervals, pairs=pairs)


#: Triangle pairs :func:`check_motion` tests at once.
_CHUNK = 100_000


def cylinder_bands(tris: np.ndarray, screw: Screw, allowance: np.ndarray,
                   angle_tol: np.ndarray) -> np.ndarray:
    """``(k, 4)`` per triangle of ``tris`` ``(k, 3, 3)`` (outward normals by their winding):
    the least and largest distance of its points from the screw's axis (which the motion
    keeps), its ``allowance`` (unit: the length tolerance plus its chord sag), and its kind:
    1 or -1 for a facet of a cylinder about the axis whose part lies inside (its normal
    points away from the axis) or outside it, 2 for a face square to the axis, else 0.

    A facet of a cylinder about the axis: its normal square to the axis and pointing along
    the radius at its centroid, both within ``angle_tol`` (per triangle, radians: half its
    facet angle plus the angular tolerance), its radii within its allowance. A face square
    to the axis: its normal along the axis within ``angle_tol``."""
    radial = screw.cylindrical(tris)[1]
    rmax = np.linalg.norm(radial, axis=2).max(axis=1)
    e1, e2 = plane_basis(screw.axis)
    rmin = origin_distance_2d(np.stack([radial @ e1, radial @ e2], axis=2))
    n = cross(tris[:, 1] - tris[:, 0], tris[:, 2] - tris[:, 0])
    n /= np.maximum(np.linalg.norm(n, axis=1), 1e-300)[:, None]
    out_dir = radial.mean(axis=1)
    out_dir /= np.maximum(np.linalg.norm(out_dir, axis=1), 1e-300)[:, None]
    allowance = np.asarray(allowance, dtype=float)
    tol = np.asarray(angle_tol, dtype=float)
    along = n @ screw.axis
    facing = np.einsum("ij,ij->i", n, out_dir)
    facet = ((np.abs(along) <= np.sin(tol)) & (np.abs(facing) >= np.cos(tol))
             & (rmax - rmin <= allowance))
    kind = np.where(facet, np.sign(facing), np.where(np.abs(along) >= np.cos(tol), 2.0, 0.0))
    return np.stack([rmin, rmax, allowance, kind], axis=1)


def _in_band(m: np.ndarray, f: np.ndarray) -> np.ndarray:
    """Pairs of :func:`cylinder_bands` rows (moving ``m``, fixed ``f``) that can only meet
    where one part's cylinder facet lies against the other part across that cylinder: a
    facet with its part inside against a facet with its part outside, or against a face
    square to the axis, each lying no nearer the axis than the first's band less its
    allowance (a shank in its hole, at the hole's rim), and the same the other way round (a
    bore round a shaft, at the shaft's end). With a fifth column (a group per row), only
    rows of one group (>= 0) are paired."""
    def against(c: np.ndarray, o: np.ndarray) -> np.ndarray:
        inside = (c[:, 3] == 1) & ((o[:, 3] == -1) | (o[:, 3] == 2)) \
            & (o[:, 0] >= c[:, 0] - c[:, 2])
        outside = (c[:, 3] == -1) & ((o[:, 3] == 1) | (o[:, 3] == 2)) \
            & (o[:, 1] <= c[:, 1] + c[:, 2])
        return inside | outside

    same = np.ones(len(m), dtype=bool)
    if m.shape[1] > 4:  # a joint per row (-1 for none): only a joint's two parts
        same = (m[:, 4] >= 0) & (m[:, 4] == f[:, 4])
    return same & (against(m, f) | against(f, m))


def _split(tris: np.ndarray) -> np.ndarray:
    """Each triangle ``(k, 3, 3)`` cut in two at its longest edge's midpoint ``(2 k, 3, 3)``."""
    edge = np.linalg.norm(np.roll(tris, -1, axis=1) - tris, axis=2)
    first = np.argmax(edge, axis=1)  # the edge from vertex ``first`` to the next
    k = np.arange(len(tris))
    a, b, c = tris[k, first], tris[k, (first + 1) % 3], tris[k, (first + 2) % 3]
    m = (a + b) / 2
    return np.stack([np.stack([a, m, c], axis=1), np.stack([m, b, c], axis=1)],
                    axis=1).reshape(-1, 3, 3)


def _separated(hull: np.ndarray, screw: Screw, tri: np.ndarray, t0: float, t1: float,
               fixed: np.ndarray, eps: float) -> np.ndarray:
    """Per pair ``(p,)``: whether the hull points ``hull`` ``(p, m, 3)`` and the fixed
    triangle ``fixed`` ``(p, 3, 3)`` overlap by at most ``eps`` along some axis among the
    fixed triangle's normal, the moving triangle's (``tri`` turned to ``t0``, ``t1`` and
    between) and the cross products of their edges (mid-interval)."""
    eb = np.roll(fixed, -1, axis=1) - fixed
    axes = [cross(eb[:, 0], eb[:, 1])]
    for t in (t0, t1, (t0 + t1) / 2):
        at = screw.move(tri, t)
        ea = np.roll(at, -1, axis=1) - at
        axes.append(cross(ea[:, 0], ea[:, 1]))
    axes += [cross(ea[:, i], eb[:, j]) for i in range(3) for j in range(3)]
    ok = np.zeros(len(hull), dtype=bool)
    for w in axes:
        norm = np.linalg.norm(w, axis=1)
        use = norm > 0
        w = w / np.where(use, norm, 1.0)[:, None]
        ph = np.einsum("pmd,pd->pm", hull, w)
        pf = np.einsum("pvd,pd->pv", fixed, w)
        overlap = np.minimum(ph.max(axis=1) - pf.min(axis=1), pf.max(axis=1) - ph.min(axis=1))
        ok |= use & (overlap <= eps)
    return ok


def alignment_angles(moving: np.ndarray, fixed: np.ndarray, axis: np.ndarray,
                     tol: float = 1e-9) -> np.ndarray:
    """The angles in ``(0, 2 pi)`` (ascending, distinct) that turn some unit normal of
    ``moving`` ``(k, 3)`` about the unit ``axis`` onto some unit normal of ``fixed``
    ``(q, 3)`` with the same component along it (within ``tol``): where a turned face may
    come to lie against, or slide past, a face of the rest.

    >>> alignment_angles(np.array([[1.0, 0, 0]]), np.array([[0, 1.0, 0], [1.0, 0, 0]]),
    ...                  np.array([0, 0, 1.0])).round(6).tolist()
    [1.570796]
    """
    pa, pb = moving @ axis, fixed @ axis
    ra = moving - pa[:, None] * axis
    rb = fixed - pb[:, None] * axis
    ia, ib = np.nonzero(np.abs(pa[:, None] - pb[None, :]) <= tol)
    ra, rb = ra[ia], rb[ib]
    good = (np.linalg.norm(ra, axis=1) > tol) & (np.linalg.norm(rb, axis=1) > tol)
    ra, rb = ra[good], rb[good]
    ang = np.mod(np.arctan2(np.einsum("ij,j->i", cross(ra, rb), axis),
                            np.einsum("ij,ij->i", ra, rb)), 2 * np.pi)
    ang = np.unique(np.round(ang, 12))
    return ang[(ang > tol) & (ang < 2 * np.pi - tol)]

"""Infinitesimal interlocking by linear programming (any number of hands; paper section 7.1).

Parts get translational velocities ``v_i``; for every contact normal ``n`` out of part ``a``
into part ``b`` the motion must not make ``a`` penetrate ``b``: ``n . (v_b - v_a) >= 0``
(sliding allowed), and one part (``fixed``, default the first) stays. The product is
*infinitesimally interlocked* iff the only admissible motion is ``v = 0`` (:func:`interlock`).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np

from ..geometry.lp import solve_lp

TOL = 1e-7


def _rows(n: int, pair_normals: Mapping[tuple[int, int], np.ndarray], dim: int) -> np.ndarray:
    rows = []
    for (a, b) in sorted(pair_normals):
        normals = np.asarray(pair_normals[(a, b)], dtype=float).reshape(-1, dim)
        for nv in normals:
            row = np.zeros(n * dim)
            row[b * dim:(b + 1) * dim] += nv
            row[a * dim:(a + 1) * dim] -= nv
            rows.append(row)
    return np.array(rows).reshape(-1, n * dim)


def _groups(v: np.ndarray, tol: float) -> list[list[int]]:
    """Parts grouped by equal velocity (rows of ``v``), groups ordered by their first part."""
    groups: list[list[int]] = []
    reps: list[np.ndarray] = []
    for i, vi in enumerate(v):
        for g, r in zip(groups, reps):
            if np.max(np.abs(vi - r)) <= tol:
                g.append(i)
                break
        else:
            groups.append([i])
            reps.append(vi)
    return groups


def interlock(n: int, pair_normals: Mapping[tuple[int, int], np.ndarray],
              fixed: int | None = None, *, dim: int = 3, tol: float = TOL,
              ids: Sequence[str] | None = None) -> dict:
    """Decide infinitesimal interlocking of ``n`` parts with contact normals
    ``pair_normals[(a, b)]`` (``(k, dim)`` array, out of ``a`` into ``b``).

    Returns ``{"value": interlocked, "why", "kind": "separating"|"sliding"|None,
    "separation": LP optimum, "velocities": [[...]] per part, "moved_sets": [[parts]...],
    "fixed_set": [parts], "moved_set_count": len(moved_sets), "fixed"}`` (part indices; with
    ``ids`` the ``why`` text names the parts and ``moved_ids`` lists them): parts are grouped
    by equal velocity; ``fixed_set`` is the fixed part's group, ``moved_sets`` the others (so
    the motion is an instruction with ``moved_set_count + 1`` moved sets in the paper's
    terms).

    Test: (1) maximise the total separation ``sum n . (v_b - v_a)`` under ``-1 <= v <= 1``
    (HiGHS via ``scipy.optimize.linprog``); an optimum > tol gives a separating motion; (2)
    otherwise every admissible motion keeps all contacts sliding, so the admissible set is the
    subspace ``{n . (v_b - v_a) = 0, v_fixed = 0}``, whose null-space basis (SVD) gives a
    sliding motion when nonempty (a peg sliding out of a through-hole). ``moved_set_count`` is
    the number of hands *this* motion uses, not a minimum: maximising the total separation
    spreads the parts over many velocities (a stack of boxes comes apart in several sets at
    once although lifting the top box alone would do); :func:`classes.interlock_hands` adds
    the fewest moved sets when the NDBG decides it.
    """
    fixed = 0 if fixed is None else fixed
    if n < 2:
        return {"value": False, "why": "fewer than two parts: nothing to separate",
                "kind": None, "separation": 0.0, "velocities": [], "moved_sets": [],
                "fixed_set": list(range(n)), "moved_set_count": 0, "fixed": fixed,
                "moved_ids": None if ids is None else []}
    a_rows = _rows(n, pair_normals, dim)
    nv = n * dim
    bounds = [(-1.0, 1.0)] * nv
    for k in range(dim):
        bounds[fixed * dim + k] = (0.0, 0.0)
    kind = None
    v = np.zeros(nv)
    sep = 0.0
    if len(a_rows):
        c = -a_rows.sum(axis=0)
        # v = 0 is feasible and the box bounds it, so only the solver can fail: HiGHS
        # stopped with an unknown status after its presolve on the turned engine's 3,869
        # normals (every method alike), and solves the same LP without it
        res = solve_lp(c, (("highs", {}), ("highs", {"presolve": False}),
                           ("highs-ipm", {"presolve": False})),
                       A_ub=-a_rows, b_ub=np.zeros(len(a_rows)), bounds=bounds)
        if res.status != 0:
            raise RuntimeError(f"interlocking LP failed: {res.message}")
        sep = float(-res.fun)
        if sep > tol:
            kind = "separating"
            v = np.asarray(res.x, dtype=float)
    if kind is None:
        keep = [i for i in range(nv) if not (fixed * dim <= i < (fixed + 1) * dim)]
        sub = a_rows[:, keep] if len(a_rows) else np.zeros((0, len(keep)))
        if sub.shape[0] == 0:
            basis = np.eye(len(keep))
        else:
            # only V is needed: no (rows x rows) U (costly with thousands of normals)
            _, s, vt = np.linalg.svd(sub, full_matrices=sub.shape[0] < sub.shape[1])
            rank = int(np.sum(s > tol * max(1.0, float(s.max()) if s.size else 1.0)))
            basis = vt[rank:]
        if len(basis):
            kind = "sliding"
            w = basis[0] / np.max(np.abs(basis[0]))
            v = np.zeros(nv)
            v[keep] = w
    vel = v.reshape(n, dim)
    vel = np.where(np.abs(vel) < tol, 0.0, vel)
    groups = _groups(vel, 1e-6)
    fixed_group = next(g for g in groups if fixed in g)
    moved = [g for g in groups if g is not fixed_group]
    def label(group: list[int]) -> str:
        return "{" + ", ".join(str(i) if ids is None else ids[i] for i in group) + "}"

    if kind is None:
        why = ("no simultaneous translation of any number of parts separates or slides "
               f"anything relative to part {label([fixed])}")
    else:
        how = f"LP separation {sep:.6g}" if kind == "separating" else "all contacts slide"
        # the LP's motion, not a minimum: it shows that these sets can move, not that fewer
        # sets cannot
        why = (f"the LP found a {kind} motion with {len(moved)} moved set(s) ({how})"
               f": {', '.join(label(g) for g in moved)} move relative to {label(fixed_group)}")
    return {"value": kind is None, "why": why, "kind": kind, "separation": sep,
            "velocities": [[float(x) for x in row] for row in vel], "moved_sets": moved,
            "fixed_set": fixed_group, "moved_set_count": len(moved), "fixed": fixed,
            "moved_ids": None if ids is None else [[ids[i] for i in g] for g in moved]}

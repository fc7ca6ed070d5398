"""Clashing parts kept together as one unit (the ``--interference`` policy's meaning for a
clash, :mod:`ndbg_cli.contacts.fits`).

Two parts that interpenetrate beyond a press fit or a shallow overlap cannot be separated by
any motion the paper considers, and the model does not say how they were joined (a display
model's merged bodies, a weld, a modelling error). Planning them apart would only prove that
no plan exists. So, unless the policy is ``error``, each group of parts linked by clashes
becomes one part, ``a+b+...`` (its meshes together), placed where its first member was, and
the analysis runs on that assembly; the report's interferences name the unit.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from ..core.assembly import Assembly, Part

__all__ = ["clash_units", "merge_units"]


def clash_units(n: int, pairs: list[tuple[int, int]]) -> list[list[int]]:
    """Groups (sorted, of two or more parts) of the graph on ``n`` parts whose edges are
    ``pairs``, ordered by their first member.

    >>> clash_units(5, [(3, 1), (0, 4), (4, 2)])
    [[0, 2, 4], [1, 3]]
    """
    root = list(range(n))

    def find(x: int) -> int:
        while root[x] != x:
            root[x] = root[root[x]]
            x = root[x]
        return x

    for a, b in pairs:
        ra, rb = find(a), find(b)
        if ra != rb:
            root[max(ra, rb)] = min(ra, rb)
    groups: dict[int, list[int]] = {}
    for x in range(n):
        groups.setdefault(find(x), []).append(x)
    return sorted((g for g in groups.values() if len(g) > 1), key=lambda g: g[0])


def member_order(asm: Assembly, group: list[int]) -> list[int]:
    """The part indices of a unit in the natural order of their ids, not the manifest's: a
    unit's name, members and mesh must not change when the parts are listed in another
    order (issue 34)."""
    from ..io.loaders import natural_key

    return sorted(group, key=lambda i: (natural_key(asm.ids[i]), asm.ids[i]))


def merge_units(asm: Assembly, units: list[list[int]]) -> Assembly:
    """``asm`` with each unit of ``units`` (part indices) made one part named by its members
    joined with ``+`` in the natural order of their ids (its meshes together; fixed when any
    member is; the base when it holds the base), at the place of its first member; joints
    inside a unit are dropped and the others renamed."""
    from ..io.validate import make_part

    name = {}
    merged: dict[int, Part] = {}
    for g in units:
        members = [asm.parts[i] for i in member_order(asm, g)]
        uid = "+".join(p.id for p in members)
        for p in members:
            name[p.id] = uid
        v, f, off = [], [], 0
        for p in members:
            v.append(np.asarray(p.mesh.vertices))
            f.append(np.asarray(p.mesh.faces) + off)
            off += len(p.mesh.vertices)
        part, _ = make_part(uid, np.vstack(v), np.vstack(f), source=members[0].source,
                            fixed=any(p.fixed for p in members))
        merged[g[0]] = part
    drop = {i for g in units for i in g[1:]}
    parts = tuple(merged.get(i, p) for i, p in enumerate(asm.parts) if i not in drop)
    joints = tuple(dataclasses.replace(j, parts=tuple(name.get(x, x) for x in j.parts))
                   for j in asm.joints if len({name.get(x, x) for x in j.parts}) == 2)
    base = name.get(asm.base, asm.base) if asm.base is not None else None
    return asm.replace(parts=parts, joints=joints, base=base)

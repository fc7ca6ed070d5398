"""Interlocking: the LP on the contacts, and what its answer is worth.

:func:`interlock_and_grasp` runs the interlocking LP (:mod:`ndbg_cli.planning.interlock`) on the
contacts and the grasps on the NDBGs. Both the LP and the contact-based NDBGs read an edge or
point contact as more than it blocks: the LP every normal of its cone (or, where no cone forms,
of the faces meeting there), the NDBGs the latter pair by pair, "blocking on any"
(:func:`ndbg_cli.contacts.features.edge_point_contacts`). So with such contacts the LP's
"interlocked" is a necessary condition only, and a candidate family's "no candidate tree" is
not a proof.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ..core.assembly import Assembly
from ..core.constants import INFINITE, INFINITESIMAL
from ..ndbg.model import NDBG

__all__ = ["conservative_contacts", "interlock_and_grasp"]


def conservative_contacts(analysis: Any) -> tuple[int, int]:
    """``(lp, ndbg)``: the edge and point contacts of a contact analysis (the LP reads each as
    every normal of its cone), and those of them read pair by pair, "blocking on any" (the
    NDBGs read those as every face meeting there: more than they block)."""
    found = [c for c in getattr(analysis, "contacts", ()) if getattr(c, "kind", None)
             in ("edge", "point")]
    return len(found), sum(1 for c in found if getattr(c, "blocking", "any") == "any")


def interlock_and_grasp(asm: Assembly, ca: Any, ndbgs: dict[str, NDBG]
                        ) -> tuple[dict | None, dict]:
    """Infinitesimal interlocking (LP over part velocities, any number of hands) and the
    prismatic form-closure grasps of the translational families.

    Parameters
    ----------
    asm : Assembly
        The assembly (clashing parts already made units).
    ca : ContactAnalysis
        Its contacts.
    ndbgs : dict
        Family name -> NDBG, the usable ones.

    Returns
    -------
    tuple
        The LP's result (with ``exact`` false when edge or point contacts make its yes a
        necessary condition only; None without a translational family) and the grasps per
        family.
    """
    from ..planning.fingers import exterior_faces
    from ..planning.grasp import grasp
    from ..planning.interlock import interlock

    dim = asm.dimension
    normals: dict[tuple[int, int], list[np.ndarray]] = {}
    for c in ca.contacts:
        normals.setdefault((c.a, c.b), []).append(np.asarray(c.normals, float).reshape(-1, dim))
    # a declared thread (the translational NDBGs block its pair both ways) holds its pair
    # together: every axis both ways, i.e. equal velocities
    threads = _threads_of(asm, ndbgs)
    for a, b in threads:
        normals.setdefault((a, b), []).append(np.vstack([np.eye(dim), -np.eye(dim)]))
    pair_normals = {k: np.concatenate(v) for k, v in sorted(normals.items())}
    fixed = asm.index(asm.base) if asm.base is not None else 0
    lock = None
    if INFINITESIMAL in ndbgs or INFINITE in ndbgs:
        lock = interlock(len(asm), pair_normals, fixed, dim=dim, ids=asm.ids)
        lock.pop("velocities", None)
        if threads:
            lock["why"] += " (declared threads hold " + ", ".join(
                f"{asm.ids[a]} and {asm.ids[b]}" for a, b in threads) + " together)"
        edge_point = conservative_contacts(ca)[0]
        if edge_point:  # ``exact`` false: its yes is a necessary condition only
            lock["exact"] = False
            lock["why"] += (f" ({edge_point} edge/point contacts read as every normal of their "
                            "cone: conservative, may call a product interlocked that is not)")
    faces = exterior_faces(asm)
    grasps = {fam: grasp(ndbgs[fam], faces) for fam in (INFINITESIMAL, INFINITE)
              if fam in ndbgs}
    return lock, grasps


def _threads_of(asm: Assembly, ndbgs: dict[str, NDBG]) -> list[tuple[int, int]]:
    """The threaded pairs (part indices) the translational NDBGs block both ways
    (:func:`~ndbg_cli.ndbg.generalized.build.block_threads` records them)."""
    nd = ndbgs.get(INFINITESIMAL) or ndbgs.get(INFINITE)
    pairs = (nd.stats.get("threaded_pairs") or []) if nd is not None else []
    return sorted((asm.index(a), asm.index(b)) for a, b in pairs
                  if a in asm.ids and b in asm.ids)


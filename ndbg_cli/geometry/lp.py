"""Linear programs solved by HiGHS (``scipy.optimize.linprog``), retried with other variants
of it when one stops without an answer: on nearly degenerate constraints HiGHS can end with
an unset or unknown status that another of its methods, or the same without its presolve,
does not (:func:`ndbg_cli.geometry.sphere.cone_boundary_circles`' implicit equalities, the
interlocking test of :mod:`ndbg_cli.planning.interlock`).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

__all__ = ["solve_lp"]


def solve_lp(c: np.ndarray, attempts: Sequence[tuple[str, dict]], **kwargs):
    """The first optimal result of ``linprog(c, method=method, options=options, **kwargs)``
    over ``attempts`` (``(method, options)`` pairs, tried in turn), or the last result when
    none is optimal (its ``status`` is then not 0).

    scipy.optimize is imported here, when a program is solved, not when ndbg starts.

    Examples
    --------
    >>> res = solve_lp([-1.0], (("highs", {}), ("highs-ipm", {})), bounds=[(0.0, 2.0)])
    >>> res.status, float(res.x[0])
    (0, 2.0)
    """
    from scipy.optimize import linprog

    res = None
    for method, options in attempts:
        res = linprog(c, method=method, options=dict(options), **kwargs)
        if res.status == 0:
            break
    return res

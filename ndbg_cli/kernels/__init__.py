"""The compiled kernels: numba loops over plain arrays, the lowest layer of the package.

Each private ``_*_kernels`` module holds the hot loops of one stage as ``@njit`` functions of
C-contiguous arrays, its entry points listed in its ``EXPORTS``; the wrappers above take
them by name from :func:`ndbg_cli.kernels.compiled.loaded`: compiled ahead of time when
built (``make bytecode``, ``python -m ndbg_cli.kernels``), else through numba's just-in-time
compiler. Like shapely's GEOS layer, nothing here imports the rest of ``ndbg_cli``; the
wrappers (:mod:`ndbg_cli.ndbg.infinite`, ...) convert, check and document.

* ``_cone_kernels``, ``_cover_kernels``, ``_term_kernels``, ``_union_kernels``: the exact
  infinite-translation NDBG (blocking cones on the cube map, their arrangement, coverage);
* ``_sweep_kernels``: the direct sweep test, the proofs' oracle (it shares no code with the
  arrangement's);
* :mod:`.cube_faces`: the cube map's faces, a constant of the kernels and of their wrappers,
  importable without numba.
"""

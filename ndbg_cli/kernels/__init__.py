"""The compiled kernels: numba loops over plain arrays, the lowest layer of the package.

Each private ``_*_kernels`` module holds the hot loops of one stage as ``@njit`` functions of
C-contiguous arrays, its entry points listed in its ``EXPORTS``; the wrappers above take
them by name from :func:`ndbg_cli.kernels.compiled.loaded`: compiled ahead of time when
built (``make bytecode``, ``python -m ndbg_cli.kernels``), else through numba's just-in-time
compiler. Like shapely's GEOS layer, nothing here imports the rest of ``ndbg_cli``; the
wrappers (:mod:`ndbg_cli.ndbg.infinite`, :mod:`ndbg_cli.contacts.bvh`,
:mod:`ndbg_cli.contacts.facets`) convert, check and
document. ``loaded`` is the kernel modules' only way in: no module imports one.

* ``_cone_kernels``, ``_cover_kernels``, ``_term_kernels``, ``_union_kernels``: the exact
  infinite-translation NDBG (blocking cones on the cube map, their arrangement, coverage);
* ``_sweep_kernels``: the direct sweep test, the proofs' oracle (it shares no code with the
  arrangement's);
* ``_box_kernels``: a bounding-volume hierarchy over boxes and the pairs that meet
  (:class:`ndbg_cli.contacts.bvh.BoxHierarchy`: the narrow phase, the finger probes);
* ``_triangle_kernels``: the narrow phase's triangle predicates (closest points, triangle
  distances, separating-axis gaps: :mod:`ndbg_cli.contacts.facets`);
* :mod:`.cube_faces`: the cube map's faces, a constant of the kernels and of their wrappers,
  importable without numba.
"""

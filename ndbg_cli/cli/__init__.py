"""The ``ndbg`` command line: a thin click layer over the library (``main`` is the entry point)."""

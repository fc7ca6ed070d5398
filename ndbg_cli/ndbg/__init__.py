"""The non-directional blocking graph (paper sections 4.2 and 4.4): DBGs as bitsets, the NDBG and
its partitionings; one subpackage per motion family."""

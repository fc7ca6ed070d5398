"""The NDBG for generalized motions (paper sections 5.2 and 6): twists, the local-freedom LP,
suggested rotations and screws."""

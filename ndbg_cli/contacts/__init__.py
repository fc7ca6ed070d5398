"""Contacts between parts (paper sections 4.3 and 5.1): touching pairs, contact features and
normals, near misses, interferences; 3D meshes and 2D polygons."""

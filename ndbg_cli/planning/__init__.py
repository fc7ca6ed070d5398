"""Measures and plans from the NDBGs (paper section 7): the AND/OR graph, decompositions,
classes, assembly plans and their verification, removal, interlocking, grasps."""

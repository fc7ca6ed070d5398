"""The NDBG for infinite translations (paper section 5.3): blocked-direction sets on the cube
map, their arrangement and the direct sweep test; their compiled loops are in
:mod:`ndbg_cli.kernels`."""

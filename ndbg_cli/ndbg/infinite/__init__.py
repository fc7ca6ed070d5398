"""The NDBG for infinite translations (paper section 5.3): blocked-direction sets on the cube
map, their arrangement and the direct sweep test; compiled kernels in the private
``_*kernels`` modules, which import no wrapper."""

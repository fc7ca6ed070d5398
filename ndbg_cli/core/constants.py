"""Names and tolerances shared by every stage: the motion families' report keys and the
angular tolerances (each name says its unit).

One table, so that a family is spelled the same in the NDBGs, the plans, the classes and the
report (paper sections 5.1-5.3 and 6 define the three families).
"""

from __future__ import annotations

import math

#: Infinitesimal translations (paper sections 4.2-4.5, 5.1).
INFINITESIMAL = "infinitesimal_translation"
#: Infinite translations, each to infinity along one direction (paper section 5.3).
INFINITE = "infinite_translation"
#: Generalized motions: rotations and screws as well as translations (paper section 6).
GENERALIZED = "generalized"
#: Every family, in the order the reports list them.
FAMILIES = (INFINITESIMAL, INFINITE, GENERALIZED)
#: The translational families: their plans are algorithms of single translations.
TRANSLATION = (INFINITESIMAL, INFINITE)

#: Default relative length tolerance: lengths below ``DEFAULT_RELATIVE_TOLERANCE`` times the
#: model's size (``Assembly.size``, the same in any frame) are treated as zero (gaps, overlaps,
#: coplanarity).
DEFAULT_RELATIVE_TOLERANCE = 1e-4

#: Smallest length tolerance, in the assembly unit and relative to the model's size:
#: the default is never below it and an explicit one below it is refused. Under 1e-12 of the
#: model's size the coordinates' own rounding (2.2e-16 of their magnitude) is no longer
#: negligible beside it, and under 1e-12 absolute a report, whose floats stop at 1e-15
#: (``report.document.ZERO``), could not state it.
MIN_TOLERANCE = 1e-12


#: Work units an AND/OR search may spend by default (``planning.andor.Budget.max_work``;
#: paper section 7.2). A unit is one DBG induced on a subassembly being expanded, one region
#: listed for one of its candidate partitionings, or one node of its contact-connected set
#: search: a count that does not depend on the machine, unlike the clock. Calibrated on the
#: 115-part engine so that a search there stops within a couple of seconds (benchmarks/NOTES.md).
WORK_LIMIT = 5_000_000


#: Parts above which the default run does not compute the infinite-translation NDBG over the
#: whole sphere (3D), whatever its triangles: every pair of parts blocks the other in some
#: directions, so the arrangement of the n(n-1) blocked sets has O(n^4) regions at worst, and
#: the stages after it work per region (racks of boards on standoffs: 16 parts 3,604 regions,
#: 36 parts 10,906, 56 parts 22,438 and over a minute in all; benchmarks/NOTES.md). Above it
#: the plan is proposed by the infinitesimal NDBG and proven by the sweep test, which decides
#: the infinite family's classes when it succeeds; ``--motion infinite`` computes it anyway.
INFINITE_MAX_PARTS = 40

#: Angle (radians, 1e-6 rad ~ 0.2 arc-seconds) below which two directions of the arrangements
#: are one (merged normals, vertices) and a direction lies on a great circle (sign tests).
ANGLE_TOL_RAD = 1e-6
#: Angle (radians, the value is 1 degree) within which triangle normals form one contact
#: normal and two faces count as facing (the contact finder's ``angle_tolerance`` default).
CONTACT_ANGLE_TOL_RAD = math.radians(1.0)


#: Seconds a model file's reader may take by default (``--load-timeout``): a STEP product of a
#: few hundred parts tessellates in well under a minute at the default deflection; the limit
#: is there to end a reader that hangs on a damaged file, not to cut real products short.
LOAD_TIMEOUT_S = 120.0
#: Address space (GiB) a native reader's process may use by default (``--load-memory``):
#: OpenCASCADE needs a few GiB for a large product; a damaged file that makes it allocate
#: without end fails at this limit instead of driving the machine into swap.
LOAD_MEMORY_GIB = 16.0
#: Triangles one assembly may have by default (``--max-triangles``), counted as its files are
#: read: the stages' memory grows with them (about 2.4 kB a triangle at the peak of a
#: translation analysis of two 82k-triangle spheres: 585 MB), so 5 million need about
#: 12 GB, what a 16 GB workstation can hold. A larger input fails at once with a one-line
#: error instead of swapping or being killed; the largest real models analysed so far (AS1,
#: the engine, the finely tessellated gearbox: under 0.5 million) are well below it.
MAX_TRIANGLES = 5_000_000
#: Linear deflection (mm, OpenCASCADE's working unit) of STEP/IGES tessellation by default:
#: the largest distance between a facet and the exact surface. Kept since the first release
#: (reports of STEP files depend on it).
STEP_DEFLECTION_MM = 0.01
#: For a model larger than 1 m the default deflection grows with its size: this fraction of
#: its bounding-box diagonal (ten times below the default length tolerance, 1e-4 x diagonal,
#: so faceting never looks like a gap or an overlap to the contact stage). Below 1 m the
#: fixed :data:`STEP_DEFLECTION_MM` wins, which keeps every smaller model's tessellation.
DEFLECTION_RELATIVE = 1e-5
#: Angular deflection (radians) of STEP/IGES tessellation.
STEP_ANGULAR_DEFLECTION_RAD = 0.5

__all__ = ["INFINITESIMAL", "INFINITE", "GENERALIZED", "FAMILIES", "WORK_LIMIT", "ANGLE_TOL_RAD",
           "CONTACT_ANGLE_TOL_RAD",
           "LOAD_TIMEOUT_S", "LOAD_MEMORY_GIB", "MAX_TRIANGLES", "STEP_DEFLECTION_MM",
           "DEFLECTION_RELATIVE",
           "STEP_ANGULAR_DEFLECTION_RAD"]

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

#: Work units an AND/OR search may spend by default (``planning.andor.Budget.max_work``;
#: paper section 7.2). A unit is one DBG induced on a subassembly being expanded, one region
#: listed for one of its candidate partitionings, or one node of its contact-connected set
#: search: a count that does not depend on the machine, unlike the clock. Calibrated on the
#: 115-part engine so that a search there stops within a couple of seconds (benchmarks/NOTES.md).
WORK_LIMIT = 5_000_000


#: Angle (radians, 1e-6 rad ~ 0.2 arc-seconds) below which two directions of the arrangements
#: are one (merged normals, vertices) and a direction lies on a great circle (sign tests).
ANGLE_TOL_RAD = 1e-6
#: Angle (radians, the value is 1 degree) within which triangle normals form one contact
#: normal and two faces count as facing (the contact finder's ``angle_tolerance`` default).
CONTACT_ANGLE_TOL_RAD = math.radians(1.0)

__all__ = ["INFINITESIMAL", "INFINITE", "GENERALIZED", "FAMILIES", "ANGLE_TOL_RAD",
           "CONTACT_ANGLE_TOL_RAD", "WORK_LIMIT"]

"""Names and tolerances shared by every stage: the motion families' report keys.

One table, so that a family is spelled the same in the NDBGs, the plans, the classes and the
report (paper sections 5.1-5.3 and 6 define the three families).
"""

from __future__ import annotations

#: Infinitesimal translations (paper sections 4.2-4.5, 5.1).
INFINITESIMAL = "infinitesimal_translation"
#: Infinite translations, each to infinity along one direction (paper section 5.3).
INFINITE = "infinite_translation"
#: Generalized motions: rotations and screws as well as translations (paper section 6).
GENERALIZED = "generalized"
#: Every family, in the order the reports list them.
FAMILIES = (INFINITESIMAL, INFINITE, GENERALIZED)

#: Work units a search may spend by default (:attr:`ndbg_cli.planning.andor.Budget.max_work`). A unit is one DBG
#: induced on a subassembly being expanded, one region listed for one of its candidate
#: partitionings, or one node of its contact-connected set search (``andor.node_splits``): a
#: count that does not depend on the machine, unlike the clock. Calibrated on the 115-part
#: engine, whose 8,110 distinct DBGs make one subassembly cost up to ~10^6 units: its AND/OR
#: build spends about 0.35 s per million units (one core of the reference machine), so a
#: search stops within about 2 s there, as the former 2 s default time limit did; the bell's
#: and AS1's builds spend 5,000 and 29,000 units.
WORK_LIMIT = 5_000_000

__all__ = ["INFINITESIMAL", "INFINITE", "GENERALIZED", "FAMILIES", "WORK_LIMIT"]

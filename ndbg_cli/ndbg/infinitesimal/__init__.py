"""The NDBG for infinitesimal translations (paper sections 4.2-4.5 and 5.1)."""

"""JUnit XML for ``ndbg check --junit FILE``: one test case per assembly, so CI systems
(GitLab, Jenkins, GitHub test reporters) list each design with its violated rules."""

from __future__ import annotations

import xml.etree.ElementTree as ET

from .rules import Outcome


def junit_xml(outcomes: list[list[Outcome]], suite: str = "ndbg check") -> str:
    """The XML document for per-assembly outcome lists (in batch order). A failed rule is a
    ``<failure>``, an assembly that could not be analysed an ``<error>``; passing and
    undecided-but-passed rules go to ``<system-out>``."""
    root = ET.Element("testsuites", name=suite)
    failures = sum(1 for oc in outcomes if any(not o.passed and o.rule != "analysis" for o in oc))
    errors = sum(1 for oc in outcomes if any(o.rule == "analysis" for o in oc))
    ts = ET.SubElement(root, "testsuite", name=suite, tests=str(len(outcomes)),
                       failures=str(failures), errors=str(errors), skipped="0")
    for oc in outcomes:
        if not oc:
            continue
        first = oc[0]
        case = ET.SubElement(ts, "testcase", name=first.assembly, classname=first.source or
                             first.assembly)
        if first.rule == "analysis":
            el = ET.SubElement(case, "error", message=first.reason, type="analysis")
            el.text = first.reason
            continue
        bad = [o for o in oc if not o.passed]
        if bad:
            el = ET.SubElement(case, "failure", type="rule",
                               message=f"{len(bad)} rule(s) violated: "
                                       + ", ".join(o.rule for o in bad))
            el.text = "\n".join(o.line() for o in bad)
        ET.SubElement(case, "system-out").text = "\n".join(o.line() for o in oc)
    ET.indent(root)
    return '<?xml version="1.0" encoding="UTF-8"?>\n' + ET.tostring(root, encoding="unicode") \
        + "\n"

"""Loading the external assemblies in ../shared/data (facts from its README)."""

from __future__ import annotations

import pytest

import ndbg_cli

from conftest import shared

pytestmark = pytest.mark.external


def test_as1_step_has_18_watertight_parts_in_mm():
    asm = ndbg_cli.load(shared("as1", "as1-oc-214.stp"))
    assert len(asm) == 18
    assert asm.units == "mm"
    assert all(p.check.watertight for p in asm.parts), "merging split vertices closes every part"
    assert not [d for d in asm.diagnostics if d.level == "error"]
    # the plate is about 200 mm wide: the file is in millimetres, not metres
    plate = asm.part("plate_1")
    assert 150 < max(plate.bounds[1] - plate.bounds[0]) < 300
    assert sum(1 for i in asm.ids if i.startswith("nut")) == 8
    assert sum(1 for i in asm.ids if i.startswith("bolt")) == 6

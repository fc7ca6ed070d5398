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


def test_beam_assembled_directory_has_5_parts():
    asm = ndbg_cli.load(shared("beam", "assembled"))
    assert sorted(asm.ids) == ["0", "1", "2", "3", "6"]
    assert all(p.check.watertight for p in asm.parts)
    assert not asm.diagnostics


@pytest.mark.parametrize("name,count", [("six-piece-000", 6), ("six-piece-001", 6),
                                        ("six-piece-002", 6), ("six-piece-257", 6),
                                        ("six-piece-258", 6), ("pelikan", 7)])
def test_burrs_load_as_closed_voxel_solids(name, count):
    asm = ndbg_cli.load(shared("burr", name))
    assert len(asm) == count
    for p in asm.parts:
        assert p.check.watertight, p.id
        # unit voxels: every piece's volume is a whole number of cubes
        assert p.check.volume == pytest.approx(round(p.check.volume), abs=1e-6), p.id
    assert {d.code for d in asm.diagnostics} <= {"non-manifold"}


def test_engine_glb_loads_with_warnings_not_a_crash():
    asm = ndbg_cli.load(shared("engine", "2CylinderEngine.glb"))
    assert len(asm) == 115
    assert sum(p.check.triangles for p in asm.parts) > 100_000
    codes = {d.code for d in asm.diagnostics}
    assert "not-watertight" in codes
    assert all(d.level == "warning" for d in asm.diagnostics)


def test_cli_as1_json_report():
    import json

    from helpers import run_cli

    r = run_cli("analyze", shared("as1", "as1-oc-214.stp"), "--format", "json")
    assert r.returncode == 0, r.stderr
    doc = json.loads(r.stdout)
    assert doc["schema"] == "ndbg.report/1"
    parts = doc["assembly"]["parts"]
    assert len(parts) == 18
    assert all(p["watertight"] and p["triangles"] > 0 for p in parts)

"""Interferences of real CAD (:mod:`ndbg_cli.contacts.fits`): press fits, overlaps and clashes in
the shipped examples, against the hand-derived facts of their ``expect`` blocks; and the answer
unchanged when a product's cylinders are tessellated coarser or finer, or turned about their
axes (facet edges must not create blocking the real parts do not have)."""

import importlib.util
import json

import numpy as np
import pytest

import ndbg_cli
from ndbg_cli.core.assembly import Assembly
from ndbg_cli.io.validate import make_part
from ndbg_cli.ndbg.infinite.sweep import SweepChecker
from tests.conftest import ASSEMBLIES


def _interference(report, a, b):
    got = [x for x in report["interferences"] if {x["a"], x["b"]} == {a, b}]
    assert len(got) == 1, (a, b)
    return got[0]


def _free(asm, moved, d):
    """The direct sweep test: ``moved`` (ids) leaves the rest of ``asm`` along ``d``."""
    s = SweepChecker(asm)
    m = sum(1 << asm.index(p) for p in moved)
    return s.frees(m, ((1 << len(asm)) - 1) & ~m, np.asarray(d, float))


def test_press_fit_example_is_classified_and_its_plan_presses():
    asm = ndbg_cli.load(ASSEMBLIES / "press-fit.yaml")
    exp = asm.expect
    report = ndbg_cli.analyze(asm)
    for e in exp["interferences"]:
        x = _interference(report, *e["pair"])
        assert x["kind"] == e["kind"] == "press_fit"
        assert x["axis"] == pytest.approx(e["axis"])
        # the 96-gons' radial gap is the circumradii's times cos(pi / 96)
        assert x["fit_depth"] == pytest.approx(e["depth"] * np.cos(np.pi / 96), rel=2e-3)
        assert x["radius"] == pytest.approx(e["radius"], abs=0.05)
    plan = report["plan"]
    assert plan["found"] and plan["verified"]["value"] is True
    assert sum(1 for s in plan["sequence"] if s.get("press")) == exp["press_steps"]
    for s in plan["sequence"]:
        assert s["removal_direction"] in ([0.0, 0.0, 1.0], [0.0, 0.0, -1.0])
    # by hand: the shoulder stops the bearing going down; the shaft leaves either way
    assert _free(asm.subset(["housing", "bearing"]), ["bearing"], exp["bearing_removal"])
    assert not _free(asm.subset(["housing", "bearing"]), ["bearing"], [0, 0, -1])
    for d in exp["shaft_removal"]:
        assert _free(asm, ["shaft"], d)
    # the press fits are cylindrical contacts: nothing but the axis frees the bearing
    inf = [p for p in report["partitionings"] if p["family"] == "infinitesimal_translation"]
    for p in inf:
        if p["moved"] == ["bearing"]:
            assert all(abs(d[2]) == pytest.approx(1.0) for d in p["directions"])


def test_overlap_example_is_classified_with_its_separating_direction():
    asm = ndbg_cli.load(ASSEMBLIES / "overlap.yaml")
    exp = asm.expect
    report = ndbg_cli.analyze(asm)
    for e in exp["interferences"]:
        x = _interference(report, *e["pair"])
        assert x["kind"] == "overlap"
        assert x["direction"] == pytest.approx(e["direction"])
        assert x["fit_depth"] == pytest.approx(e["depth"], rel=1e-3)
    assert report["plan"]["found"] and report["plan"]["verified"]["value"] is True
    for wall in exp["free_up"]:
        assert _free(asm, [wall], [0, 0, 1])
    # planned as a face contact: the front wall cannot move into the left one (+y)
    inf = next(fam for fam in report["ndbg"].values() if fam.get("family") ==
               "infinitesimal_translation")
    assert inf is not None


def test_clash_example_keeps_its_parts_together_as_one_unit():
    asm = ndbg_cli.load(ASSEMBLIES / "clash.yaml")
    exp = asm.expect
    report = ndbg_cli.analyze(asm)
    x = _interference(report, *exp["interferences"][0]["pair"])
    assert x["kind"] == "clash" and x["unit"] == exp["unit"]
    plan = report["plan"]
    assert plan["found"] and plan["verified"]["value"] is True
    assert [s["moved"] for s in plan["sequence"]] == exp["sequence"]
    assert plan["sequence"][0]["removal_direction"] == exp["cover_removal"]
    assert plan["sequence"][0]["onto"] == ["+".join(exp["unit"])]


def test_a_clash_is_an_error_under_the_error_policy():
    from ndbg_cli.core.errors import InputError
    from ndbg_cli.core.options import Options

    with pytest.raises(InputError, match="interpenetrate"):
        ndbg_cli.analyze(ndbg_cli.load(ASSEMBLIES / "clash.yaml"),
                         Options(interference="error"))
    # press fits and overlaps are contacts, not errors
    ndbg_cli.analyze(ndbg_cli.load(ASSEMBLIES / "press-fit.yaml"), Options(interference="error"))


def _build():
    spec = importlib.util.spec_from_file_location("assemblies_build", ASSEMBLIES / "build.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def _standoffs(segments: int, turn: float) -> Assembly:
    """A base with a blind hole r 4 (``segments`` facets), a standoff in it turned by
    ``turn`` degrees about its axis (its facets cross the hole's by up to the chord sag), a
    cap on the standoff, and a roller lying along x on the base's top face, turned likewise
    and set down on its lowest vertex. By hand: the standoff is held by the hole's walls and
    bottom (free along +z only, once the cap is off), the cap and the roller lift off along
    +z; nothing else blocks anything."""
    b = _build()

    def cyl(r, z0, z1):
        return b.prism(b.circle(r, n=segments), z0, z1)

    base = b.box(-30, -30, 0, 30, 30, 10) - cyl(4, 4, 11)
    standoff = cyl(4, 4, 25).rotate([0, 0, turn])
    cap = b.box(-5, -5, 25, 5, 5, 27)
    roller = b.along_x(cyl(3, -20, 20)).rotate([turn, 0, 0])
    lo = float(np.asarray(roller.to_mesh().vert_properties)[:, 2].min())
    roller = roller.translate([0, 18, 10 - lo])
    parts = []
    for pid, m in (("base", base), ("standoff", standoff), ("cap", cap), ("roller", roller)):
        mesh = m.to_mesh()
        parts.append(make_part(pid, np.asarray(mesh.vert_properties)[:, :3],
                               np.asarray(mesh.tri_verts))[0])
    return Assembly(f"standoffs-{segments}-{turn}", tuple(parts), base="base")


def _answer(asm: Assembly) -> dict:
    """What must not change: the infinitesimal partitionings (moved, rest), whether a proven
    plan exists, and the values of the classes."""
    report = ndbg_cli.analyze(asm)
    parts = sorted((tuple(p["moved"]), tuple(p["rest"])) for p in report["partitionings"]
                   if p["family"] == "infinitesimal_translation")
    classes = {fam: {k: v.get("value") for k, v in sorted(c.items())
                     if k in ("one_handed_monotone", "prismatic", "linearizable", "min_depth",
                              "stack_product", "interlocked", "min_directions")}
               for fam, c in sorted(report["classes"].items())}
    plan = report["plan"]
    return {"partitionings": parts, "plan": (plan["found"], plan["verified"]["value"]),
            "classes": classes}


def test_answers_do_not_change_with_the_tessellation_or_a_turn_about_the_axes():
    base = _answer(_standoffs(24, 0.0))
    # by hand: the standoff comes out (with or without the cap) along +z only, never alone
    # sideways; a proven plan exists
    assert base["plan"] == (True, True)
    moved = {frozenset(m) for m, _ in base["partitionings"]}
    assert {"roller"} in moved and {"cap"} in moved and {"standoff"} not in moved
    assert {"cap", "standoff"} in moved
    # 480 facets: a facet angle (0.75 degrees) below the contact angle tolerance (1 degree),
    # as in a fine STEP export
    for segments, turn in ((48, 0.0), (96, 0.0), (24, 5.0), (48, 3.75), (96, 1.0), (480, 0.3)):
        assert _answer(_standoffs(segments, turn)) == base, (segments, turn)


def test_units_reuse_the_contacts_of_the_pairs_they_leave_unchanged(tmp_path):
    """Without a cache folder, the pairs that units leave unchanged are served to the units'
    contact analysis from memory (``core.cache.MemoryCache``): the report is the one a cache
    folder gives, and a second analysis of the same parts is served whole from memory, with
    the same contacts."""
    from ndbg_cli.core.cache import MemoryCache
    from ndbg_cli.core.options import Options
    from ndbg_cli.pipeline.stages import find_contacts

    asm = ndbg_cli.load(ASSEMBLIES / "clash.yaml")
    on_disk = ndbg_cli.analyze(asm, Options(cache=str(tmp_path / "cache")))
    in_memory = ndbg_cli.analyze(asm)
    for key in ("contacts", "interferences", "plan", "classes", "ndbg"):
        assert json.dumps(in_memory[key], sort_keys=True) == json.dumps(on_disk[key],
                                                                        sort_keys=True)
    memo = MemoryCache()
    first = find_contacts(asm, cache=memo)
    pairs = first.sections["contact_stats"]["candidate_pairs"]
    assert memo.stats() == {"contacts": {"hits": 0, "misses": pairs}}
    again = find_contacts(asm, cache=memo)
    assert memo.stats() == {"contacts": {"hits": pairs, "misses": pairs}}
    assert again.sections["contacts"] == first.sections["contacts"]


def test_the_finger_placements_start_before_the_units_contacts(monkeypatch):
    """With clash units, the interlock LP and grasps' job (its finger placements need the
    parts alone) is started on the units' assembly before their contacts are found, and
    given them later: the same classes as computed in one process."""
    from ndbg_cli.core.options import Options
    from ndbg_cli.pipeline import stages

    asm = ndbg_cli.load(ASSEMBLIES / "clash.yaml")
    order = []
    find, job = stages.find_contacts, stages.interlock_job

    def finding(a, *args, **kw):
        order.append(("contacts", tuple(a.ids)))
        return find(a, *args, **kw)

    def starting(a, *args, **kw):
        order.append(("job", tuple(a.ids)))
        return job(a, *args, **kw)

    from ndbg_cli.pipeline import interlocking

    here = []  # the job's runs in this process (a forked child's are not seen here)
    later = interlocking.interlock_and_grasp_later

    def computing(*args):
        here.append(1)
        return later(*args)

    monkeypatch.setattr(stages, "find_contacts", finding)
    monkeypatch.setattr(stages, "interlock_job", starting)
    monkeypatch.setattr(interlocking, "interlock_and_grasp_later", computing)
    two = ndbg_cli.analyze(asm, Options(workers=2))
    units = order[1][1]
    assert order == [("contacts", tuple(asm.ids)), ("job", units), ("contacts", units)]
    assert "bracket+plate" in units
    assert not here  # the child computed it (had it failed, this process would have)
    one = ndbg_cli.analyze(asm, Options(workers=1))
    assert here == [1]
    assert json.dumps(two["classes"], sort_keys=True) == json.dumps(one["classes"],
                                                                    sort_keys=True)
    assert any("grasp" in json.dumps(c) for c in two["classes"].values())

"""The invariance table (issue 34, item 3): every example and every real model analysed as
given and after a rigid motion, a change of units, a permutation of its parts and a round trip
through ``ndbg convert``; the answers must not change.

``python benchmarks/invariance.py [NAME ...] [--jobs N] [--keep DIR]`` (``make invariance``)
prints one row per assembly: for each transformation ``identical``, ``differs-within-tolerance``
(the answers differ, but every differing answer is one the report marks as decided within a
tolerance: ``near-tolerance`` warnings naming it) or ``DIFFERS`` (a silent difference: a bug),
then the differences themselves; it exits 1 on any ``DIFFERS``. NAME selects assemblies by
name (``hover``, ``rod``, ``burr/pelikan``).

Only answers that do not depend on the frame are compared: each family's partitionings as
(moved, rest) sets of part names, the plan's existence and validity (``found``,
``verified.value``, ``proof_of_none``) and every class's value, evidence, scope and bounds.
Directions, points, timings, paths and texts rotate, scale or move with the input.

Transformations are new input files: a manifest is rewritten (each part's pose composed with
the motion, as a ``matrix``; units changed by declaring the new assembly unit and each part's
old one, so the loader scales the geometry); a model file (3DXML, GLB, STEP, mesh folder) is
first converted to meshes plus a manifest with ``ndbg convert``, which is then transformed.
"""

from __future__ import annotations

import argparse
import json
import shutil
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import yaml
from scipy.spatial.transform import Rotation

ROOT = Path(__file__).resolve().parents[1]
SHARED = ROOT.parent / "shared" / "data"

#: The transformations, in the table's column order.
TRANSFORMS = ("rotation", "units-m", "units-in", "permutation", "convert")

#: One fixed seed: the same motion and permutation every run (a table is reproducible).
SEED = 34

#: Length of each unit in millimetres (the units a manifest may declare).
UNIT_MM = {"mm": 1.0, "cm": 10.0, "m": 1000.0, "in": 25.4}

#: Real models of ../shared/data (README there), by name; ``corrupt/`` is left out on purpose.
MODELS = {"rod": "rod/rod.3DXML", "beam": "beam/assembled", "as1": "as1/as1-oc-214.stp",
          "engine": "engine/2CylinderEngine.glb",
          **{f"burr/{d}": f"burr/{d}" for d in ("six-piece-000", "six-piece-001",
                                                 "six-piece-002", "six-piece-257",
                                                 "six-piece-258", "pelikan")}}

#: Class fields that hold answers (not texts or frame-bound witnesses).
CLASS_KEYS = ("value", "evidence", "holds_for", "exact", "lower_bound", "upper_bound",
              "complete")


@dataclass(frozen=True)
class Case:
    """One assembly of the table: its name and its input (a manifest or a model)."""

    name: str
    source: Path

    @property
    def is_manifest(self) -> bool:
        return self.source.suffix.lower() in (".yaml", ".yml")


def cases(names: list[str]) -> list[Case]:
    """Every example and every real model (those present), or the ones named."""
    out = [Case(p.stem, p) for p in sorted((ROOT / "assemblies").glob("*.yaml"))]
    out += [Case(n, SHARED / rel) for n, rel in MODELS.items() if (SHARED / rel).exists()]
    return [c for c in out if not names or c.name in names]


# ---------------------------------------------------------------- the transformations


def _pose(entry: dict, dim: int) -> tuple[np.ndarray, np.ndarray]:
    """A part entry's rotation ``(dim, dim)`` and translation ``(dim,)`` (in its own unit)."""
    if "matrix" in entry:
        m = np.asarray(entry["matrix"], dtype=float)
        return m[:dim, :dim], m[:dim, dim]
    t = np.asarray(entry.get("translation", [0.0] * dim), dtype=float)
    spec = entry.get("rotation")
    if spec is None:
        return np.eye(dim), t
    if dim == 2:
        a = np.radians(float(spec))
        return np.array([[np.cos(a), -np.sin(a)], [np.sin(a), np.cos(a)]]), t
    if "quaternion" in spec:
        w, x, y, z = spec["quaternion"]
        return Rotation.from_quat([x, y, z, w]).as_matrix(), t
    if "euler" in spec:
        return Rotation.from_euler(spec["order"], spec["euler"], degrees=True).as_matrix(), t
    axis = np.asarray(spec["axis"], dtype=float)
    return Rotation.from_rotvec(np.radians(spec["angle"]) * axis / np.linalg.norm(axis)
                                ).as_matrix(), t


def _floats(a: np.ndarray) -> list:
    """Plain floats for YAML (repr round-trips exactly)."""
    return np.asarray(a, dtype=float).tolist()


def rotate(doc: dict, size: float, rng: np.random.Generator) -> dict:
    """The manifest moved by a random rigid motion (not axis-aligned): each part's pose
    composed with it (``x -> Q x + u``, ``u`` up to the assembly's size), joints moved too."""
    dim = int(doc.get("dimension", 3))
    if dim == 2:
        a = rng.uniform(0.3, 2 * np.pi - 0.3)
        q = np.array([[np.cos(a), -np.sin(a)], [np.sin(a), np.cos(a)]])
    else:
        q = Rotation.random(random_state=np.random.RandomState(rng.integers(2**31))).as_matrix()
    u = rng.uniform(-1.0, 1.0, dim) * size
    units = doc.get("units", "mm")
    for entry in doc["parts"]:
        r, t = _pose(entry, dim)
        # the pose is in the part's unit (the loader scales its translation): u in it
        s = UNIT_MM[entry.get("units", units)] / UNIT_MM[units]
        for key in ("translation", "rotation", "matrix"):
            entry.pop(key, None)
        m = np.eye(dim + 1)
        m[:dim, :dim], m[:dim, dim] = q @ r, q @ t + u / s
        entry["matrix"] = _floats(m)
    for joint in doc.get("joints", []):
        joint["axis"] = _floats(q @ np.asarray(joint["axis"], float))
        if "point" in joint:
            joint["point"] = _floats(q @ np.asarray(joint["point"], float) + u)
    return doc


def change_units(doc: dict, target: str) -> dict:
    """The manifest in unit ``target``: parts keep their own unit (declared per part, so the
    loader scales them); the lengths stated in the assembly unit are converted."""
    units = doc.get("units", "mm")
    f = UNIT_MM[units] / UNIT_MM[target]
    doc["units"] = target
    for entry in doc["parts"]:
        entry.setdefault("units", units)
    if "tolerance" in doc:
        doc["tolerance"] = float(doc["tolerance"]) * f
    for joint in doc.get("joints", []):
        if "point" in joint:
            joint["point"] = _floats(np.asarray(joint["point"], float) * f)
        if "pitch" in joint:
            joint["pitch"] = float(joint["pitch"]) * f
    return doc


def permute(doc: dict, rng: np.random.Generator) -> dict:
    """The manifest with its parts listed in a random order (never the same order)."""
    n = len(doc["parts"])
    order = rng.permutation(n)
    while n > 1 and (order == np.arange(n)).all():
        order = rng.permutation(n)
    doc["parts"] = [doc["parts"][i] for i in order]
    return doc


def unit_targets(units: str) -> dict[str, str]:
    """The two unit changes: to metres (or to mm for a model in metres) and to inches."""
    return {"units-m": "mm" if units == "m" else "m", "units-in": "in"}


# ---------------------------------------------------------------- inputs and analyses


def cli(*args: str, timeout: float = 3600) -> subprocess.CompletedProcess:
    """``python -m ndbg_cli ARGS`` from the project root (reports' paths relative to it)."""
    return subprocess.run([sys.executable, "-m", "ndbg_cli", *args], cwd=ROOT,
                          capture_output=True, text=True, timeout=timeout)


def prepare(case: Case, work: Path) -> dict[str, Path | None]:
    """Input files for the original and each transformation (``None``: not applicable,
    e.g. ``convert`` of a 2D manifest)."""
    work.mkdir(parents=True, exist_ok=True)
    base = work / "base"
    got = cli("-q", "convert", str(case.source), "--out", str(base), "--force")
    converted = next(base.glob("*.yaml"), None) if got.returncode == 0 else None
    if case.is_manifest:
        # the manifest beside copies of its meshes (paths may not leave its folder)
        doc = yaml.safe_load(case.source.read_text())
        for entry in doc["parts"]:
            if "mesh" in entry:
                dst = work / entry["mesh"]
                dst.parent.mkdir(parents=True, exist_ok=True)
                shutil.copyfile(case.source.parent / entry["mesh"], dst)
        folder, original = work, case.source
    else:
        if converted is None:
            raise RuntimeError(f"{case.name}: ndbg convert failed: {got.stderr.strip()}")
        doc, folder, original = yaml.safe_load(converted.read_text()), base, case.source
    import ndbg_cli

    size = float(ndbg_cli.load(converted or case.source).diagonal)
    rng = np.random.default_rng(SEED)
    docs = {"rotation": rotate(_copy(doc), size, rng)}
    for label, target in unit_targets(doc.get("units", "mm")).items():
        docs[label] = change_units(_copy(doc), target)
    docs["permutation"] = permute(_copy(doc), rng)
    paths: dict[str, Path | None] = {"original": original, "convert": converted}
    for label, d in docs.items():
        paths[label] = folder / f"{case.name.replace('/', '-')}-{label}.yaml"
        paths[label].write_text(yaml.safe_dump(d, sort_keys=False))
    return paths


def _copy(doc: dict) -> dict:
    return yaml.safe_load(yaml.safe_dump(doc))


def analyse(path: Path) -> dict:
    """The full JSON report of ``path`` (no cache: each run computes its answers)."""
    got = cli("-q", "analyze", str(path), "--format", "json", "--no-cache", "--detail",
              "full", "--jobs", "1")
    if got.returncode not in (0, 1):
        raise RuntimeError(f"{path}: exit {got.returncode}: {got.stderr.strip()}")
    return json.loads(got.stdout)


# ---------------------------------------------------------------- comparing answers


def answers(report: dict) -> dict[str, object]:
    """The frame-free answers of a report, flattened to ``{field: value}``."""
    out: dict[str, object] = {}
    fams: dict[str, set] = {}
    for p in report.get("partitionings", []):
        fams.setdefault(p["family"], set()).add((tuple(sorted(p["moved"])),
                                                 tuple(sorted(p["rest"]))))
    for fam, parts in sorted(fams.items()):
        section = (report.get("ndbg") or {}).get(fam) or {}
        if section.get("partitionings_truncated") or section.get("candidates_truncated"):
            # cut by --max-partitions (or, generalized, its candidate limit): past the parts
            # that come out on their own (all listed first, whatever the cut) the list is a
            # sample in the order of the regions and part indices, which the frame and the
            # part order change; the report says so
            out[f"partitionings.{fam}"] = {"truncated": len(parts), "single parts": sorted(
                p for p in parts if len(p[0]) == 1)}
        else:
            out[f"partitionings.{fam}"] = sorted(parts)
    plan = report.get("plan") or {}
    verified = plan.get("verified") or {}
    out["plan.found"] = plan.get("found")
    out["plan.verified.value"] = verified.get("value")
    proof = verified.get("proof_of_none")
    out["plan.verified.proof_of_none"] = (proof.get("value") if isinstance(proof, dict)
                                          else proof)
    for fam, classes in sorted((report.get("classes") or {}).items()):
        for name, c in sorted(classes.items()):
            for key in CLASS_KEYS:
                if isinstance(c, dict) and key in c:
                    out[f"classes.{fam}.{name}.{key}"] = c[key]
    return out


def within_tolerance(report: dict) -> set[str]:
    """The answers a report marks as decided within a tolerance (its ``near-tolerance``
    warnings name them in ``fields``): a flip there is said, not silent."""
    return {f for w in report.get("warnings", []) if w.get("code") == "near-tolerance"
            for f in w.get("fields", [])}


def compare(a: dict, b: dict) -> tuple[str, list[str]]:
    """``(verdict, differences)`` of two reports of the same assembly."""
    x, y = answers(a), answers(b)
    diffs = [k for k in sorted(set(x) | set(y)) if x.get(k) != y.get(k)]
    if not diffs:
        return "identical", []
    marked = within_tolerance(a) | within_tolerance(b)
    silent = [k for k in diffs if not any(k == f or k.startswith(f + ".") for f in marked)]
    lines = [f"{k}: {_short(x.get(k))} -> {_short(y.get(k))}"
             + ("" if k in silent else " (within tolerance)") for k in diffs]
    return ("DIFFERS" if silent else "differs-within-tolerance"), lines


def _short(v: object) -> str:
    s = json.dumps(v)
    return s if len(s) < 120 else s[:117] + "..."


def run_case(case: Case, work: Path, jobs: int, run: Callable[[Path], dict] = analyse
             ) -> tuple[dict[str, str], list[str], float]:
    """The row of one assembly: verdict per transformation, the differences, seconds
    (``run``: how a report is made, :func:`analyse` by default)."""
    t0 = time.perf_counter()
    paths = prepare(case, work / case.name.replace("/", "-"))
    todo = {k: p for k, p in paths.items() if p is not None}
    with ThreadPoolExecutor(max_workers=jobs) as pool:
        reports = dict(zip(todo, pool.map(run, todo.values())))
    row, notes = {}, []
    for label in TRANSFORMS:
        if label not in reports:
            row[label] = "n/a"
            continue
        row[label], diffs = compare(reports["original"], reports[label])
        notes += [f"  {case.name} / {label}: {d}" for d in diffs]
    return row, notes, time.perf_counter() - t0


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("names", nargs="*", help="assemblies to run (default: all)")
    ap.add_argument("--jobs", type=int, default=2, help="analyses run at once (default 2)")
    ap.add_argument("--keep", type=Path, help="keep the transformed inputs in this folder")
    args = ap.parse_args(argv)
    work = args.keep or Path(tempfile.mkdtemp(prefix="ndbg-invariance-"))
    t0 = time.perf_counter()
    width = max(len(c.name) for c in cases(args.names)) + 2
    print(f"{'assembly':<{width}}" + "".join(f"{t:<26}" for t in TRANSFORMS) + "seconds")
    notes, silent = [], 0
    try:
        for case in cases(args.names):
            row, diffs, secs = run_case(case, work, args.jobs)
            silent += sum(v == "DIFFERS" for v in row.values())
            print(f"{case.name:<{width}}" + "".join(f"{row[t]:<26}" for t in TRANSFORMS)
                  + f"{secs:.0f}", flush=True)
            notes += diffs
    finally:
        if not args.keep:
            shutil.rmtree(work, ignore_errors=True)
    print("\n".join(["", "differences:", *notes] if notes else ["", "no differences"]))
    print(f"{silent} silent difference(s); {time.perf_counter() - t0:.0f} s")
    return 1 if silent else 0


if __name__ == "__main__":
    sys.exit(main())

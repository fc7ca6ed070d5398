"""Scale: the default ``ndbg analyze`` of synthetic racks of 96, 296 and 996 parts
(``assemblies/build.py::rack``: boards on standoffs, answers known by construction), one fresh
CLI process each, with the floor (a fresh interpreter importing ndbg and loading the rack)
measured in the same run, the peak memory of the analysis (GNU time's maximum resident set)
and the growth exponent of the time over the parts (a least-squares slope of log time over
log parts). A run stopped after :data:`TIMEOUT` seconds is reported as that many seconds.

Figures: ``rack-N.whole_s``, ``rack-N.floor_s``, ``rack-N.peak_mib``, ``rack-N.plan`` (1
proven along the z axis alone, as built: each step's moved side up, or the rest up and it
down, the same relative motion; 0 otherwise), ``exponent`` and the issue's targets
(:data:`TARGETS`).
"""

from __future__ import annotations

import json
import math
import subprocess
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

from common import ROOT  # noqa: E402

#: Levels of the racks measured (5 levels - 4 parts).
LEVELS = (20, 60, 200)
#: Whole-process targets by part count (seconds); growth exponent and peak memory (MiB).
TARGETS = {296: 15.0, 996: 60.0}
EXPONENT_TARGET = 1.5
PEAK_TARGET_MIB = 4096.0
#: Seconds after which a run is stopped.
TIMEOUT = 900.0


def _timed(args: list[str]) -> float:
    t0 = time.perf_counter()
    try:
        subprocess.run(args, check=False, capture_output=True, cwd=ROOT, timeout=TIMEOUT)
    except subprocess.TimeoutExpired:
        return TIMEOUT
    return time.perf_counter() - t0


def _measure(path: Path, out: Path) -> tuple[float, float, float, int]:
    """``(whole_s, floor_s, peak_mib, plan)`` of one rack."""
    floor = _timed([sys.executable, "-c", f"import ndbg_cli; ndbg_cli.load({str(path)!r})"])
    args = [sys.executable, "-m", "ndbg_cli", "analyze", str(path), "--no-cache", "-q",
            "--format", "json", "--out", str(out)]
    t0 = time.perf_counter()
    try:  # GNU time's %M: the analysis's peak resident set, KiB
        proc = subprocess.run(["/usr/bin/time", "-f", "%M", *args], check=False,
                              capture_output=True, text=True, cwd=ROOT, timeout=TIMEOUT)
    except subprocess.TimeoutExpired:
        return TIMEOUT, floor, float("nan"), 0
    whole = time.perf_counter() - t0
    lines = [x for x in proc.stderr.strip().splitlines() if x.strip().isdigit()]
    peak = int(lines[-1]) / 1024.0 if lines else float("nan")
    plan = 0
    if out.exists():
        p = json.loads(out.read_text()).get("plan") or {}
        dirs = {tuple(s.get("removal_direction") or ()) for s in p.get("sequence") or []}
        plan = int(bool((p.get("verified") or {}).get("value"))
                   and dirs <= {(0.0, 0.0, 1.0), (0.0, 0.0, -1.0)})
    return whole, floor, peak, plan


def run() -> list[tuple[str, float, str]]:
    sys.path.insert(0, str(ROOT / "assemblies"))
    import build

    rows: list[tuple[str, float, str]] = []
    points = []
    with tempfile.TemporaryDirectory() as tmp:
        for levels in LEVELS:
            name = build.rack(Path(tmp), levels)
            parts = 5 * levels - 4
            whole, floor, peak, plan = _measure(Path(tmp) / f"{name}.yaml",
                                                Path(tmp) / f"{name}.json")
            points.append((parts, whole))
            rows += [(f"{name}.whole_s", whole, "s"), (f"{name}.floor_s", floor, "s"),
                     (f"{name}.peak_mib", peak, "MiB"),
                     (f"{name}.plan", plan, "1 proven along z alone / 0 not")]
            if parts in TARGETS:
                rows.append((f"{name}.target_s", TARGETS[parts],
                             "s (met)" if whole <= TARGETS[parts] else "s (MISSED)"))
            print(f"# {name}: {whole:.1f} s", file=sys.stderr, flush=True)
    xs = [math.log(p) for p, _ in points]
    ys = [math.log(t) for _, t in points]
    mx, my = sum(xs) / len(xs), sum(ys) / len(ys)
    slope = sum((x - mx) * (y - my) for x, y in zip(xs, ys)) / sum((x - mx) ** 2 for x in xs)
    rows.append(("exponent", slope, "(met)" if slope <= EXPONENT_TARGET else "(MISSED)"))
    peak = max((v for n, v, u in rows if n.endswith("peak_mib")), default=float("nan"))
    rows.append(("peak_mib_largest", peak,
                 "MiB (met)" if peak <= PEAK_TARGET_MIB else "MiB (MISSED)"))
    return rows


if __name__ == "__main__":
    for fig, value, unit in run():
        print(f"{fig:<40} {value:>12.4g} {unit}")

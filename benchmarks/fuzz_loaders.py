"""Fuzz the readers through the CLI: damaged copies of a small real file of each format
(tests/fuzzing.py, fixed seed) analysed by ``ndbg analyze``; prints the count of each outcome
per format. Every outcome must be ``ok`` (exit 0, nothing on stderr) or ``input-error`` (exit
2, one ``ndbg: error:`` line; ``crash`` or ``timeout`` when the reader's child crashed or ran
out of time): anything else (``internal`` exit 3, ``signal``, ``hung``, ``noisy`` stderr) is a
bug. Usage: python benchmarks/fuzz_loaders.py [CASES_PER_FORMAT [JOBS]]
"""

from __future__ import annotations

import subprocess
import sys
import tempfile
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))

from fuzzing import FORMATS, cases, write_samples  # noqa: E402

STEP = ROOT.parent / "shared" / "data" / "as1" / "as1-oc-214.stp"


def outcome(path: Path) -> str:
    try:
        r = subprocess.run([sys.executable, "-m", "ndbg_cli", "analyze", str(path), "--no-cache",
                            "--motion", "translation", "--format", "json", "--load-timeout",
                            "30"], capture_output=True, text=True, timeout=300, cwd=ROOT)
    except subprocess.TimeoutExpired:
        return "hung"
    # status lines of a long load ("ndbg: loading FILE: STAGE (10 s so far)") are expected
    lines = [x for x in r.stderr.strip().splitlines() if not x.startswith("ndbg: loading ")]
    errors = [x for x in lines if x.startswith("ndbg: error: ")]
    others = [x for x in lines if not x.startswith(("ndbg: error: ", "ndbg: warning: "))]
    if r.returncode < 0:
        return "signal"
    if others:
        return "noisy"
    if r.returncode == 0:
        return "ok"
    if r.returncode == 2 and len(errors) == 1:
        if "did not finish within" in errors[0]:
            return "input-error (timeout)"
        if "crashed on this file" in errors[0]:
            return "input-error (crash)"
        return "input-error"
    return "internal" if r.returncode == 3 else f"exit {r.returncode}"


def main() -> None:
    n = int(sys.argv[1]) if len(sys.argv) > 1 else 20
    jobs = int(sys.argv[2]) if len(sys.argv) > 2 else 2
    with tempfile.TemporaryDirectory(prefix="ndbg-fuzz-") as tmp:
        samples = write_samples(Path(tmp) / "samples", STEP if STEP.is_file() else None)
        todo = cases(samples, {k: n for k in FORMATS}, Path(tmp) / "cases")
        with ThreadPoolExecutor(jobs) as pool:
            results = list(pool.map(lambda c: outcome(c[1]), todo))
    counts: dict[str, dict[str, int]] = {}
    for (fmt, path, how), res in zip(todo, results):
        counts.setdefault(fmt, {}).setdefault(res, 0)
        counts[fmt][res] += 1
        if not res.startswith(("ok", "input-error")):
            print(f"BUG {fmt} {path.name} ({how}): {res}")
    for fmt, c in counts.items():
        print(f"{fmt:10s} " + ", ".join(f"{k}: {v}" for k, v in sorted(c.items())))


if __name__ == "__main__":
    main()

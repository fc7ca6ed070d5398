"""Run every ``benchmarks/bench_*.py`` and print one line per figure: name, value, unit.

Each module exposes ``run() -> list[tuple[str, float, str]]``. Figures are also written to
``benchmarks/results.json``. A module whose data is missing or that fails prints a note and
the others still run. ``python benchmarks/run.py contacts`` runs only ``bench_contacts.py``.
"""

from __future__ import annotations

import importlib.util
import json
import sys
import time
import traceback
from pathlib import Path

HERE = Path(__file__).resolve().parent


def main(argv: list[str]) -> int:
    only = set(argv)
    figures = []
    failed = 0
    for path in sorted(HERE.glob("bench_*.py")):
        name = path.stem.removeprefix("bench_")
        if only and name not in only:
            continue
        spec = importlib.util.spec_from_file_location(path.stem, path)
        module = importlib.util.module_from_spec(spec)
        t0 = time.perf_counter()
        try:
            spec.loader.exec_module(module)
            rows = module.run()
        except Exception:
            failed += 1
            print(f"# {name}: FAILED", file=sys.stderr)
            traceback.print_exc()
            continue
        for fig, value, unit in rows:
            print(f"{name}.{fig:<44} {value:>14.6g} {unit}", flush=True)
            figures.append({"name": f"{name}.{fig}", "value": value, "unit": unit})
        print(f"# {name}: {time.perf_counter() - t0:.1f} s", file=sys.stderr)
    (HERE / "results.json").write_text(json.dumps(figures, indent=2) + "\n")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))

"""The fuzzing campaign (``make fuzz``; a fixed-seed slice in ``tests/test_fuzz_campaign.py``).

Every case (``tests/fuzz_cases.py``: a generated manifest, a degenerate mesh, a damaged real
file) is analysed by the real CLI, ``ndbg analyze TARGET --out-dir OUT --format json
--no-cache``, in its own process forked from a warm server (``tests/cli_server.py``: the
interpreter and the stages imported once, so a case costs its analysis, not 1.5 s of start-up).
What is checked is what a user sees: the exit code (0, or 2 with one ``ndbg: error:`` line;
1 is documented too), stderr (no traceback, only ``ndbg:`` lines), the out dir (no temporary
or partial file, every JSON file parses and is valid against the shipped report schema, an
exit 0 wrote its report and index) and the input folder (nothing written there). A case past
its time bound is killed by an alarm (``timeout``); a server that stops answering is killed
and replaced (``hung``).

Usage: python tests/fuzz_campaign.py [--cases N] [--seed S] [--jobs J] [--timeout T]
       python tests/fuzz_campaign.py --case GENERATOR:SEED [--keep DIR]   (re-run one case)
Prints the count of each outcome per generator; exits 1 on any failure.
"""

from __future__ import annotations

import argparse
import json
import os
import select
import signal
import subprocess
import sys
import tempfile
import threading
import time
from collections import Counter
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))

from cli_server import _read, _write  # noqa: E402
from fuzz_cases import GENERATORS, Case, Pool, build, remove  # noqa: E402

#: Outcomes that are not bugs: a report, or an error with a documented exit code.
GOOD = ("report", "exit 1", "exit 2")
#: Seconds a case may take (the forked CLI's alarm); the 2,000-part cases need about 20.
TIMEOUT_S = 60
#: Seconds a server may stay silent beyond the case's own bound before it is killed.
GRACE_S = 30
#: The campaign's default seed: the same cases on every run.
SEED = 20260127


class Server:
    """A fork server of the CLI (``tests/cli_server.py``) in its own process group, so a
    forked case that hangs past its alarm is killed with it."""

    def __init__(self) -> None:
        self.proc = subprocess.Popen(
            [sys.executable, str(ROOT / "tests" / "cli_server.py"), str(ROOT)],
            stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.DEVNULL,
            start_new_session=True)
        if _read(self.proc.stdout) != "ready":
            raise RuntimeError("the CLI fork server did not start")

    def run(self, args: list[str], cwd: Path, timeout: int
            ) -> tuple[int | None, bytes, bytes]:
        """``(exit code, stdout, stderr)`` of ``python -m ndbg_cli ARGS``; code ``None``
        when the server gave no answer in time (it is then killed)."""
        env = dict(os.environ, NDBG_CACHE_DIR=str(cwd.parent / "cache"))
        _write(self.proc.stdin, (args, str(cwd), env, b"", timeout, 0o022))
        ready, _, _ = select.select([self.proc.stdout], [], [], timeout + GRACE_S)
        got = _read(self.proc.stdout) if ready else None
        if got is None:  # hung (or the server died): the case's whole process group goes
            self.close(kill=True)
            return None, b"", b""
        return got

    def close(self, kill: bool = False) -> None:
        if kill:
            try:
                os.killpg(self.proc.pid, signal.SIGKILL)
            except ProcessLookupError:
                pass
        else:
            self.proc.stdin.close()
        self.proc.wait()


@dataclass
class Result:
    case: str
    note: str
    outcome: str
    detail: str
    seconds: float


def _files(folder: Path) -> set[str]:
    return {str(p.relative_to(folder)) for p in folder.rglob("*")} if folder.exists() else set()


def _check_out(out: Path, code: int) -> str:
    """What is wrong with the out dir after a run that ended with ``code`` ('' if nothing)."""
    from ndbg_cli.report.document import validate_report

    names = sorted(_files(out))
    for name in names:
        if name.startswith(".") or name.endswith(".tmp") or not name.endswith(".json"):
            return f"partial or stray file {name}"
        try:
            validate_report(json.loads((out / name).read_text()))
        except ValueError as exc:
            return f"{name} is not JSON: {exc}"
        except Exception as exc:  # noqa: BLE001 (jsonschema's ValidationError, and any other)
            return f"{name} is not a valid report: {str(exc).splitlines()[0]}"
    if "index.json" in names:
        listed = {r["report"] for r in json.loads((out / "index.json").read_text())["reports"]}
        if listed - set(names):
            return f"index.json lists missing reports {sorted(listed - set(names))}"
    if code == 0 and (len(names) < 2 or "index.json" not in names):
        return "exit 0 without its report and index.json"
    return ""


def classify(code: int | None, err: bytes, out: Path) -> tuple[str, str]:
    """The outcome of one run and what shows it."""
    text = err.decode("utf-8", "replace")
    lines = text.splitlines()
    errors = [x for x in lines if x.startswith("ndbg: error: ")]
    if code is None:
        return "hung", "the server gave no answer"
    if code == -signal.SIGALRM:
        return "timeout", f"past {TIMEOUT_S} s"
    if code < 0:
        return "signal", signal.Signals(-code).name
    if "Traceback (most recent call last)" in text:
        return "traceback", text.strip().splitlines()[-1][:300]
    others = [x for x in lines if not x.startswith("ndbg")]
    if others:
        return "noisy", others[0][:300]
    if code not in (0, 1, 2):
        return f"exit {code}", (errors or [""])[0][:300]
    if code == 2 and len(errors) != 1:
        return "bad-error", f"{len(errors)} error lines for exit 2"
    if code == 0 and errors:
        return "bad-error", f"exit 0 with {errors[0][:200]}"
    wrong = _check_out(out, code)
    if wrong:
        return "bad-output", wrong
    return ("report" if code == 0 else f"exit {code}"), (errors or [""])[0][:300]


def run_case(server: Server, generator: str, seed: int, work: Path, pool: Pool,
             timeout: int = TIMEOUT_S, keep: bool = False) -> Result:
    """Build case ``(generator, seed)`` under ``work``, run it, check it, remove it."""
    folder = work / f"{generator}-{seed}"
    (folder / "in").mkdir(parents=True)
    try:
        case: Case = build(generator, seed, folder / "in", pool)
    except Exception as exc:  # noqa: BLE001 (a bug of the fuzzer: counted, the run goes on)
        remove(folder)
        return Result(f"{generator}:{seed}", "", "fuzzer-error", repr(exc)[:300], 0.0)
    before = _files(case.folder)
    out = folder / "out"
    args = ["analyze", case.target, "--out-dir", str(out), "--format", "json", "--no-cache",
            "-q", "--load-timeout", "20", *case.args]
    start = time.monotonic()
    code, _, err = server.run(args, case.folder, timeout)
    seconds = time.monotonic() - start
    outcome, detail = classify(code, err, out)
    stray = _files(case.folder) - before
    if outcome in GOOD and stray:
        outcome, detail = "bad-output", f"wrote into the input folder: {sorted(stray)[:3]}"
    if not keep:
        remove(folder)
    return Result(case.name, case.note, outcome, detail, seconds)


def campaign(cases: int, seed: int = SEED, jobs: int = 2, timeout: int = TIMEOUT_S,
             progress: bool = False) -> list[Result]:
    """``cases`` cases, the generators in turn (4 manifests, 3 meshes, 3 mutations in 10),
    case ``i`` seeded ``seed + i``, on ``jobs`` fork servers."""
    plan = [(GENERATORS[(0, 0, 0, 0, 1, 1, 1, 2, 2, 2)[i % 10]], seed + i) for i in range(cases)]
    local = threading.local()
    servers: list[Server] = []
    lock = threading.Lock()
    done: list[Result] = []
    start = time.monotonic()
    with tempfile.TemporaryDirectory(prefix="ndbg-fuzz-") as tmp:
        pool = Pool(Path(tmp) / "pool")

        def one(item: tuple[str, int]) -> Result:
            if getattr(local, "server", None) is None or local.server.proc.poll() is not None:
                local.server = Server()
                with lock:
                    servers.append(local.server)
            r = run_case(local.server, *item, Path(tmp), pool, timeout)
            if r.outcome == "timeout":  # the killed case's own workers may live on: they
                local.server.close(kill=True)  # are in the server's process group
            if r.outcome in ("hung", "timeout"):
                local.server = None
            with lock:
                done.append(r)
                if progress and len(done) % 250 == 0:
                    counts = Counter(x.outcome for x in done)
                    print(f"fuzz: {len(done)}/{cases} in {time.monotonic() - start:.0f} s: "
                          + ", ".join(f"{k} {v}" for k, v in sorted(counts.items())),
                          file=sys.stderr, flush=True)
            return r

        try:
            with ThreadPoolExecutor(jobs) as ex:
                results = list(ex.map(one, plan))
        finally:
            for s in servers:
                if s.proc.poll() is None:
                    s.close()
    return results


def summary(results: list[Result]) -> str:
    """The counts of each outcome per generator and in all, and each failure with how to
    re-run it."""
    lines = []
    for gen in (*GENERATORS, "all"):
        mine = [r for r in results if gen == "all" or r.case.startswith(gen + ":")]
        counts = Counter(r.outcome for r in mine)
        bad = sum(v for k, v in counts.items() if k not in GOOD)
        lines.append(f"{gen:9s} {len(mine):6d} cases: "
                     + ", ".join(f"{k} {counts[k]}" for k in sorted(counts))
                     + f"; failures {bad}; mean "
                     f"{sum(r.seconds for r in mine) / max(1, len(mine)):.2f} s per case")
    total = Counter(r.outcome for r in results)
    lines.append("tracebacks {}, timeouts {}, hung {}, signals {}, partial/invalid output {}"
                 .format(total["traceback"], total["timeout"], total["hung"], total["signal"],
                         total["bad-output"]))
    slow = max(results, key=lambda r: r.seconds, default=None)
    if slow is not None:
        lines.append(f"slowest case: {slow.case} ({slow.note}) {slow.seconds:.1f} s")
    for r in results:
        if r.outcome not in GOOD:
            lines.append(f"FAIL {r.case} [{r.outcome}] {r.detail} ({r.note}); re-run: "
                         f"python tests/fuzz_campaign.py --case {r.case} --keep DIR")
    return "\n".join(lines)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--cases", type=int, default=int(os.environ.get("FUZZ_CASES", 10000)))
    ap.add_argument("--seed", type=int, default=int(os.environ.get("FUZZ_SEED", SEED)))
    ap.add_argument("--jobs", type=int, default=int(os.environ.get("FUZZ_JOBS", 2)))
    ap.add_argument("--timeout", type=int, default=TIMEOUT_S)
    ap.add_argument("--case", help="re-run one case, GENERATOR:SEED")
    ap.add_argument("--keep", type=Path, help="with --case: keep its files in this folder")
    a = ap.parse_args()
    start = time.monotonic()
    if a.case:
        gen, seed = a.case.split(":")
        work = a.keep or Path(tempfile.mkdtemp(prefix="ndbg-fuzz-"))
        pool = Pool(work / "pool")
        server = Server()
        try:
            r = run_case(server, gen, int(seed), work, pool, a.timeout, keep=a.keep is not None)
        finally:
            server.close()
        print(f"{r.case}: {r.outcome} {r.detail} ({r.note}) {r.seconds:.1f} s"
              + (f"; files in {work / f'{gen}-{seed}'}" if a.keep else ""))
        sys.exit(0 if r.outcome in GOOD else 1)
    results = campaign(a.cases, a.seed, a.jobs, a.timeout, progress=True)
    print(summary(results))
    print(f"{len(results)} cases in {time.monotonic() - start:.0f} s ({a.jobs} jobs, seed "
          f"{a.seed}, time bound {a.timeout} s per case)")
    sys.exit(0 if all(r.outcome in GOOD for r in results) else 1)


if __name__ == "__main__":
    main()

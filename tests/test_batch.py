"""Batches: JSON Lines in input order, worker processes, error records, atomic report files
that survive a SIGTERM."""

from __future__ import annotations

import json
import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from helpers import run_cli

ROOT = Path(__file__).resolve().parents[1]
EX = ROOT / "assemblies"
SMALL = ["hover", "stack", "fig3-2d", "fig5-rotation", "fig11-nonlinear", "peg-37"]


def make_batch(folder: Path, copies: int = 1, broken: int = 0) -> list[str]:
    """Copies of small examples (with their meshes) plus ``broken`` bad manifests; returns
    the manifest stems in the order ``ndbg`` discovers them (sorted paths)."""
    shutil.copytree(EX / "meshes", folder / "meshes")
    for k in range(copies):
        for name in SMALL:
            text = (EX / f"{name}.yaml").read_text()
            (folder / f"{name}-{k:02d}.yaml").write_text(text)
    for k in range(broken):
        (folder / f"zz-broken-{k}.yaml").write_text("name: x\nparts: [\n")
    return sorted(p.stem for p in folder.glob("*.yaml"))


def test_jsonl_in_input_order_and_identical_across_jobs(tmp_path):
    stems = make_batch(tmp_path, broken=1)
    one = run_cli("analyze", tmp_path, "--format", "jsonl", "--motion", "translation",
                  "--jobs", "1")
    two = run_cli("analyze", tmp_path, "--format", "jsonl", "--motion", "translation",
                  "--jobs", "2")
    assert one.returncode == two.returncode == 2  # the broken manifest is an input error
    assert one.stdout == two.stdout
    lines = one.stdout.splitlines()
    assert len(lines) == len(stems)
    sources = [Path(json.loads(x).get("source") or json.loads(x)["assembly"]["source"]).stem
               for x in lines]
    assert sources == stems
    errors = [json.loads(x) for x in lines if "error" in json.loads(x)]
    assert len(errors) == 1 and errors[0]["error"]["code"] == 2
    assert "Traceback" not in one.stderr + two.stderr


def test_examples_folder_gives_one_line_per_manifest():
    r = run_cli("analyze", EX, "--format", "jsonl", "--motion", "translation")
    assert r.returncode == 0, r.stderr
    assert len(r.stdout.splitlines()) == len(list(EX.glob("*.yaml")))


def test_out_dir_reports_and_index(tmp_path):
    src = tmp_path / "src"
    src.mkdir()
    stems = make_batch(src, broken=2)
    out = tmp_path / "out"
    r = run_cli("analyze", src, "--out-dir", out, "--motion", "translation", "-q")
    assert r.returncode == 2
    files = sorted(p.stem for p in out.glob("*.json") if p.name != "index.json")
    # named after the assembly (the manifest's name), made unique; error records by file stem
    assert len(files) == len(stems)
    assert set(SMALL) | {"zz-broken-0", "zz-broken-1"} == set(files)
    index = json.loads((out / "index.json").read_text())
    assert index["summary"] == {"assemblies": len(stems), "ok": len(stems) - 2, "errors": 2}



def test_out_dir_index_follows_the_schema_and_index_is_not_a_report_name(tmp_path):
    """index.json validates against the shipped schema (each entry has its top-level
    ``source``), and an assembly named ``index`` does not overwrite it."""
    from ndbg_cli.report.document import validate_report

    src = tmp_path / "src"
    src.mkdir()
    shutil.copytree(EX / "meshes", src / "meshes")
    shutil.copy(EX / "hover.yaml", src / "hover.yaml")
    (src / "index.yaml").write_text((EX / "stack.yaml").read_text()
                                    .replace("name: stack", "name: index"))
    (src / "zz-broken.yaml").write_text("name: x\nparts: [\n")
    out = tmp_path / "out"
    r = run_cli("analyze", src, "--out-dir", out, "--motion", "translation", "--no-cache",
                "-q")
    assert r.returncode == 2, r.stderr
    index = json.loads((out / "index.json").read_text())
    validate_report(index)
    assert index["schema"] == "ndbg.batch/1"
    assert [Path(e["source"]).name for e in index["reports"]] == \
        ["hover.yaml", "index.yaml", "zz-broken.yaml"]
    assert sorted(p.name for p in out.glob("*.json")) == \
        ["hover.json", "index-2.json", "index.json", "zz-broken.json"]
    assert json.loads((out / "index-2.json").read_text())["assembly"]["name"] == "index"


@pytest.mark.slow
def test_sigterm_leaves_only_complete_reports(tmp_path):
    src = tmp_path / "src"
    src.mkdir()
    make_batch(src, copies=4)
    out = tmp_path / "out"
    env = dict(os.environ)
    proc = subprocess.Popen([sys.executable, "-m", "ndbg_cli", "analyze", str(src), "--out-dir",
                             str(out), "--jobs", "2", "-q"], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, env=env)
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline and len(list(out.glob("*.json"))) < 3:
        time.sleep(0.05)
    proc.send_signal(signal.SIGTERM)
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == 143, err
    assert "Traceback" not in err
    written = list(out.glob("*.json"))
    assert 3 <= len(written) < 4 * len(SMALL)  # stopped midway
    for f in written:
        json.loads(f.read_text())  # complete JSON, never truncated
    assert not list(out.glob(".*.tmp"))


class _Stop(Exception):
    pass


def test_sigterm_inside_write_atomic_leaves_no_temporary_file(tmp_path, monkeypatch):
    """The window the batch test hits only by luck: SIGTERM just after the temporary file is
    created. The report is completed (or not started), the signal still stops the caller."""
    import tempfile

    from ndbg_cli.core import files

    real_mkstemp = tempfile.mkstemp

    def mkstemp_then_sigterm(*args, **kwargs):
        made = real_mkstemp(*args, **kwargs)
        os.kill(os.getpid(), signal.SIGTERM)
        time.sleep(0.01)  # a pending Python handler runs at the next bytecode boundary
        return made

    def stop(signum, frame):
        raise _Stop()

    previous = signal.signal(signal.SIGTERM, stop)
    monkeypatch.setattr(tempfile, "mkstemp", mkstemp_then_sigterm)
    try:
        with pytest.raises(_Stop):
            files.write_atomic(tmp_path / "r.json", '{"a": 1}\n')
    finally:
        signal.signal(signal.SIGTERM, previous)
    assert signal.getsignal(signal.SIGTERM) is previous
    assert [p.name for p in tmp_path.iterdir()] == ["r.json"]
    assert json.loads((tmp_path / "r.json").read_text()) == {"a": 1}


def _children(pid: int) -> dict[int, str]:
    """``child pid -> state letter`` (R running, S sleeping, ...) of a process, from /proc."""
    out = {}
    for d in Path("/proc").iterdir():
        if not d.name.isdigit():
            continue
        try:
            fields = (d / "stat").read_text().rsplit(")", 1)[1].split()
        except OSError:  # gone meanwhile
            continue
        if int(fields[1]) == pid:
            out[int(d.name)] = fields[0]
    return out


@pytest.mark.skipif(not Path("/proc/self/stat").exists(), reason="reads /proc")
def test_sigkilled_worker_costs_only_its_assembly(tmp_path):
    """A worker killed with SIGKILL (as by the out-of-memory killer) while it analyses one of
    two slow assemblies: that one gets an error record (exit code 3), the other one (under
    way in the worker the broken pool ended) is analysed again, the rest is kept."""
    src = tmp_path / "src"
    src.mkdir()
    shutil.copytree(EX / "meshes", src / "meshes")
    fast = ["hover", "fig5-rotation", "peg-37"]
    for name in fast:
        shutil.copy(EX / f"{name}.yaml", src / f"a-{name}.yaml")
    for stem in ("y-stack", "z-stack"):  # about 4 s each
        (src / f"{stem}.yaml").write_text((EX / "stack.yaml").read_text()
                                          .replace("name: stack", f"name: {stem}"))
    out = tmp_path / "out"
    proc = subprocess.Popen([sys.executable, "-m", "ndbg_cli", "analyze", str(src), "--out-dir",
                             str(out), "--jobs", "2", "--no-cache", "-q"],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        deadline = time.monotonic() + 120
        victim = None
        # reports are written in input order: once the fast ones are there, both workers
        # are on the stacks; kill one that is running
        while victim is None and time.monotonic() < deadline:
            time.sleep(0.05)
            if {f"{n}.json" for n in fast} <= {p.name for p in out.glob("*.json")}:
                victim = next((pid for pid, st in _children(proc.pid).items() if st == "R"),
                              None)
        assert victim is not None, "no busy worker seen"
        os.kill(victim, signal.SIGKILL)
        _, err = proc.communicate(timeout=120)
    finally:
        if proc.poll() is None:
            proc.kill()
    assert proc.returncode == 3, err
    assert "Traceback" not in err and "BrokenProcessPool" not in err
    index = json.loads((out / "index.json").read_text())
    assert index["summary"] == {"assemblies": 5, "ok": 4, "errors": 1}
    errors = [r for r in index["reports"] if "error" in r]
    assert Path(errors[0]["source"]).stem in ("y-stack", "z-stack")
    assert errors[0]["error"]["code"] == 3 and "SIGKILL" in errors[0]["error"]["message"]
    assert len(err.strip().splitlines()) == 1 and "SIGKILL" in err
    ok = {json.loads(p.read_text())["assembly"]["name"] for p in out.glob("*.json")
          if p.name != "index.json" and "error" not in json.loads(p.read_text())}
    assert ok == set(fast) | {"y-stack", "z-stack"} - {Path(errors[0]["source"]).stem}


def test_a_rerun_stopped_part_way_leaves_no_index_of_the_old_run(tmp_path):
    """Was: a rerun into the same --out-dir that stopped part-way kept the first run's
    index.json, describing files partly rewritten by the second. Now the index is removed
    before the first report and written at the end, naming each run's own files: here the
    rerun stops at its second report (the path is a folder: 'cannot write', exit 2)."""
    src = tmp_path / "src"
    src.mkdir()
    shutil.copytree(EX / "meshes", src / "meshes")
    for name in ("fig5-rotation", "hover", "peg-37"):
        shutil.copy(EX / f"{name}.yaml", src / f"{name}.yaml")
    out = tmp_path / "out"
    fast = ["--motion", "translation", "--no-cache", "-q", "--jobs", "1"]
    first = run_cli("analyze", src, "--out-dir", out, *fast)
    assert first.returncode == 0, first.stderr
    index = json.loads((out / "index.json").read_text())
    assert [Path(e["source"]).name for e in index["reports"]] == \
        ["fig5-rotation.yaml", "hover.yaml", "peg-37.yaml"]
    (src / "peg-37.yaml").unlink()
    (out / "hover.json").unlink()
    (out / "hover.json").mkdir()  # the rerun cannot write its second report
    r = run_cli("analyze", src, "--out-dir", out, *fast)
    assert r.returncode == 2 and "cannot write" in r.stderr, r.stderr
    assert not (out / "index.json").exists()
    (out / "hover.json").rmdir()
    again = run_cli("analyze", src, "--out-dir", out, *fast)
    assert again.returncode == 0, again.stderr
    index = json.loads((out / "index.json").read_text())
    assert index["summary"]["assemblies"] == 2
    assert [e["report"] for e in index["reports"]] == ["fig5-rotation.json", "hover.json"]
    assert not list(out.glob(".*.tmp"))


def test_index_json_that_cannot_be_removed_is_an_input_error(tmp_path):
    src = tmp_path / "src"
    src.mkdir()
    shutil.copytree(EX / "meshes", src / "meshes")
    shutil.copy(EX / "hover.yaml", src / "hover.yaml")
    (tmp_path / "out" / "index.json").mkdir(parents=True)
    r = run_cli("analyze", src, "--out-dir", tmp_path / "out", "--motion", "translation")
    assert r.returncode == 2
    assert r.stderr.startswith(f"ndbg: error: cannot write {tmp_path / 'out'}: ")
    assert not (tmp_path / "out" / "hover.json").exists()  # refused before any analysis


def test_a_run_that_cannot_start_keeps_the_previous_index(tmp_path, monkeypatch):
    """The index goes only once the run can start: an unreachable dask scheduler (exit 2
    before any analysis) leaves the previous complete run's index and reports as they were."""
    pytest.importorskip("distributed")
    src = tmp_path / "src"
    src.mkdir()
    shutil.copytree(EX / "meshes", src / "meshes")
    shutil.copy(EX / "hover.yaml", src / "hover.yaml")
    out = tmp_path / "out"
    first = run_cli("analyze", src, "--out-dir", out, "--motion", "translation", "-q")
    assert first.returncode == 0, first.stderr
    before = (out / "index.json").read_text()
    monkeypatch.setenv("NDBG_SCHEDULER_TIMEOUT", "1")  # nothing listens there
    r = run_cli("analyze", src, "--out-dir", out, "--scheduler", "tcp://127.0.0.1:1")
    assert r.returncode == 2 and "tcp://127.0.0.1:1" in r.stderr
    assert (out / "index.json").read_text() == before


def test_one_assembly_with_workers_gives_the_same_report_and_a_failing_side_job_is_redone():
    """``Options.workers`` > 1 computes the interlock LP and the grasps in a forked process
    beside the planner (:class:`ndbg_cli.core.pools.Forked`): the report must be the same
    byte for byte. A side job that fails in its child is run again in the parent, whose
    error is the one the caller sees; one that cannot fork runs in place."""
    import dataclasses

    import ndbg_cli
    from ndbg_cli.core.options import Options
    from ndbg_cli.core.pools import Forked
    from ndbg_cli.report.document import dumps

    for name in ("bell", "fig3-2d", "fig10-latch"):
        asm = ndbg_cli.load(EX / f"{name}.yaml")
        one = dumps(ndbg_cli.analyze(asm, Options()))
        two = dumps(ndbg_cli.analyze(asm, dataclasses.replace(Options(), workers=2)))
        assert one == two, name
    assert Forked(divmod, 17, 5).result() == (3, 2)
    assert Forked(divmod, 17, 5, enabled=False).result() == (3, 2)
    with pytest.raises(ZeroDivisionError):
        Forked(divmod, 1, 0).result()


def _sum_after(path, parts, get):
    """A ``later`` job's body: waits until ``path`` exists (the parent makes it only once its
    ``send`` has returned), then adds what it was sent."""
    import time

    while not path.exists():
        time.sleep(0.01)
    return sum(parts) + sum(get())


def test_a_forked_job_given_its_input_later(tmp_path):
    """``Forked(..., later=True)``: the child starts on its arguments and waits for the
    value the parent sends; a value larger than a pipe's buffer does not make ``send`` wait
    for the child to ask for it (the child asks only after the parent's ``send`` returned:
    without the child's reader this deadlocks), and the same value comes without a child."""
    from ndbg_cli.core.pools import Forked

    big = list(range(200_000))  # about 1 MB pickled, over the 64 KiB of a pipe
    for enabled in (True, False):
        flag = tmp_path / f"sent-{enabled}"
        job = Forked(_sum_after, flag, [1, 2], enabled=enabled, later=True)
        job.send(big)
        flag.touch()
        assert job.result() == 3 + sum(big)
    with pytest.raises(RuntimeError):
        Forked(divmod, 1, 2).send(3)  # not a later job
    # a job dropped before its input is sent: the child reads end of file and ends
    dropped = Forked(_sum_after, flag, [], later=True)
    child = dropped._proc
    del dropped
    child.join(timeout=30)
    assert child.exitcode == 0
    # dropped after it was sent, with a result larger than a pipe's buffer: the child's
    # write breaks (it holds no reading end of its own), it does not wait for ever
    dropped = Forked(_big_after, flag, later=True)
    dropped.send(1)
    child = dropped._proc
    del dropped
    child.join(timeout=30)
    assert child.exitcode == 0
    # cancelled while it waits for its input: ended at once
    job = Forked(_sum_after, flag, [], later=True)
    child = job._proc
    job.cancel()
    assert not child.is_alive()
    # a with block that raises drops it the same way; one that took the value leaves nothing
    with pytest.raises(KeyError):
        with Forked(_sum_after, flag, [], later=True) as job:
            child = job._proc
            raise KeyError
    assert not child.is_alive()
    with Forked(divmod, 17, 5) as job:
        assert job.result() == (3, 2)


def _big_after(path, get):
    return "x" * 1_000_000 * get()


def test_a_later_jobs_seconds_leave_out_its_wait_for_the_input(tmp_path):
    """The child's own seconds (``--timings``' ``interlock_s``) do not count the time it
    waited for its input: here it is sent after a second, and its work takes none."""
    import time

    from ndbg_cli.core.pools import Forked

    job = Forked(_sum_after, tmp_path, [1], later=True)
    time.sleep(1.0)
    job.send([2])
    assert job.result() == 3
    assert 0 <= job.seconds < 0.5


def test_contacts_in_worker_processes_are_the_contacts_found_in_one(monkeypatch):
    """The narrow phase over forked workers (``analyze_contacts(workers=2)``, here with the
    work threshold lowered so a small example takes that path) finds the same contacts and
    interferences, in the same order, as one process: the press fit and the clash too."""
    import ndbg_cli
    import ndbg_cli.contacts.contacts3d as c3
    from ndbg_cli.report.contacts import contacts_section
    from ndbg_cli.report.document import dumps

    monkeypatch.setattr(c3, "MIN_PARALLEL_TRIANGLES", 0)
    for name in ("gearbox", "press-fit", "clash", "bell"):
        asm = ndbg_cli.load(EX / f"{name}.yaml")
        one, two = (contacts_section(asm, c3.analyze_contacts(asm, workers=w)) for w in (1, 2))
        for sec in (one, two):
            sec["contact_stats"].pop("timings_s", None)
        assert dumps(one) == dumps(two), name


def _slow_item(context: float, item: int) -> int:
    time.sleep(context)
    return item


@pytest.mark.parametrize("workers", [1, 2])
def test_items_dropped_before_they_start_are_not_computed(workers):
    """``Mapper.imap``'s ``drop``: the caller adds the last items once the first value is in;
    with one process none of them is computed, with two workers (each item 0.3 s) they are
    still waiting then, and are not computed or yielded either."""
    from ndbg_cli.core.pools import ForkMapper

    drop: set[int] = set()
    got = []
    for k, value in ForkMapper(workers).imap(_slow_item, 0.3 if workers > 1 else 0.0,
                                             list(range(12)), drop=drop):
        assert k == value
        got.append(k)
        drop.update({9, 10, 11})
    assert got[0] == 0 and not {9, 10, 11} & set(got)
    assert set(got) >= set(range(1, 4)), got  # the first ones had started


def _fails_in_a_child(parent: int, item: int) -> int:
    if item == 3 and os.getpid() != parent:
        raise RuntimeError("only in the child")
    return 2 * item


def test_a_helpers_batch_that_fails_in_its_child_is_computed_here():
    """``Helper``: a batch whose function raises in the child is computed by the caller
    (which would see the error itself); the next batches still go to the child."""
    from ndbg_cli.core.pools import Helper

    with Helper(_fails_in_a_child, os.getpid()) as helper:
        helper.start([1, 2, 3])
        assert helper.values() == [2, 4, 6]
        helper.start([4, 5])
        assert helper.values() == [8, 10]
        with pytest.raises(RuntimeError):
            helper.values()  # no batch started


def test_a_helper_left_with_a_batch_under_way_ends_at_once():
    """``Helper.close`` after ``start`` without ``values`` (the caller raised meanwhile): the
    child, busy with the batch, is terminated rather than waited for."""
    from ndbg_cli.core.pools import Helper

    helper = Helper(_slow_item, 30.0)
    helper.start([1])
    t0 = time.monotonic()
    helper.close()
    assert time.monotonic() - t0 < 3.0


def test_items_that_do_not_pickle_are_computed_by_the_caller():
    from ndbg_cli.core.pools import Helper

    with Helper(lambda c, x: x(c), 3) as helper:
        helper.start([lambda c: c + 1, lambda c: c * 2])  # lambdas: no pickle
        assert helper.values() == [4, 6]


def test_spare_workers_leave_out_a_forked_job_still_at_work():
    """``spare_workers(2)``: none while a ``Forked`` job's child works (the AND/OR build then
    starts no Helper beside it: three busy processes on two cores), one once its value is
    sent, and again after it is taken."""
    from ndbg_cli.core.pools import Forked, spare_workers

    assert spare_workers(2) == 1
    job = Forked(_slow_item, 1.0, 7)
    assert spare_workers(2) == 0
    time.sleep(2.0)  # its value is in the pipe
    assert spare_workers(2) == 1
    assert job.result() == 7 and spare_workers(2) == 1

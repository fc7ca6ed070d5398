"""``ndbg analyze --scheduler``: batches on a dask.distributed cluster give the same reports,
in the same order, as a local run; so does one assembly whose per-pair work is computed on the
cluster's workers; a bad or unreachable scheduler is a one-line input error."""

from __future__ import annotations

import json
import shutil
import subprocess
import sys
from collections import Counter
from pathlib import Path

import pytest

distributed = pytest.importorskip("distributed")

from dask.utils import key_split  # noqa: E402

from ndbg_cli.contacts import contacts3d  # noqa: E402
from ndbg_cli.core.options import Options  # noqa: E402
from ndbg_cli.ndbg.infinite import pair_workers  # noqa: E402
from ndbg_cli.pipeline import batch, cluster  # noqa: E402

from conftest import ROOT  # noqa: E402
from helpers import run_cli  # noqa: E402

EX = Path(__file__).resolve().parents[1] / "assemblies"
THREE = ["hover", "stack", "peg-37"]


def make_three(tmp_path: Path) -> tuple[Path, list[Path]]:
    """``tmp_path/src``: three small examples with their meshes folder (the result cache stays
    outside it); returns the folder and its manifests in sorted order."""
    folder = tmp_path / "src"
    shutil.copytree(EX / "meshes", folder / "meshes")
    for name in THREE:
        shutil.copy(EX / f"{name}.yaml", folder / f"{name}.yaml")
    return folder, sorted(folder.glob("*.yaml"))


@pytest.fixture(autouse=True)
def own_cache(tmp_path, monkeypatch):
    """Each test (and the CLI runs it starts) uses its own result cache folder."""
    monkeypatch.setenv("NDBG_CACHE_DIR", str(tmp_path / "cache"))


def _plain_and_local_cluster(tmp_path, monkeypatch, *args):
    """``ndbg *args`` with ``--jobs 1``, then with ``--scheduler local --jobs 2``, each with a
    cache folder of its own (the second computes, it does not read the first's results);
    both must succeed. Returns the two runs."""
    monkeypatch.setenv("NDBG_CACHE_DIR", str(tmp_path / "cache-plain"))
    plain = run_cli(*args, "--jobs", "1")
    monkeypatch.setenv("NDBG_CACHE_DIR", str(tmp_path / "cache-dask"))
    dask = run_cli(*args, "--scheduler", "local", "--jobs", "2")
    assert plain.returncode == 0, plain.stderr
    assert dask.returncode == 0, dask.stderr
    return plain, dask


def test_local_cluster_is_byte_identical_to_a_local_run(tmp_path, monkeypatch):
    src, _ = make_three(tmp_path)
    plain, dask = _plain_and_local_cluster(tmp_path, monkeypatch, "analyze", src, "--format",
                                           "jsonl", "--motion", "translation")
    assert len(plain.stdout.splitlines()) == 3
    assert dask.stdout == plain.stdout
    assert "Traceback" not in dask.stderr


def test_unreachable_scheduler_is_a_one_line_error(tmp_path, monkeypatch):
    monkeypatch.setenv("NDBG_SCHEDULER_TIMEOUT", "1")  # nothing listens: no need to wait 10 s
    src, _ = make_three(tmp_path)
    r = run_cli("analyze", src, "--format", "jsonl", "--scheduler", "tcp://127.0.0.1:1")
    assert r.returncode == 2
    assert r.stdout == ""
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("ndbg: error: "), r.stderr
    assert "tcp://127.0.0.1:1" in lines[0]
    assert "Traceback" not in r.stderr


@pytest.mark.parametrize("address", ["nonsense", "foo://host:1"])
def test_malformed_address_is_a_one_line_error(tmp_path, address):
    src, _ = make_three(tmp_path)
    r = run_cli("analyze", src, "--scheduler", address)
    assert r.returncode == 2
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith(f"ndbg: error: --scheduler {address}: ")


def test_without_distributed_the_cli_says_what_to_install(tmp_path):
    src, _ = make_three(tmp_path)
    code = ("import sys; sys.modules['distributed'] = None\n"
            "from ndbg_cli.cli.main import main\n"
            f"main(['analyze', {str(src)!r}, '--scheduler', 'local'])\n")
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert r.returncode == 2
    assert r.stderr == f"ndbg: error: {cluster.DASK_MISSING}\n"


def test_a_task_failing_on_the_cluster_becomes_an_error_record(tmp_path, monkeypatch):
    """A failure outside analyze_one (a worker died, a result could not be sent) gives the
    error record analyze_one makes for a bug; the other targets are unaffected."""
    _, targets = make_three(tmp_path)
    real = batch.analyze_one

    def flaky(target, options, debug=False):
        if Path(target).stem == "peg-37":  # the middle one
            raise RuntimeError("worker lost")
        return real(target, options, debug)

    monkeypatch.setattr(batch, "analyze_one", flaky)
    options = Options(motion="translation")
    # threads in this process, so the workers see the patched function
    with distributed.LocalCluster(n_workers=1, threads_per_worker=2, processes=False,
                                  protocol="tcp://", host="127.0.0.1",
                                  dashboard_address=None) as cluster:
        out = list(batch.run_batch_dask(targets, options, cluster.scheduler_address, 2))
    assert [Path(r.get("source") or r["assembly"]["source"]).stem for r in out] == sorted(THREE)
    bad = out[1]
    assert bad["error"]["code"] == 3 and bad["error"]["kind"] == "NdbgError"
    assert bad["error"]["message"].startswith(f"{targets[1]}: internal error: RuntimeError: "
                                              "worker lost")
    assert out[0] == real(targets[0], options) and out[2] == real(targets[2], options)


def _rack(folder: Path, levels: int) -> Path:
    """The synthetic rack of ``levels`` boards on standoffs (``assemblies/build.py``)."""
    sys.path.insert(0, str(EX))
    try:
        import build
    finally:
        sys.path.pop(0)
    return folder / f"{build.rack(folder, levels)}.yaml"


def test_one_assembly_on_a_local_cluster_gives_the_report_of_one_process(tmp_path, monkeypatch):
    """A single assembly with ``--scheduler local --jobs 2``: analysed in the CLI's process, its
    contact pairs on a LocalCluster of two worker processes; the full JSON report is
    byte-identical to ``--jobs 1``'s. A rack of 5 boards (21 parts), translations only (its
    whole-sphere infinite NDBG alone takes half a minute; the next test has that stage)."""
    path = _rack(tmp_path / "src", 5)
    plain, dask = _plain_and_local_cluster(tmp_path, monkeypatch, "analyze", path, "--format",
                                           "json", "--detail", "full", "--motion", "translation")
    report = json.loads(plain.stdout)
    assert len(report["assembly"]["parts"]) == 21
    assert len(report["contact_stats"]["touching_pairs"]) == 32
    assert dask.stdout == plain.stdout
    assert "Traceback" not in dask.stderr


def test_one_assembly_pair_work_runs_on_the_cluster_workers(tmp_path, monkeypatch):
    """``--scheduler ADDRESS`` on one assembly sends its per-pair work to that cluster (two
    worker processes started here): the scheduler's task stream holds, for both per-pair
    stages (the contacts' narrow phase, the infinite NDBG's blocked sets), the tasks that the
    part pairs the run computed (its cache misses, in the report's timings) are dealt into,
    and both workers took some. Work that stayed in the CLI's process would leave no task.
    The report, timings removed, is ``--jobs 1``'s."""
    path = EX / "fig2-sandwich-5.yaml"
    args = ("analyze", path, "--format", "json", "--detail", "full", "--timings")
    monkeypatch.setenv("NDBG_CACHE_DIR", str(tmp_path / "cache-plain"))
    plain = run_cli(*args, "--jobs", "1")
    monkeypatch.setenv("NDBG_CACHE_DIR", str(tmp_path / "cache-dask"))
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                  host="127.0.0.1", dashboard_address=None) as here, \
            distributed.Client(here, set_as_default=False) as client:
        workers = set(client.scheduler_info()["workers"])
        with distributed.get_task_stream(client) as stream:
            dask = run_cli(*args, "--scheduler", here.scheduler_address, "--jobs", "2")
    assert plain.returncode == 0, plain.stderr
    assert dask.returncode == 0, dask.stderr
    got, want = json.loads(dask.stdout), json.loads(plain.stdout)
    timings = got.pop("timings")
    want.pop("timings")
    assert got == want
    tasks = Counter(key_split(t["key"]) for t in stream.data)

    def dealt(pairs: int) -> int:  # the tasks a map of that many items makes on two threads
        return len(cluster.deal(range(pairs), cluster.TASKS_PER_THREAD * 2))

    # each contact pair of the sandwich touches (its surfaces cross) without interfering:
    # its interference test and its surface contacts are two items (clash units may follow)
    assert tasks == {
        cluster.task_prefix(contacts3d._narrow_phase):
            dealt(2 * timings["cache_contacts_misses"]),
        cluster.task_prefix(pair_workers._pair_blocked_sets):
            dealt(timings["cache_infinite_misses"])}
    assert min(tasks.values()) > 1
    assert {t["worker"] for t in stream.data} == workers and len(workers) == 2


def test_items_are_dealt_round_robin_from_the_costliest():
    assert cluster.deal([5, 4, 3, 2, 1], 2) == [[5, 3, 1], [4, 2]]
    assert cluster.deal([2, 0, 1], 8) == [[2], [0], [1]]
    assert cluster.deal([1, 0], 0) == [[1, 0]]
    assert cluster.deal([], 8) == []


def _fails_on_a_worker(context: int, item: int) -> int:
    """``context + item``, except on a dask worker for item 2; item 0 fails everywhere."""
    if item == 0:
        raise ZeroDivisionError("item 0")
    try:
        distributed.get_worker()
    except ValueError:  # not on a worker: here
        return context + item
    if item == 2:
        raise RuntimeError("lost on the cluster")
    return context + item


def test_cluster_mapper_computes_here_what_failed_there():
    """:class:`~ndbg_cli.pipeline.cluster.ClusterMapper`: values in item order whatever the
    order handed out; a task that fails on the cluster is computed here (the value a loop
    gives), and an error of the function's own is raised here, as in a loop."""
    with distributed.LocalCluster(n_workers=1, threads_per_worker=2, processes=False,
                                  protocol="tcp://", host="127.0.0.1",
                                  dashboard_address=None) as here, \
            distributed.Client(here, set_as_default=False) as client:
        mapper = cluster.ClusterMapper(client)
        seen: list = []
        assert mapper.map(_fails_on_a_worker, 10, [1, 2, 3], order=[2, 0, 1], small=True,
                          meanwhile=lambda: seen.append(1)) == [11, 12, 13]
        assert seen == [1]
        assert mapper.map(_fails_on_a_worker, 10, []) == []
        with pytest.raises(ZeroDivisionError, match="item 0"):
            mapper.map(_fails_on_a_worker, 10, [3, 0, 1])


def test_cluster_workers_end_without_binding_warnings(tmp_path):
    """The clash example's interference tests run on the local cluster's workers (manifold3d
    solids, kept per part); a worker ends as Python does, tearing its modules down, and
    nanobind, manifold3d's binding, printed a warning for every solid still kept then. They
    are freed before that (an exit function), so the run's stderr stays empty."""
    r = run_cli("analyze", str(ROOT / "assemblies" / "clash.yaml"), "--format", "json",
                "--out", str(tmp_path / "r.json"), "--scheduler", "local", "--jobs", "2")
    assert r.returncode == 0, r.stderr
    assert "leaked" not in r.stderr and "nanobind" not in r.stderr, r.stderr[:300]

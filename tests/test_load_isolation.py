"""A reader that crashes, hangs or runs out of memory never takes ndbg down (issue 36).

Native readers (OpenCASCADE for STEP/IGES, trimesh over libxml2 and image decoders for glTF,
3DXML, 3MF) run in a child process (:mod:`ndbg_cli.io.isolated`); a crash, a timeout or an
out-of-memory there is a one-line input error (exit 2) in every command and with any
``--jobs``. The crashes here are real: a ``sitecustomize`` module on the child's path swaps
the reader for one that dereferences NULL, aborts or sleeps (the parent is left alone, so a
crash reaching it would show). Damaged files of every format (a fixed-seed fuzz slice) end in
a report or a one-line input error, with nothing else on stderr.
"""

from __future__ import annotations

import json
import logging
import os
import subprocess
import sys
import time
import warnings
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import numpy as np
import pytest

from ndbg_cli.core.constants import DEFLECTION_RELATIVE as DEFLECTION
from ndbg_cli.core.errors import InputError
from ndbg_cli.io.isolated import run_isolated
from ndbg_cli.io.loaders import default_deflection_mm, load

from conftest import ROOT, SHARED, shared
from fuzzing import cases, write_samples
from helpers import box

CORRUPT = ["screw-mutated-1.step", "screw-mutated-2.step", "screw-mutated-3.step",
           "beam-part-mutated.obj"]

#: Swaps the reader of a reader's child (``python -c``, see ndbg_cli.io.isolated) for a
#: faulty one when NDBG_TEST_READER_FAULT is set; other processes are left alone.
SITECUSTOMIZE = '''
import os, sys
_FAULT = os.environ.get("NDBG_TEST_READER_FAULT")
if _FAULT and sys.argv[:1] == ["-c"]:
    import ndbg_cli.io.loaders as _loaders

    def _faulty(*args, **kwargs):
        if _FAULT == "segv":
            import ctypes
            ctypes.string_at(0)
        elif _FAULT == "abort":
            os.abort()
        elif _FAULT == "hang":
            import time
            time.sleep(600)
        raise RuntimeError("unknown fault " + _FAULT)

    _loaders.read_model = _faulty
'''

#: Functions the library-level tests run in a child (a module on the child's path).
CHILD_FUNCS = '''
import os

def segv(stage):
    import ctypes
    stage("about to crash")
    ctypes.string_at(0)

def abort(stage):
    os.abort()

def hang(stage):
    import time
    stage("sleeping")
    time.sleep(600)

def hog(stage):
    return bytearray(4 << 30)  # 4 GiB, above the limit the test sets

def fails(stage):
    raise ValueError("bad header\\nsecond line")

def refuses(stage):
    from ndbg_cli.core.errors import InputError
    raise InputError("no shape in it", part="p1")

def arrays(n, stage):
    import numpy as np
    rng = np.random.default_rng(n)
    return [("a", rng.random((n, 3)), rng.integers(0, n, (2 * n, 3)))]
'''


def _env(fault_dir: Path, fault: str | None = None) -> dict:
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join([str(fault_dir), str(ROOT),
                                         env.get("PYTHONPATH", "")]).rstrip(os.pathsep)
    env.pop("NDBG_DEBUG_NATIVE", None)
    if fault:
        env["NDBG_TEST_READER_FAULT"] = fault
    else:
        env.pop("NDBG_TEST_READER_FAULT", None)
    return env


def _ndbg(*args, env: dict | None = None, cwd: Path | None = None,
          timeout: float = 120) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "ndbg_cli", *map(str, args)],
                          capture_output=True, text=True, env=env, cwd=cwd, timeout=timeout)


def _stderr_lines(r: subprocess.CompletedProcess) -> list[str]:
    """stderr's lines but the status lines of a load that took over 10 s (a loaded
    machine): ``ndbg: loading FILE: STAGE (N s so far)``."""
    return [x for x in r.stderr.strip().splitlines() if not x.startswith("ndbg: loading ")]


def _one_line_input_error(r: subprocess.CompletedProcess, *fragments: str) -> str:
    assert r.returncode == 2, (r.returncode, r.stderr[-2000:])
    lines = _stderr_lines(r)
    assert len(lines) == 1 and lines[0].startswith("ndbg: error: "), r.stderr[-2000:]
    assert "Traceback" not in r.stderr and "internal error" not in r.stderr
    for f in fragments:
        assert f in lines[0], lines[0]
    return lines[0]


def _parallel(jobs: list, workers: int = 3) -> list:
    """Run the ``(function, args)`` in ``jobs`` a few at a time (each starts processes)."""
    with ThreadPoolExecutor(workers) as pool:
        return list(pool.map(lambda job: job[0](*job[1]), jobs))


@pytest.fixture(scope="module")
def fault_dir(tmp_path_factory) -> Path:
    d = tmp_path_factory.mktemp("fault")
    (d / "sitecustomize.py").write_text(SITECUSTOMIZE)
    (d / "ndbg_test_child_funcs.py").write_text(CHILD_FUNCS)
    return d


@pytest.fixture(scope="module")
def glb(tmp_path_factory) -> Path:
    import trimesh

    d = tmp_path_factory.mktemp("glb")
    scene = trimesh.Scene()
    scene.add_geometry(box((0, 0, 0), (1, 1, 1)), node_name="lower", geom_name="lower")
    scene.add_geometry(box((0, 0, 1), (1, 1, 2)), node_name="upper", geom_name="upper")
    path = d / "two.glb"
    scene.export(path)
    return path


def test_meanwhile_runs_while_a_native_reader_reads_only(glb):
    """``load(meanwhile=)``: called here while the GLB reader's child reads (the CLI loads
    numba's kernels then), not for a manifest of STL files, read in this process."""
    calls: list[int] = []
    asm = load(glb, meanwhile=lambda: calls.append(os.getpid()))
    assert asm.ids == ["lower", "upper"] and calls == [os.getpid()]
    load(ROOT / "assemblies" / "hover.yaml", meanwhile=lambda: calls.append(0))
    assert calls == [os.getpid()]


# -- the damaged files of ../shared/data/corrupt -------------------------------------------

@pytest.mark.external
def test_corrupt_files_are_one_line_input_errors_in_every_loading_command(tmp_path):
    """Were: exit 139 with nothing on stderr (STEP, a segfault in OpenCASCADE), and exit 3
    (OBJ, ``ValueError: matmul`` on vertices of one coordinate)."""
    folder = shared("corrupt")
    runs = [("analyze", name) for name in CORRUPT]
    runs += [(cmd, name) for cmd in ("contacts", "convert")
             for name in ("screw-mutated-1.step", "beam-part-mutated.obj")]

    def run(cmd, name):
        extra = ["--out", tmp_path / f"out-{name}"] if cmd == "convert" else []
        return _ndbg(cmd, folder / name, *extra, "--no-cache" if cmd == "analyze" else "-q")

    for (cmd, name), r in zip(runs, _parallel([(run, job) for job in runs])):
        line = _one_line_input_error(r, str(folder / name))
        if name.endswith(".step"):
            assert "the STEP reader (OpenCASCADE) crashed on this file: segmentation fault" \
                in line, (cmd, line)
        else:
            assert "vertices of shape (3502, 1)" in line, (cmd, line)
        if cmd == "convert":
            assert not (tmp_path / f"out-{name}" / "meshes").exists() or \
                not list((tmp_path / f"out-{name}" / "meshes").iterdir())


@pytest.mark.external
@pytest.mark.parametrize("name", CORRUPT)
def test_corrupt_files_raise_input_errors_in_the_library(name):
    with pytest.raises(InputError) as err:
        load(shared("corrupt", name))
    assert err.value.file == str(SHARED / "corrupt" / name)


# -- a crashing reader, in every command and in a batch ------------------------------------

def test_a_crashing_reader_is_contained_in_every_command(tmp_path, fault_dir, glb):
    """A real segfault (and an abort) in the reader's child: one line, exit 2, in every
    command that loads; the reports and outputs of healthy runs are not needed for that."""
    rules = tmp_path / "rules.yaml"
    rules.write_text("rules:\n  no_interference: true\n")
    commands = [
        ("segv", ["analyze", glb, "--no-cache"]),
        ("segv", ["check", glb, "--rules", rules, "--no-cache"]),
        ("segv", ["contacts", glb]),
        ("abort", ["convert", glb, "--out", tmp_path / "conv"]),
        ("segv", ["query", glb, "--direction", "0,0,1"]),
        ("abort", ["remove", glb, "lower"]),
    ]
    results = _parallel([(lambda f, a: _ndbg(*a, env=_env(fault_dir, f)), job)
                         for job in commands])
    for (fault, args), r in zip(commands, results):
        how = "segmentation fault (SIGSEGV)" if fault == "segv" else "aborted (SIGABRT)"
        what = (str(glb), "the GLB reader (trimesh) crashed on this file", how)
        if args[0] == "check":  # the error record is in the check's report, on stdout
            assert r.returncode == 2 and "Traceback" not in r.stderr + r.stdout, r.stderr
            assert all(w in r.stdout for w in what), r.stdout
            assert _stderr_lines(r) == [
                "ndbg check: 0 of 1 assemblies pass (1 rules checked, 1 violation(s))"]
            continue
        _one_line_input_error(r, *what)


def test_a_crashing_reader_in_a_batch_is_one_error_record(tmp_path, fault_dir, glb):
    """In a batch (worker processes, ``--jobs 2``) the assembly whose reader crashed gets an
    input-error record and the others complete; the same with ``--jobs 1``."""
    (tmp_path / "bad").mkdir()
    (tmp_path / "bad" / "two.glb").write_bytes(glb.read_bytes())
    (tmp_path / "bad" / "a.yaml").write_text("parts:\n  - {id: a, mesh: two.glb}\n")
    good = tmp_path / "good"
    good.mkdir()
    box((0, 0, 0), (1, 1, 1)).export(good / "a.stl")
    box((0, 0, 1), (1, 1, 2)).export(good / "b.stl")
    (good / "b.yaml").write_text("parts:\n  - {id: a, mesh: a.stl}\n  - {id: b, mesh: b.stl}\n")
    runs = [["analyze", tmp_path, "--jobs", j, "--format", "jsonl", "--no-cache", "-q"]
            for j in ("1", "2")]
    for r in _parallel([(lambda a: _ndbg(*a, env=_env(fault_dir, "segv")), (a,))
                        for a in runs]):
        assert r.returncode == 2, r.stderr
        import json

        recs = [json.loads(line) for line in r.stdout.splitlines()]
        assert len(recs) == 2
        bad, ok = recs
        assert bad["error"]["code"] == 2 and "crashed on this file" in bad["error"]["message"]
        assert "error" not in ok and ok["assembly"]["name"] == "b"
        line = _one_line_input_error(r, "two.glb")
        assert "segmentation fault" in line


def test_a_hanging_reader_ends_at_the_load_timeout(fault_dir, glb):
    t0 = time.monotonic()
    r = _ndbg("contacts", glb, "--load-timeout", "1.5", env=_env(fault_dir, "hang"))
    elapsed = time.monotonic() - t0
    _one_line_input_error(r, str(glb), "the GLB reader (trimesh) did not finish within 1.5 s",
                          "--load-timeout")
    assert elapsed < 15, elapsed


def test_healthy_native_file_through_the_child(glb, fault_dir):
    """The reader's child gives the same parts as reading in the process."""
    r = _ndbg("contacts", glb, "--format", "json", env=_env(fault_dir))
    assert r.returncode == 0 and r.stderr == "", r.stderr
    a, b = load(glb), load(glb, isolate=False)
    assert a.ids == b.ids
    for p, q in zip(a.parts, b.parts):
        assert p.hash == q.hash
        assert np.array_equal(p.mesh.vertices, q.mesh.vertices)
        assert np.array_equal(p.mesh.faces, q.mesh.faces)


# -- the mechanism, in the library -------------------------------------------------------

@pytest.fixture
def child_path(fault_dir, monkeypatch):
    monkeypatch.setenv("PYTHONPATH", os.pathsep.join([str(fault_dir), str(ROOT)]))
    monkeypatch.delenv("NDBG_DEBUG_NATIVE", raising=False)
    monkeypatch.delenv("NDBG_TEST_READER_FAULT", raising=False)


def _isolated(name: str, *args, timeout: float | None = 30, memory: float | None = 2.0,
              progress=None):
    return run_isolated(f"ndbg_test_child_funcs:{name}", args, file="f.step",
                        reader="the X reader", timeout=timeout, memory_gib=memory,
                        progress=progress, timeout_hint="try less")


@pytest.mark.parametrize("name, fragment", [
    ("segv", "the X reader crashed on this file: segmentation fault (SIGSEGV)"),
    ("abort", "the X reader crashed on this file: aborted (SIGABRT)"),
    ("hog", "the X reader ran out of memory (limit 2 GiB, --load-memory)"),
    ("fails", "the X reader failed: ValueError: bad header"),
])
def test_child_failures_are_input_errors(child_path, name, fragment):
    with pytest.raises(InputError) as err:
        _isolated(name)
    assert err.value.file == "f.step"
    assert fragment in err.value.message and "\n" not in err.value.message


def test_child_input_errors_keep_their_part(child_path):
    with pytest.raises(InputError) as err:
        _isolated("refuses")
    assert err.value.message == "f.step: part 'p1': no shape in it"


def test_child_timeout_and_progress(child_path):
    seen = []
    t0 = time.monotonic()
    with pytest.raises(InputError) as err:
        _isolated("hang", timeout=1.0, progress=lambda stage, s: seen.append(stage))
    assert time.monotonic() - t0 < 5
    assert err.value.message == ("f.step: the X reader did not finish within 1 s "
                                 "(--load-timeout; try less)")
    assert "sleeping" in seen


def test_work_meanwhile_longer_than_the_limit_is_not_the_readers_timeout(child_path):
    """``run_isolated(meanwhile=)`` outlasting ``timeout``: the child answered in time, and
    what waits in the pipe is read before any timeout is declared (a small --load-timeout
    and numba compiling its kernels meanwhile gave 'did not finish')."""
    calls = []
    got = run_isolated("ndbg_test_child_funcs:arrays", (10,), file="f.step",
                       reader="the X reader", timeout=1.0, memory_gib=2.0,
                       meanwhile=lambda: (time.sleep(1.5), calls.append(1)))
    assert calls == [1] and got[0][0] == "a"


def test_child_arrays_cross_exactly(child_path):
    (name, v, f), = _isolated("arrays", 200_000)
    rng = np.random.default_rng(200_000)
    assert name == "a" and np.array_equal(v, rng.random((200_000, 3)))
    assert np.array_equal(f, rng.integers(0, 200_000, (400_000, 3)))


# -- deflection ----------------------------------------------------------------------------

def test_default_deflection_follows_the_model_size_above_one_metre():
    def points(*coords):
        return "".join(f"#{k}=CARTESIAN_POINT('',({x:.1f},{y:.1f},{z:.1f}));\n"
                       for k, (x, y, z) in enumerate(coords)).encode()

    assert default_deflection_mm(points((0, 0, 0), (300, 0, 0)), "mm") == 0.01
    assert default_deflection_mm(points((0, 0, 0), (3000, 4000, 0)), "mm") == \
        pytest.approx(0.05)
    assert default_deflection_mm(points((0, 0, 0), (3, 4, 0)), "m") == pytest.approx(0.05)
    assert default_deflection_mm(b"no points", "mm") == 0.01
    # the size is the same in any frame (a box diagonal grew by up to 1.7 when turned)
    corners = np.array([(x, y, z) for x in (0, 3000) for y in (0, 4000) for z in (0, 500)], float)
    turn = np.linalg.qr(np.random.default_rng(7).normal(size=(3, 3)))[0]
    want = default_deflection_mm(points(*corners), "mm")
    assert want == pytest.approx(DEFLECTION * np.sqrt(3000**2 + 4000**2 + 500**2))
    assert default_deflection_mm(points(*(corners @ turn.T)), "mm") == pytest.approx(want, rel=1e-4)
    flat = np.array([(0, 0, 0), (3000, 0, 0), (0, 4000, 0)], float)  # no volume: from the mean
    assert default_deflection_mm(points(*(flat @ turn.T)), "mm") == pytest.approx(
        default_deflection_mm(points(*flat), "mm"), rel=1e-4)


@pytest.mark.external
def test_as1_keeps_its_tessellation_and_mesh_tolerance_changes_it():
    path = shared("as1", "as1-oc-214.stp")
    assert default_deflection_mm(path.read_bytes(), "mm") == 0.01  # a 355 mm model
    fine = load(path)
    coarse = load(path, mesh_tolerance=1.0)
    assert len(coarse) == len(fine) == 18
    tri = [sum(p.check.triangles for p in a.parts) for a in (fine, coarse)]
    assert tri[1] < tri[0]


# -- damaged files of every format: a fixed-seed fuzz slice -----------------------------

#: Cases per format: many for the readers in the process (milliseconds each), a few for the
#: native ones (a child process each).
FUZZ = {"stl": 40, "stl-ascii": 40, "obj": 40, "ply": 40, "ply-ascii": 40, "off": 40,
        "glb": 4, "gltf": 3, "3mf": 3, "3dxml": 4, "igs": 3, "step": 4}


def _outcome(path: Path) -> str:
    try:
        load(path, load_timeout=60)
    except InputError as exc:
        assert "\n" not in exc.message and exc.file, exc.message
        return "input-error"
    return "ok"


def test_fuzz_damaged_files_of_every_format(tmp_path, capfd):
    """Each damaged copy loads, or is an InputError with a one-line message: never another
    exception (exit 3), a crash of this process (139) or a hang; and nothing reaches stderr
    or stdout (numpy's cast warnings, trimesh's logged tracebacks, OpenCASCADE's output)."""
    step = SHARED / "as1" / "as1-oc-214.stp"
    samples = write_samples(tmp_path / "samples", step if step.is_file() else None)
    all_cases = cases(samples, FUZZ, tmp_path / "cases")
    assert len(all_cases) == sum(FUZZ[k] for k in samples)
    capfd.readouterr()
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        native = [c for c in all_cases if c[1].suffix.lower() in
                  {".glb", ".gltf", ".3mf", ".3dxml", ".igs", ".step"}]
        local = [c for c in all_cases if c not in native]
        outcomes = [_outcome(path) for _, path, _ in local]
        outcomes += _parallel([(_outcome, (path,)) for _, path, _ in native])
    out, err = capfd.readouterr()
    assert err == "" and out == "", (out[-2000:], err[-2000:])
    assert [str(w.message) for w in caught] == []
    counts: dict[str, dict[str, int]] = {}
    for (fmt, _, _), o in zip(local + native, outcomes):
        counts.setdefault(fmt, {}).setdefault(o, 0)
        counts[fmt][o] += 1
    print("fuzz outcomes:", counts)
    assert set(counts) == set(samples)


def test_fuzz_slice_through_the_cli(tmp_path):
    """A few damaged files through ``ndbg analyze``: exit 0 or 2, and on stderr either
    nothing or one error line (never 3, a signal, a timeout, a traceback or a warning)."""
    samples = write_samples(tmp_path / "samples")
    picked = cases({k: samples[k] for k in ("stl-ascii", "obj", "off", "ply-ascii", "3mf",
                                            "igs")},
                   {k: 1 for k in samples}, tmp_path / "cases", seed=7)
    results = _parallel([(_ndbg, ("analyze", path, "--no-cache", "--motion", "translation"))
                         for _, path, _ in picked])
    for (fmt, path, how), r in zip(picked, results):
        assert r.returncode in (0, 2), (fmt, how, r.returncode, r.stderr[-1500:])
        lines = _stderr_lines(r)
        assert (r.returncode == 0 and lines == []) or \
            (len(lines) == 1 and lines[0].startswith(f"ndbg: error: {path}")), \
            (fmt, how, r.stderr[-1500:])


# -- no warning leaks --------------------------------------------------------------------

def test_numpy_cast_warnings_do_not_leak(tmp_path):
    """Was: ``RuntimeWarning: invalid value encountered in cast`` on stderr for an OFF file
    whose face indices are not numbers."""
    path = tmp_path / "nan.off"
    path.write_text("OFF\n4 2 0\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n3 0 1 nan\n3 0 1 3\n")
    r = _ndbg("analyze", path, "--no-cache")
    assert "Warning" not in r.stderr and "Traceback" not in r.stderr, r.stderr
    assert r.returncode in (0, 2) and len(r.stderr.strip().splitlines()) <= 1, r.stderr


def test_loading_leaves_the_callers_warning_filters_numpy_and_logging_alone(tmp_path):
    path = tmp_path / "bad.stl"
    path.write_text("solid x\nfacet normal 0 0 nan\nouter loop\nvertex 0 0 0\nendloop\n")
    filters = list(warnings.filters)
    errs = np.geterr()
    handlers = list(logging.getLogger("trimesh").handlers)
    with pytest.raises(InputError):
        load(path)
    assert warnings.filters == filters and np.geterr() == errs
    assert logging.getLogger("trimesh").handlers == handlers


#: A STEP file with no shape in it (OpenCASCADE reads it and finds none).
EMPTY_STEP = """ISO-10303-21;
HEADER;
FILE_DESCRIPTION((''),'2;1');
FILE_NAME('empty.step','2026-01-01T00:00:00',(''),(''),'','','');
FILE_SCHEMA(('AUTOMOTIVE_DESIGN'));
ENDSEC;
DATA;
ENDSEC;
END-ISO-10303-21;
"""


def _program(*args: str, tmp_path: Path) -> subprocess.CompletedProcess:
    """``ndbg ARGS`` run by its entry point :func:`~ndbg_cli.cli.main.run` in a new
    interpreter; prints, as the process ends, whether cascadio was imported there and the
    garbage collector's thresholds."""
    code = ("import atexit, gc, sys; atexit.register(lambda: print("
            "sys.modules.get('cascadio', 'absent'), gc.get_threshold())); "
            f"sys.argv = ['ndbg', *{list(args)!r}]; "
            "from ndbg_cli.cli.main import run; run()")
    return subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          cwd=tmp_path, timeout=300)


def test_the_program_reads_step_in_its_reader_child(tmp_path):
    """``ndbg`` keeps OpenCASCADE out of its own process (``import trimesh`` would import it
    for trimesh's STEP loader), and its reader's child, a new interpreter, still reads STEP:
    here it finds no shape in the file, an input error (exit 2)."""
    step = tmp_path / "empty.step"
    step.write_text(EMPTY_STEP)
    got = _program("-q", "analyze", str(step), "--format", "json", "--out",
                   str(tmp_path / "r.json"), tmp_path=tmp_path)
    assert got.returncode == 2
    assert "OpenCASCADE found no shape in it" in got.stderr
    assert got.stdout.split()[0] == "None"  # blocked here: never imported
    assert got.stdout.split(maxsplit=1)[1].strip() == "(10000, 10, 10)"


def test_the_library_leaves_the_process_alone():
    """Neither ``import ndbg_cli`` nor the CLI's :func:`~ndbg_cli.cli.main.main` (what a
    library caller runs) blocks cascadio or changes the garbage collector's thresholds:
    only the program's entry point does (:func:`~ndbg_cli.cli.main.run`)."""
    code = ("import gc, sys; t = gc.get_threshold(); import ndbg_cli, trimesh; "
            "from ndbg_cli.cli.main import main\n"
            "try:\n    main(['--version'])\nexcept SystemExit:\n    pass\n"
            "print(sys.modules.get('cascadio') is not None, gc.get_threshold() == t)")
    got = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         cwd=ROOT, timeout=120)
    assert got.stdout.split()[-2:] == ["True", "True"], got.stderr


def test_a_real_step_product_through_the_program(tmp_path):
    """AS1 (a STEP file of 18 parts) through the program, OpenCASCADE out of its process:
    read by the reader's child, its report whole and its plan proven."""
    step = shared("as1", "as1-oc-214.stp")
    out = tmp_path / "r.json"
    got = _program("-q", "analyze", str(step), "--format", "json", "--no-cache", "--out",
                   str(out), tmp_path=tmp_path)
    assert got.returncode == 0, got.stderr
    assert got.stdout.split()[0] == "None"  # blocked here: never imported
    report = json.loads(out.read_text())
    assert len(report["assembly"]["parts"]) == 18 and report["plan"]["verified"]["value"]


def test_a_cad_file_read_in_the_process_of_the_program(tmp_path):
    """With OpenCASCADE kept out of the program's process, a caller that reads a STEP file
    in process (``isolate=False``) still gets OpenCASCADE's answer."""
    step = tmp_path / "empty.step"
    step.write_text(EMPTY_STEP)
    code = ("import sys; sys.modules['cascadio'] = None\n"
            "from ndbg_cli.io.loaders import load\n"
            "from ndbg_cli.core.errors import InputError\n"
            f"try:\n    load({str(step)!r}, isolate=False)\n"
            "except InputError as exc:\n    print(exc.message)")
    got = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         timeout=120)
    assert "OpenCASCADE found no shape in it" in got.stdout, got.stderr

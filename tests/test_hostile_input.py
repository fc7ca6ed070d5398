"""Hostile or odd input: YAML alias bombs, nesting past the recursion limit, file names that
are not UTF-8. Each is an input error (exit 2, one line) or, for names, a report written with
the name escaped, never an internal error or a traceback."""

from __future__ import annotations

import json
import os
import resource
import subprocess
import sys
from pathlib import Path

import pytest
import yaml

from helpers import box, run_cli, write_two_boxes

#: Nine anchors of nine aliases each: 9**9 values when expanded, 400 bytes of YAML.
BOMB = ["metadata:", "  a0: &a0 [lol, lol, lol, lol, lol, lol, lol, lol, lol]"] + [
    f"  a{i}: &a{i} [{', '.join([f'*a{i - 1}'] * 9)}]" for i in range(1, 9)]
#: The same with merge keys: every level merges the one below nine times.
MERGE_BOMB = ["metadata:", "  a0: &a0 {k0: 0, k1: 1, k2: 2, k3: 3, k4: 4, k5: 5, k6: 6}"] + [
    f"  a{i}: &a{i} {{<<: [{', '.join([f'*a{i - 1}'] * 9)}]}}" for i in range(1, 11)]


def _nest(n: int) -> str:
    return "[" * n + "]" * n


def _run_limited(*args: str) -> subprocess.CompletedProcess:
    """The CLI with its address space capped at 1 GB: a bomb that expands fails the run
    with a MemoryError (an internal error) instead of swapping the machine."""
    def cap():
        resource.setrlimit(resource.RLIMIT_AS, (1 << 30, 1 << 30))

    return subprocess.run([sys.executable, "-m", "ndbg_cli", *args], capture_output=True,
                          text=True, timeout=120, preexec_fn=cap)


def _one_line_input_error(r: subprocess.CompletedProcess, *fragments: str) -> None:
    assert r.returncode == 2, (r.returncode, r.stderr[-2000:])
    assert "Traceback" not in r.stderr and "internal error" not in r.stderr
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("ndbg: error: "), r.stderr[-2000:]
    for f in fragments:
        assert f in lines[0], lines[0]


# -- YAML aliases that expand too much ----------------------------------------------------

@pytest.mark.parametrize("bomb", [BOMB, MERGE_BOMB], ids=["aliases", "merge-keys"])
def test_alias_bomb_in_a_manifest_is_an_input_error(tmp_path, bomb):
    """Was: the line map, the finiteness check and the schema walked the 9**9 expanded
    values (1.3 GB, minutes). Now refused while composing, naming the anchor's line."""
    p = write_two_boxes(tmp_path, extra="\n".join(bomb) + "\n")
    r = _run_limited("analyze", str(p), "--no-cache")
    _one_line_input_error(r, "two.yaml:", "aliases expand to more than")


def test_alias_bomb_in_config_and_rules_files(tmp_path):
    p = write_two_boxes(tmp_path)
    cfg = tmp_path / "cfg.yaml"
    cfg.write_text("motion: all\nx:\n" + "\n".join(BOMB[1:]) + "\n")
    _one_line_input_error(_run_limited("analyze", str(p), "--config", str(cfg)),
                          "cfg.yaml", "aliases expand to more than")
    rules = tmp_path / "rules.yaml"
    rules.write_text("rules: {max_warnings: 1}\ndescription:\n" + "\n".join(BOMB[1:]) + "\n")
    _one_line_input_error(_run_limited("check", str(p), "--rules", str(rules)),
                          "rules.yaml:", "aliases expand to more than")


def test_recursive_alias_is_an_input_error(tmp_path):
    p = write_two_boxes(tmp_path, extra="metadata: &m {self: *m}\n")
    _one_line_input_error(run_cli("analyze", p), "two.yaml:9:", "refers to a node that "
                          "contains it")


def test_a_few_aliases_are_still_fine(tmp_path):
    from ndbg_cli.io.loaders import load

    p = write_two_boxes(tmp_path, extra="metadata: {r: &r [1, 2, 3], s: *r, t: *r}\n")
    assert load(p).metadata == {"r": [1, 2, 3], "s": [1, 2, 3], "t": [1, 2, 3]}


# -- nesting past the recursion limit -----------------------------------------------------

def test_deeply_nested_yaml_is_an_input_error(tmp_path):
    """Was: exit 3 (RecursionError in PyYAML's composer) for the manifest, the config and
    the rules file."""
    deep = _nest(100_000)
    p = write_two_boxes(tmp_path, extra=f"metadata: {{x: {deep}}}\n")
    _one_line_input_error(run_cli("analyze", p), "two.yaml:9:", "nested deeper than 100")
    ok = write_two_boxes(tmp_path / "ok")
    cfg = tmp_path / "cfg.yaml"
    cfg.write_text(f"motion: {deep}\n")
    _one_line_input_error(run_cli("analyze", ok, "--config", cfg), "cfg.yaml",
                          "nested deeper than 100")
    rules = tmp_path / "rules.yaml"
    rules.write_text(f"rules: {deep}\n")
    _one_line_input_error(run_cli("check", ok, "--rules", rules), "rules.yaml:1:",
                          "nested deeper than 100")


def test_nesting_at_the_limit_is_read(tmp_path):
    """100 levels (the root mapping, ``metadata``'s mapping, 98 lists) load; the readers
    that walk the data recursively (line map, finiteness, schema) stay within Python's
    recursion limit."""
    from ndbg_cli.io.loaders import load

    p = write_two_boxes(tmp_path, extra=f"metadata: {{x: {_nest(98)}}}\n")
    assert load(p).metadata["x"] == json.loads(_nest(98))


def test_aliases_cannot_nest_past_the_limit(tmp_path):
    """Each anchor 60 levels deep inside the next: 240 levels once expanded."""
    lines = ["metadata:", f"  a0: &a0 {_nest(60)}"] + [
        f"  a{i}: &a{i} {'[' * 60}*a{i - 1}{']' * 60}" for i in range(1, 4)]
    p = write_two_boxes(tmp_path, extra="\n".join(lines) + "\n")
    _one_line_input_error(run_cli("analyze", p), "once its aliases are expanded")


def test_deeply_nested_json_report_is_an_input_error(tmp_path):
    """Was: exit 3 (RecursionError from ``json``) for ``ndbg diff`` and ``ndbg check``."""
    deep = tmp_path / "deep.json"
    deep.write_text(_nest(100_000))
    _one_line_input_error(run_cli("diff", deep, deep), "deep.json: ", "nested too deeply")
    rules = tmp_path / "rules.yaml"
    rules.write_text("rules: {max_warnings: 1}\n")
    _one_line_input_error(run_cli("check", deep, "--rules", rules), "deep.json: ",
                          "nested too deeply")


# -- rules files read numbers as manifests do ---------------------------------------------

def test_rules_files_read_exponent_floats_as_manifests_do(tmp_path):
    """Was: yaml.safe_load (YAML 1.1) read ``1e1`` as the string '1e1' in a rules file,
    while manifests and configs read it as 10.0 (manifest.YamlLoader)."""
    from ndbg_cli.core.errors import InputError
    from ndbg_cli.report.rules import load_rules

    rules = tmp_path / "rules.yaml"
    rules.write_text("rules:\n  max_depth: 1e1\n")
    with pytest.raises(InputError, match=r"needs a non-negative integer, got 10\.0$"):
        load_rules(rules)
    rules.write_text("rules:\n  max_depth: 10\nassemblies:\n  1e3: {max_depth: 2}\n")
    assert load_rules(rules).assemblies[0][0] == str(1e3)


def test_rules_file_that_is_not_utf8_is_an_input_error(tmp_path):
    rules = tmp_path / "rules.yaml"
    rules.write_bytes(b"rules: {max_depth: 3}\n# caf\xe9\n")
    p = write_two_boxes(tmp_path)
    _one_line_input_error(run_cli("check", p, "--rules", rules), "rules.yaml: ",
                          "not UTF-8")


# -- file names that are not UTF-8 --------------------------------------------------------

def _run_bytes(*args, errors: str = "strict") -> subprocess.CompletedProcess:
    """The CLI with bytes out (to check they are UTF-8), its stdout and stderr UTF-8 with
    the ``errors`` handler Python would give them: ``strict`` (a UTF-8 locale such as
    en_US.UTF-8) or ``surrogateescape`` (the C locale, UTF-8 mode)."""
    env = {**os.environ, "PYTHONIOENCODING": f"utf-8:{errors}"}
    return subprocess.run([sys.executable, "-m", "ndbg_cli", *map(os.fsencode, args)],
                          capture_output=True, timeout=300, env=env)


@pytest.fixture
def latin1_batch(tmp_path) -> Path:
    """A batch folder holding ``tw\\xffo.yaml`` (a good manifest whose name has the byte
    0xff) and ``bad\\xff.yaml`` (an invalid one)."""
    src = tmp_path / "src"
    write_two_boxes(src)
    folder = os.fsencode(src)
    try:
        os.rename(folder + b"/two.yaml", folder + b"/tw\xffo.yaml")
    except OSError:
        pytest.skip("the file system refuses names that are not UTF-8")
    with open(folder + b"/bad\xff.yaml", "w") as fh:
        fh.write("parts: 5\n")
    return src


def _check_names(text: bytes) -> dict:
    doc = json.loads(text.decode("utf-8"))  # strict: the JSON text is UTF-8
    sources = sorted(identity_source(r) for r in doc["reports"])
    assert [s.rsplit("/", 1)[1] for s in sources] == ["bad\\xff.yaml", "tw\\xffo.yaml"]
    return doc


def identity_source(r: dict) -> str:
    from ndbg_cli.report.document import identity

    return identity(r)[1]


@pytest.mark.parametrize("errors", ["strict", "surrogateescape"])
def test_non_utf8_names_in_json_on_stdout(latin1_batch, errors):
    """Was: exit 3 (UnicodeEncodeError: surrogates not allowed) with a strict stdout, and
    the raw byte 0xff in the JSON (not UTF-8) with surrogateescape. Now the byte is
    written ``\\xff`` in the JSON string, the bad manifest is an error record, the other
    report completes."""
    r = _run_bytes("-q", "analyze", latin1_batch, "--format", "json", "--no-cache",
                   errors=errors)
    assert r.returncode == 2, r.stderr.decode(errors="replace")[-2000:]
    doc = _check_names(r.stdout)
    assert doc["summary"] == {"assemblies": 2, "ok": 1, "errors": 1}
    err = r.stderr.decode("utf-8")
    assert err.startswith("ndbg: error: ") and "bad\\xff.yaml:1: parts" in err
    assert "internal error" not in err
    lines = _run_bytes("-q", "analyze", latin1_batch, "--format", "jsonl", "--no-cache",
                       errors=errors).stdout.decode("utf-8")
    assert len([json.loads(line) for line in lines.splitlines()]) == 2


def test_non_utf8_names_in_out_dir_and_text(latin1_batch, tmp_path):
    """--out-dir: both reports and the index are written (UTF-8, ``\\xff``); text on
    stdout names the file ``tw\\xffo.yaml``."""
    out = tmp_path / "out"
    r = _run_bytes("-q", "analyze", latin1_batch, "--out-dir", out, "--no-cache")
    assert r.returncode == 2, r.stderr.decode(errors="replace")[-2000:]
    index = _check_names((out / "index.json").read_bytes())
    assert index["summary"]["errors"] == 1
    assert sorted(p.name for p in out.iterdir()) == ["bad_.json", "index.json", "two.json"]
    good = json.loads((out / "two.json").read_bytes().decode("utf-8"))
    assert good["assembly"]["source"].endswith("/tw\\xffo.yaml")
    text = _run_bytes("-q", "analyze", os.fsencode(latin1_batch) + b"/tw\xffo.yaml",
                      "--no-cache")
    assert text.returncode == 0, text.stderr.decode(errors="replace")[-2000:]
    assert "tw\\xffo.yaml)" in text.stdout.decode("utf-8").splitlines()[0]


def test_non_utf8_mesh_file_names(tmp_path):
    """A folder of meshes, one named ``a\\xff.stl``: was exit 3 (trimesh encodes the body
    name it takes from the file name to hash its scene graph); now part ``a\\xff``."""
    folder = os.fsencode(tmp_path)
    box((0, 0, 0), (1, 1, 1)).export(tmp_path / "b.stl")
    try:
        os.rename(folder + b"/b.stl", folder + b"/a\xff.stl")
    except OSError:
        pytest.skip("the file system refuses names that are not UTF-8")
    box((0, 0, 1), (1, 1, 2)).export(tmp_path / "b.stl")
    r = _run_bytes("-q", "analyze", tmp_path, "--format", "json", "--no-cache")
    assert r.returncode == 0, r.stderr.decode(errors="replace")[-2000:]
    doc = json.loads(r.stdout.decode("utf-8"))
    assert [p["id"] for p in doc["assembly"]["parts"]] == ["a\\xff", "b"]


def test_config_file_that_is_not_utf8_is_an_input_error(tmp_path):
    """Was: exit 3 (UnicodeDecodeError escaped analysis.read_config)."""
    cfg = tmp_path / "cfg.yaml"
    cfg.write_bytes(b"motion: all\n# caf\xe9\n")
    p = write_two_boxes(tmp_path)
    _one_line_input_error(run_cli("analyze", p, "--config", cfg), "cfg.yaml: ", "not UTF-8")


@pytest.mark.parametrize("brk", ["\n", "\r", "\x85", "\u2028"])
def test_an_error_quoting_a_line_break_stays_one_line(tmp_path, brk):
    """Found by the fuzzing campaign: a part id holding a line break (a unicode one, e.g.
    U+2028, splits a line for ``str.splitlines`` and for many log viewers) split the one-line
    error that quotes it."""
    man = tmp_path / "odd.yaml"
    (tmp_path / "a.stl").write_text("solid a\nendsolid a\n")
    part = {"id": f"a{brk}b", "mesh": "a.stl"}
    man.write_text(yaml.safe_dump({"name": "odd", "parts": [part]},
                                  allow_unicode=True), encoding="utf-8")
    r = run_cli("analyze", man, "--no-cache")  # the empty mesh is an error quoting the id
    _one_line_input_error(r, "part 'a")  # (YAML reads U+0085 as a space)

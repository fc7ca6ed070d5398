"""The house rules of ARCHITECTURE.md, checked: the stages' import contracts (import-linter,
as `make lint` runs them), no private name imported across subpackages, and a CLI start that
imports no numerical library."""

from __future__ import annotations

import ast
import importlib.util
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
PACKAGE = ROOT / "ndbg_cli"
LINT_IMPORTS = Path(sys.executable).parent / "lint-imports"


def _lint_imports(root: Path) -> subprocess.CompletedProcess:
    """Run import-linter on the package below ``root`` with ``root``'s pyproject.toml."""
    return subprocess.run([str(LINT_IMPORTS), "--no-cache", "--config", "pyproject.toml"],
                          cwd=root, env={"PYTHONPATH": str(root), "PATH": "/usr/bin:/bin"},
                          capture_output=True, text=True, timeout=300)


@pytest.mark.skipif(not LINT_IMPORTS.exists(), reason="import-linter is not installed")
def test_the_import_contracts_hold_and_fail_on_an_upward_import(tmp_path):
    ok = _lint_imports(ROOT)
    assert ok.returncode == 0, ok.stdout + ok.stderr
    assert "0 broken" in ok.stdout
    # a lower stage (core) importing a higher one (pipeline) must break the layers contract
    shutil.copytree(PACKAGE, tmp_path / "ndbg_cli", ignore=shutil.ignore_patterns("__pycache__"))
    shutil.copy(ROOT / "pyproject.toml", tmp_path / "pyproject.toml")
    errors = tmp_path / "ndbg_cli" / "core" / "errors.py"
    errors.write_text(errors.read_text() + "\n\ndef _late():\n    from ..pipeline import stages\n")
    bad = _lint_imports(tmp_path)
    assert bad.returncode != 0
    assert "Stages: each imports only the stages below it BROKEN" in bad.stdout
    assert "ndbg_cli.core.errors -> ndbg_cli.pipeline.stages" in bad.stdout


def _modules() -> dict[str, Path]:
    out = {}
    for path in sorted(PACKAGE.rglob("*.py")):
        parts = path.relative_to(ROOT).with_suffix("").parts
        name = ".".join(parts[:-1] if parts[-1] == "__init__" else parts)
        out[name] = path
    return out


def _subpackage(module: str) -> str:
    """The stage a module belongs to: ``ndbg_cli.X`` (``ndbg_cli.ndbg.X`` for the families)."""
    parts = module.split(".")
    return ".".join(parts[:3] if parts[1:2] == ["ndbg"] and len(parts) > 3 else parts[:2])


def test_no_private_name_is_imported_across_subpackages():
    modules = _modules()
    crossings = []
    for name, path in modules.items():
        package = name if path.name == "__init__.py" else name.rpartition(".")[0]
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if not isinstance(node, ast.ImportFrom) or not node.level:
                continue
            target = importlib.util.resolve_name("." * node.level + (node.module or ""), package)
            for alias in node.names:
                full = f"{target}.{alias.name}"
                where = full if full in modules else target
                if _subpackage(where) == _subpackage(name):
                    continue
                # the package's own ``_version`` is every stage's to read
                private = [p for p in full.removeprefix("ndbg_cli.").split(".")
                           if p.startswith("_") and not p.startswith("__") and p != "_version"]
                if private:
                    crossings.append(f"{name}:{node.lineno} imports {full}")
    assert crossings == []


def test_the_cli_starts_without_numerical_libraries():
    """``ndbg --help``, ``--version`` and ``schema`` must start fast: the CLI's modules import
    no stage, so neither numpy nor trimesh nor numba is loaded until a command runs."""
    code = ("import sys, ndbg_cli.cli.main\n"
            "heavy = sorted(m for m in ('numpy', 'trimesh', 'numba', 'scipy', 'shapely', 'fcl')"
            " if m in sys.modules)\n"
            "print(','.join(heavy))\n")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True).stdout.strip()
    assert out == ""


def test_the_docstring_examples_run(monkeypatch):
    """Every ``>>>`` example in the package's docstrings runs and prints what it says (from
    the repository root, where the examples' assembly paths are)."""
    import doctest
    import importlib

    monkeypatch.chdir(ROOT)
    ran = 0
    for name, path in _modules().items():
        if ">>>" not in path.read_text(encoding="utf-8"):
            continue
        result = doctest.testmod(importlib.import_module(name), optionflags=doctest.ELLIPSIS)
        assert result.failed == 0, name
        ran += result.attempted
    assert ran > 0


def test_the_library_stages_give_the_cli_report(tmp_path):
    """A notebook calling the stage functions gets the NDBG sections, classes and plan the
    CLI reports for the same options (the CLI composes the same functions)."""
    import json

    import ndbg_cli
    from ndbg_cli.core.constants import FAMILIES, INFINITE
    from ndbg_cli.report.document import clean

    from helpers import run_cli

    path = ROOT / "assemblies" / "hover.yaml"
    out = run_cli("analyze", str(path), "--format", "json", "--no-cache", "--detail", "full")
    assert out.returncode == 0, out.stderr
    report = json.loads(out.stdout)
    asm = ndbg_cli.load(path)
    contacts = ndbg_cli.find_contacts(asm)
    families, inf = {}, None
    for name in FAMILIES:
        families[name] = ndbg_cli.build_ndbg(asm, name, contacts, infinitesimal=inf)
        inf = families[name].ndbg if inf is None else inf
    assert {n: clean(f.section) for n, f in families.items()} == report["ndbg"]
    ndbgs = {n: f.ndbg for n, f in families.items() if f.usable}
    measures = ndbg_cli.measure(asm, contacts, ndbgs)
    assert clean(measures.classes) == report["classes"]
    plan = clean(ndbg_cli.plan_assembly(asm, contacts, ndbgs, measures))
    assert plan == report["plan"] and plan["family"] == INFINITE

"""The package's layers and the absence of import cycles (pyproject.toml [tool.importlinter]), and that the
contracts really fail when an import breaks them."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
PACKAGE = ROOT / "src" / "hydrohil"


def lint_imports(cwd: Path, pythonpath: Path) -> subprocess.CompletedProcess:
    """Run import-linter's command line on the package found first on ``pythonpath``, with the project's
    contracts (no cache: the graph is built from the files as they are)."""
    env = {**os.environ, "PYTHONPATH": str(pythonpath)}
    lint = Path(sys.executable).parent / "lint-imports"
    return subprocess.run([str(lint), "--config", str(ROOT / "pyproject.toml"), "--no-cache"], cwd=cwd, env=env,
                          capture_output=True, text=True, timeout=300)


def test_the_package_keeps_its_layers_and_has_no_import_cycle():
    r = lint_imports(ROOT, ROOT / "src")
    assert r.returncode == 0, r.stdout + r.stderr
    assert "2 kept, 0 broken" in r.stdout


@pytest.fixture
def package_copy(tmp_path) -> Path:
    """The package's Python files copied to tmp_path/src/hydrohil (what the linter reads)."""
    dest = tmp_path / "src" / "hydrohil"
    shutil.copytree(PACKAGE, dest, ignore=lambda d, names: [n for n in names if not (
        n.endswith(".py") or (Path(d) / n).is_dir()) or n == "__pycache__"])
    return tmp_path / "src"


def _append(path: Path, text: str) -> None:
    path.write_text(path.read_text() + "\n\n" + text + "\n")


BREAKS = {   # an import added inside a function of a copy of the package -> the contract it breaks, what it names
    "upward": ("models/layout.py", "from hydrohil.hil.run import run_hil\n    return run_hil", "hydrohil layers",
               ("hydrohil.models.layout -> hydrohil.hil.run",)),
    "cycle": ("sequences/report.py", "from hydrohil.sequences.runner import run_suite\n    return run_suite",
              "no import cycle", ("hydrohil.sequences", ".runner -> .report")),
}


@pytest.mark.parametrize("case", BREAKS)
def test_an_import_that_breaks_a_contract_is_found(package_copy, case):
    """models may not import hil, even inside a function (the imports that hid the old cycles); a cycle
    between two modules of a package (sequences.runner imports report; report -> runner closes it) is found."""
    path, code, contract, names = BREAKS[case]
    _append(package_copy / "hydrohil" / path, f"def _added():\n    {code}")
    r = lint_imports(package_copy.parent, package_copy)
    assert r.returncode == 1, r.stdout + r.stderr
    assert contract in r.stdout and "BROKEN" in r.stdout
    for name in names:
        assert name in r.stdout, name

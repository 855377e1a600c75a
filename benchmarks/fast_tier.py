"""The fast tier of the tests: its wall time and which modules it exercises.

    python benchmarks/fast_tier.py [--no-coverage]

Runs ``python -m pytest -q -m "not slow"`` under coverage.py (child processes too: the plant and controller
processes, the C plant's Python side), then, for every Python module of the package, counts the functions
whose body ran at least once. A module "touched" by the tier has at least one function that ran (a module
without functions: at least one executed line). Prints the wall time of the run, every untouched module (the
list should be empty), and the share of functions run per package. The timing is that of a run under
coverage (a few % slower); ``--no-coverage`` gives the plain figure for the README.
"""

from __future__ import annotations

import argparse
import ast
import os
import subprocess
import sys
import tempfile
import time
from collections import defaultdict
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
PACKAGE = ROOT / "src" / "hydrohil"


def function_bodies(path: Path) -> list[tuple[str, set[int]]]:
    """(qualified name, line numbers of its body) for every function and method of a module."""
    tree = ast.parse(path.read_text())
    out = []

    def visit(node, prefix):
        for child in ast.iter_child_nodes(node):
            if isinstance(child, (ast.FunctionDef, ast.AsyncFunctionDef)):
                lines = set()
                for stmt in child.body:
                    lines.update(range(stmt.lineno, (stmt.end_lineno or stmt.lineno) + 1))
                out.append((prefix + child.name, lines))
                visit(child, prefix + child.name + ".")
            elif isinstance(child, ast.ClassDef):
                visit(child, prefix + child.name + ".")
    visit(tree, "")
    return out


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--no-coverage", action="store_true", help="only time the tier")
    args = ap.parse_args()
    cmd = [sys.executable, "-m", "pytest", "-q", "-m", "not slow", "-p", "no:cacheprovider"]
    if args.no_coverage:
        t0 = time.monotonic()
        rc = subprocess.call(cmd, cwd=ROOT)
        print(f"fast tier: exit {rc}, {time.monotonic() - t0:.0f} s wall")
        return rc
    import coverage
    with tempfile.TemporaryDirectory() as tmp:
        rc_file = Path(tmp) / "coveragerc"
        rc_file.write_text(f"[run]\nsource = hydrohil\nparallel = true\npatch = subprocess\n"
                           f"data_file = {tmp}/.coverage\n")
        env = {**os.environ, "COVERAGE_RCFILE": str(rc_file)}
        t0 = time.monotonic()
        rc = subprocess.call([sys.executable, "-m", "coverage", "run", "--rcfile", str(rc_file), *cmd[1:]],
                             cwd=ROOT, env=env)
        wall = time.monotonic() - t0
        cov = coverage.Coverage(config_file=str(rc_file), data_file=f"{tmp}/.coverage")
        cov.combine()
        data = cov.get_data()
        executed = {Path(f).resolve(): set(data.lines(f) or ()) for f in data.measured_files()}
    untouched, share = [], defaultdict(lambda: [0, 0])
    for path in sorted(PACKAGE.rglob("*.py")):
        rel = path.relative_to(PACKAGE.parent)
        mod = ".".join(rel.with_suffix("").parts)
        ran = set()
        for p, lines in executed.items():        # an installed copy or the source tree
            if p.parts[-len(rel.parts):] == rel.parts:
                ran |= lines
        funcs = function_bodies(path)
        n_run = sum(1 for _, body in funcs if body & ran)
        pkg = ".".join(mod.split(".")[:2])
        share[pkg][0] += n_run
        share[pkg][1] += len(funcs)
        if (funcs and n_run == 0) or (not funcs and not ran and path.read_text().strip()):
            untouched.append(mod)
    print(f"fast tier: exit {rc}, {wall:.0f} s wall (under coverage)")
    for pkg, (a, b) in sorted(share.items()):
        if b:
            print(f"  {pkg:32s} functions run {a:4d} / {b:4d}  ({100 * a / b:3.0f} %)")
    print("modules the fast tier does not touch:", ", ".join(untouched) if untouched else "none")
    return rc or (1 if untouched else 0)


if __name__ == "__main__":
    sys.exit(main())

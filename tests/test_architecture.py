"""The package's shape: layers import only downwards (the contract in pyproject.toml), no module
imports another that imports it back, and no underscore name crosses a module boundary."""

from __future__ import annotations

import ast
import shutil
import subprocess
import sys

import pytest

from conftest import ROOT, need, need_module

PACKAGE = ROOT / "src" / "tamp_os"


def module_name(path) -> str:
    parts = list(path.relative_to(PACKAGE.parent).with_suffix("").parts)
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


@pytest.mark.timeout(120)
def test_layers_contract_is_kept():
    lint = shutil.which("lint-imports", path=str(ROOT / ".venv" / "bin")) or shutil.which("lint-imports")
    need(lint is not None, "import-linter (pip install import-linter)")
    done = subprocess.run([lint, str(ROOT / "pyproject.toml")], cwd=ROOT, capture_output=True, text=True,
                          timeout=110)
    assert done.returncode == 0, done.stdout[-3000:] + done.stderr[-2000:]
    assert "1 kept, 0 broken" in done.stdout


@pytest.mark.timeout(120)
def test_no_import_circles():
    grimp = need_module("grimp")
    nx = need_module("networkx")
    sys.path.insert(0, str(PACKAGE.parent))
    graph = grimp.build_graph("tamp_os")  # module-level and function-level imports alike
    g = nx.DiGraph((m, d) for m in graph.modules for d in graph.find_modules_directly_imported_by(m))
    circles = [sorted(c) for c in nx.strongly_connected_components(g) if len(c) > 1]
    assert not circles, circles


def private_imports(path) -> list[str]:
    """`from X import _name` where X is another module of the package (relative or absolute)."""
    found = []
    here = module_name(path).split(".")
    package = here if path.name == "__init__.py" else here[:-1]
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if not isinstance(node, ast.ImportFrom):
            continue
        if node.level:
            source = ".".join(package[: len(package) - node.level + 1] + ([node.module] if node.module else []))
        else:
            source = node.module or ""
        if not source.startswith("tamp_os"):
            continue
        for alias in node.names:
            if alias.name.startswith("_") and not alias.name.startswith("__"):
                found.append(f"{module_name(path)}:{node.lineno} imports {alias.name} from {source}")
    return found


def test_no_private_name_crosses_a_module():
    found = [f for path in sorted(PACKAGE.rglob("*.py")) for f in private_imports(path)]
    assert not found, "\n".join(found)


def test_the_top_level_shows_the_layers():
    """At most a handful of foundation modules beside the stage folders."""
    modules = sorted(p.stem for p in PACKAGE.glob("*.py") if p.stem != "__init__")
    assert len(modules) <= 8, modules
    folders = {p.name for p in PACKAGE.iterdir() if (p / "__init__.py").is_file()}
    assert {"read", "clean", "relief", "mesh", "tactile", "export", "printing", "lithograph", "cli", "gui"} <= folders


@pytest.mark.timeout(120)
def test_ruff_finds_nothing():
    ruff = shutil.which("ruff", path=str(ROOT / ".venv" / "bin")) or shutil.which("ruff")
    need(ruff is not None, "ruff (pip install ruff)")
    done = subprocess.run([ruff, "check", "--no-cache", "src", "tests", "benchmarks", "scripts"], cwd=ROOT,
                          capture_output=True, text=True, timeout=110)
    assert done.returncode == 0, done.stdout[-4000:]


MAX_POSITIONAL = 3  # beyond these, a public function's parameters are keyword-only (as scikit-image's are)
MAX_FUNCTION_LINES = 60


def public_functions(tree):
    """(function, is a method) for the module's public functions and its public classes' methods."""
    for node in tree.body:
        if isinstance(node, ast.FunctionDef) and not node.name.startswith("_"):
            yield node, False
        if isinstance(node, ast.ClassDef) and not node.name.startswith("_"):
            yield from ((f, True) for f in node.body if isinstance(f, ast.FunctionDef) and not f.name.startswith("_"))


def test_public_functions_take_options_by_keyword():
    crowded = []
    for path in sorted(PACKAGE.rglob("*.py")):
        for f, is_method in public_functions(ast.parse(path.read_text(encoding="utf-8"))):
            names = [a.arg for a in f.args.posonlyargs + f.args.args]
            if is_method and names[:1] in (["self"], ["cls"]):
                names = names[1:]
            if len(names) > MAX_POSITIONAL:
                crowded.append(f"{module_name(path)}.{f.name}({', '.join(names)})")
    assert not crowded, "keyword-only (a `*`) beyond the first three parameters:\n" + "\n".join(crowded)


def code_lines(node) -> int:
    """A function's lines without its docstring (a numpydoc docstring is documentation, not length)."""
    body = node.body
    if body and isinstance(body[0], ast.Expr) and isinstance(getattr(body[0], "value", None), ast.Constant) and isinstance(body[0].value.value, str):
        return node.end_lineno - node.lineno + 1 - (body[0].end_lineno - body[0].lineno + 1)
    return node.end_lineno - node.lineno + 1


def test_functions_are_short():
    long = []
    for path in sorted(PACKAGE.rglob("*.py")):
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
                lines = code_lines(node)
                if lines > MAX_FUNCTION_LINES:
                    long.append(f"{module_name(path)}.{node.name}: {lines} lines")
    assert not long, f"functions over {MAX_FUNCTION_LINES} lines (docstrings aside):\n" + "\n".join(long)

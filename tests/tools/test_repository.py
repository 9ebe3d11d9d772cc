"""The repository's own rules: it stands alone, its modules import without cycles, and the safety
invariants in docs/DESIGN.md name tests that exist."""

import ast
import re
import subprocess
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
PACKAGES = ("shared", "device", "desktop", "tools")


def _tracked_files():
    out = subprocess.run(["git", "ls-files"], cwd=ROOT, capture_output=True, text=True, check=True).stdout
    return [ROOT / line for line in out.splitlines()]


def test_no_file_cites_material_outside_the_repository():
    # the reasons behind the code live in docs/ (DESIGN.md), not in folders beside the checkout
    pattern = re.compile(r"\.\./shared|design[ -]notes?\b|/work/shared")
    offenders = []
    for path in _tracked_files():
        if path.suffix in (".png", ".gz", ".eng", ".bin", ".log") or not path.is_file():
            continue
        try:
            text = path.read_text(encoding="utf-8")
        except UnicodeDecodeError:
            continue
        for n, line in enumerate(text.splitlines(), 1):
            if pattern.search(line) and path != Path(__file__).resolve():
                offenders.append(f"{path.relative_to(ROOT)}:{n}: {line.strip()}")
    assert not offenders, "\n".join(offenders)


def _module_name(path):
    rel = path.relative_to(ROOT).with_suffix("")
    parts = rel.parts[:-1] if rel.name == "__init__" else rel.parts
    return ".".join(parts)


def _imports(path, name):
    """Every project module that ``path`` imports, at module level or inside functions."""
    tree = ast.parse(path.read_text(encoding="utf-8"))
    package = name if path.name == "__init__.py" else name.rpartition(".")[0]
    found = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            found.update(alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")
                base = base[: len(base) - node.level + 1]
                mod = ".".join(base + ([node.module] if node.module else []))
            else:
                mod = node.module or ""
            found.add(mod)
            found.update(f"{mod}.{alias.name}" for alias in node.names)
    return {m for m in found if m.split(".")[0] in PACKAGES}


def test_no_import_cycle_among_project_modules():
    modules = {}
    for path in _tracked_files():
        if path.suffix == ".py" and path.parts[len(ROOT.parts)] in PACKAGES and path.is_file():
            modules[_module_name(path)] = path
    graph = {name: {m for m in _imports(path, name) if m in modules and m != name}
             for name, path in modules.items()}
    # a package's __init__ importing its own submodules is not a cycle between jobs
    for name in graph:
        graph[name] = {m for m in graph[name] if not m.startswith(name + ".")}
    index, low, stack, on_stack, cycles = {}, {}, [], set(), []

    def strongconnect(v):  # Tarjan's algorithm
        index[v] = low[v] = len(index)
        stack.append(v)
        on_stack.add(v)
        for w in graph[v]:
            if w not in index:
                strongconnect(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            component = []
            while True:
                w = stack.pop()
                on_stack.discard(w)
                component.append(w)
                if w == v:
                    break
            if len(component) > 1:
                cycles.append(sorted(component))

    for v in sorted(graph):
        if v not in index:
            strongconnect(v)
    assert not cycles, cycles


def test_design_invariants_name_tests_that_exist():
    text = (ROOT / "docs" / "DESIGN.md").read_text(encoding="utf-8")
    refs = re.findall(r"(tests/[\w/]+\.py)::(\w+)", text)
    assert len(refs) >= 5
    for file, test in refs:
        path = ROOT / file
        assert path.is_file(), file
        assert re.search(rf"^\s*def {test}\(", path.read_text(encoding="utf-8"), re.M), f"{file}::{test}"

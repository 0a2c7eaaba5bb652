"""The package's shape (issue 30): no module imports one that imports it back, and no module grows past 500 lines.

Every import counts, at the top of a module or inside a function: a function-level import is still a
dependency, only a later one, and a circle through it is a circle in the design.
"""
import ast
import re
from pathlib import Path

import networkx as nx

PACKAGE = Path(__file__).resolve().parent.parent / "autorig"
README = PACKAGE.parent / "README.md"
MAX_LINES = 500


def _module_name(path: Path) -> str:
    parts = path.relative_to(PACKAGE.parent).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def import_graph() -> nx.DiGraph:
    """Directed graph of autorig's modules: an edge a -> b where module a imports module b (a package's
    ``__init__`` is the package's name)."""
    files = {_module_name(path): path for path in PACKAGE.rglob("*.py")}
    graph = nx.DiGraph()
    graph.add_nodes_from(files)
    for module, path in files.items():
        package = module if path.name == "__init__.py" else module.rpartition(".")[0]
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.Import):
                targets = [alias.name for alias in node.names]
            elif isinstance(node, ast.ImportFrom):
                base = node.module or ""
                if node.level:
                    anchor = package.split(".")[:len(package.split(".")) - (node.level - 1)]
                    base = ".".join(anchor + ([base] if base else []))
                # "from . import x" names a submodule when there is one, else a name in the package itself.
                targets = [f"{base}.{alias.name}" if f"{base}.{alias.name}" in files else base
                           for alias in node.names]
            else:
                continue
            graph.add_edges_from((module, target) for target in targets if target in files and target != module)
    return graph


def test_the_import_graph_is_found():
    graph = import_graph()
    assert ("autorig.pipeline", "autorig.result") in graph.edges
    # Function-level imports count as edges too.
    assert ("autorig.pipeline", "autorig.attach") in graph.edges


def test_no_import_circles():
    cycles = sorted(" -> ".join(cycle + cycle[:1]) for cycle in nx.simple_cycles(import_graph()))
    assert not cycles, f"{len(cycles)} import circles, e.g.:\n" + "\n".join(cycles[:20])


def test_no_module_over_500_lines():
    long = {str(path.relative_to(PACKAGE.parent)): n for path in PACKAGE.rglob("*.py")
            if (n := len(path.read_text(encoding="utf-8").splitlines())) > MAX_LINES}
    assert not long, f"modules over {MAX_LINES} lines: {long}"


def test_the_readme_map_names_every_package_and_module():
    """The README's "How it is built" lists each of autorig's packages (``name/``) and modules (``name.py``) once."""
    section = README.read_text(encoding="utf-8").split("## How it is built", 1)[1].split("\n## ", 1)[0]
    listed = re.findall(r"^([a-z_]+(?:/|\.py)) ", section, flags=re.M)
    present = sorted(f"{p.name}/" if p.is_dir() else p.name for p in PACKAGE.iterdir()
                     if (p / "__init__.py").exists() or (p.suffix == ".py" and p.name != "__init__.py"))
    assert len(listed) == len(set(listed))
    assert sorted(listed) == present

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
    assert ("autorig.pipeline", "autorig.weights.attach") in graph.edges


def test_no_import_circles():
    cycles = sorted(" -> ".join(cycle + cycle[:1]) for cycle in nx.simple_cycles(import_graph()))
    assert not cycles, f"{len(cycles)} import circles, e.g.:\n" + "\n".join(cycles[:20])


def test_no_module_over_500_lines():
    long = {str(path.relative_to(PACKAGE.parent)): n for path in PACKAGE.rglob("*.py")
            if (n := len(path.read_text(encoding="utf-8").splitlines())) > MAX_LINES}
    assert not long, f"modules over {MAX_LINES} lines: {long}"


MAX_TOP_LEVEL_MODULES = 12


def _listed(path: Path) -> list[str]:
    """A package's packages (``name/``) and modules (``name.py``), without ``__init__.py`` and ``__main__.py``."""
    return sorted(f"{p.name}/" if p.is_dir() else p.name for p in path.iterdir()
                  if (p / "__init__.py").exists() or (p.suffix == ".py" and not p.name.startswith("__")))


def test_the_top_level_shows_the_stages():
    """The package's top level holds the spine and what every stage shares, at most 12 modules besides its
    packages: the stages themselves are folders."""
    modules = [name for name in _listed(PACKAGE) if name.endswith(".py")]
    assert "pipeline.py" in modules
    assert len(modules) <= MAX_TOP_LEVEL_MODULES, f"{len(modules)} top-level modules: {modules}"
    for stage in ("input/", "discretize/", "embed/", "readoff/", "weights/", "exchange/"):
        assert stage in _listed(PACKAGE)


def test_the_readme_map_names_every_package_and_module():
    """The README's "How it is built" lists each of autorig's packages (``name/``) and top-level modules
    (``name.py``) once, and under each package, indented by two spaces, each of that package's modules once."""
    section = README.read_text(encoding="utf-8").split("## How it is built", 1)[1].split("\n## ", 1)[0]
    top = re.findall(r"^([a-z_]+(?:/|\.py)) ", section, flags=re.M)
    assert len(top) == len(set(top))
    assert sorted(top) == _listed(PACKAGE)
    listed: dict[str, list[str]] = {}
    package = None
    for line in section.splitlines():
        if match := re.match(r"^([a-z_]+/) ", line):
            package = listed.setdefault(match[1], [])
        elif match := re.match(r"^  ([a-z_]+\.py) ", line):
            assert package is not None, line
            package.append(match[1])
        elif re.match(r"^[a-z_]+\.py ", line):
            package = None
    for name, modules in listed.items():
        assert len(modules) == len(set(modules)), name
        assert sorted(modules) == _listed(PACKAGE / name.rstrip("/")), name


def test_no_package_or_module_hides_the_public_api():
    """A subpackage or module named like a name of the public API (``autorig.skin``, ``autorig.rig``, ...) would
    replace it as ``autorig``'s attribute as soon as anything imports it."""
    import autorig
    import autorig.pipeline
    import autorig.weights.attach  # noqa: F401  (sets autorig.weights, as any import of a subpackage does)
    clashes = [name for name in autorig.__all__ if (PACKAGE / name).is_dir() or (PACKAGE / f"{name}.py").exists()]
    assert not clashes
    assert autorig.skin is autorig.pipeline.skin and autorig.rig is autorig.pipeline.rig

"""The layers of the house, kept by its import graph (docs/architecture.md, "Layers").

The graph is grimp's: every ``import`` statement of a module, those inside functions included.

1. no module of spfem_core, workflows, verification or benchmarks is part of an import cycle;
2. between the packages only the allowed arrows: workflows -> spfem_core, verification -> both,
   benchmarks -> all three (never back); within workflows, no cycle between its rooms (a module
   directly in it, or a sub-package), a room's declarations counted apart from its running code
   (the table below, the code that runs it above);
3. the study file's declarations (``workflows.study`` and all it imports) reach no code that runs:
   only the fields kit, the tables of the kinds' rooms and the study's own modules;
4. no file edits ``sys.path`` (a process imports what its working directory and PYTHONPATH give);
5. each module of spfem_core and workflows imports as the first one (a loop through a package's
   ``__init__``, which the graph does not draw, shows only for some first imports).

``python tests/test_import_graph.py`` (or ``pytest -s``) prints the arrows between packages, between
their sub-packages (a module directly in a package counts as one), and between the rooms of
workflows with their declarations apart.
"""

from __future__ import annotations

import ast
import fnmatch
import subprocess
import sys
from pathlib import Path

import grimp

REPO = Path(__file__).resolve().parents[1]
PACKAGES = ("spfem_core", "workflows", "verification", "benchmarks")
ALLOWED_PACKAGE_ARROWS = {
    ("workflows", "spfem_core"),
    ("verification", "spfem_core"), ("verification", "workflows"),
    ("benchmarks", "spfem_core"), ("benchmarks", "workflows"), ("benchmarks", "verification"),
}
STUDY_READER = "workflows.study"
DECLARATIONS = (
    "workflows.fields", "workflows.box", "workflows.engineering_units",  # the kit a table is made of
    "workflows.distributions", "workflows.random_field.correlation",  # the kinds of random value a table names
    "workflows.probabilistic.kinds",  # the methods and computations [probabilistic] names
    "workflows.study", "workflows.study.*",  # the study's own tables, its reading and reference
    "workflows.materials", "workflows.materials.*", "workflows.loads", "workflows.loads.*",  # a module per kind
    "workflows.stages", "workflows.stages.*",  # a module per stage kind (not its runner: RUNNERS)
    "workflows.*.table",  # a room's declaration beside the code that runs it: water, seepage, random_field, ...
    "workflows.collapse.experiment", "workflows.collapse.kinds",  # the reference column, the kinds of collapse
    # what a stage kind measures and draws of its own result, imported inside the method that needs it
    # (scipy, matplotlib); they import nothing of the study's
    "workflows.runout.*", "workflows.collapse.metrics", "workflows.output.variables", "workflows.output.figures",
)
"""What the study reader may import (``fnmatch`` patterns of module names within workflows)."""
RUNNERS = ("workflows.stages.running",)
"""Code that runs, in a room whose other modules are declarations."""


def import_graph() -> grimp.ImportGraph:
    return grimp.build_graph(*PACKAGES, cache_dir=None)


def cycles(graph: grimp.ImportGraph) -> list[list[str]]:
    """The strongly connected components of more than one module (Tarjan), each sorted."""
    index, low, stack, on_stack, found = {}, {}, [], set(), []

    def visit(module: str) -> None:
        index[module] = low[module] = len(index)
        stack.append(module)
        on_stack.add(module)
        for imported in sorted(graph.find_modules_directly_imported_by(module)):
            if imported not in index:
                visit(imported)
                low[module] = min(low[module], low[imported])
            elif imported in on_stack:
                low[module] = min(low[module], index[imported])
        if low[module] == index[module]:
            component = []
            while True:
                member = stack.pop()
                on_stack.discard(member)
                component.append(member)
                if member == module:
                    break
            if len(component) > 1:
                found.append(sorted(component))

    sys.setrecursionlimit(max(sys.getrecursionlimit(), 10 * len(graph.modules)))
    for module in sorted(graph.modules):
        if module not in index:
            visit(module)
    return found


def arrows(graph: grimp.ImportGraph, depth: int) -> list[tuple[str, str]]:
    """(importer, imported) between the modules' names cut to ``depth`` parts (1: the packages; 2: their
    sub-packages, a module directly in a package counting as one), each once."""
    found = set()
    for module in graph.modules:
        for imported in graph.find_modules_directly_imported_by(module):
            a, b = ".".join(module.split(".")[:depth]), ".".join(imported.split(".")[:depth])
            if a != b:
                found.add((a, b))
    return sorted(found)


def test_no_module_is_part_of_an_import_cycle():
    found = cycles(import_graph())
    assert found == [], "import cycles (imports inside functions included):\n" + "\n".join(map(str, found))


def test_packages_import_one_way():
    found = arrows(import_graph(), 1)
    print("\npackage arrows:", ", ".join(f"{a} -> {b}" for a, b in found))
    assert set(found) <= ALLOWED_PACKAGE_ARROWS, sorted(set(found) - ALLOWED_PACKAGE_ARROWS)


def declaration(module: str) -> bool:
    return module not in RUNNERS and any(fnmatch.fnmatchcase(module, pattern) for pattern in DECLARATIONS)


def floor(module: str) -> str:
    """The room of a module of workflows (``workflows.<room>``), its declarations as a room of their own
    (``workflows.<room>:declarations``); a module of another package: its package."""
    parts = module.split(".")
    if parts[0] != "workflows":
        return parts[0]
    room = ".".join(parts[:2])
    return f"{room}:declarations" if declaration(module) else room


def rooms_graph(graph: grimp.ImportGraph) -> grimp.ImportGraph:
    """The graph of :func:`floor`: a node per room (its declarations apart), an arrow where a module of
    one imports a module of another."""
    rooms = grimp.ImportGraph()
    for module in graph.modules:
        rooms.add_module(floor(module))
        for imported in graph.find_modules_directly_imported_by(module):
            if floor(imported) != floor(module):
                rooms.add_import(importer=floor(module), imported=floor(imported))
    return rooms


def test_the_rooms_of_workflows_import_one_way():
    graph = import_graph()
    print("\nsub-package arrows:", ", ".join(f"{a} -> {b}" for a, b in arrows(graph, 2)))
    found = cycles(rooms_graph(graph))
    assert found == [], "rooms of workflows that import each other:\n" + "\n".join(map(str, found))


def test_the_study_reader_imports_no_code_that_runs():
    graph = import_graph()
    reached = sorted(m for m in graph.find_upstream_modules(STUDY_READER) if m.startswith("workflows."))
    running = [m for m in reached if not declaration(m)]
    chains = [" -> ".join(graph.find_shortest_chain(importer=STUDY_READER, imported=m)) for m in running]
    assert running == [], "the study reader reaches code that runs:\n" + "\n".join(chains)


def _is_sys_path(node: ast.AST) -> bool:
    return (isinstance(node, ast.Attribute) and node.attr == "path" and isinstance(node.value, ast.Name)
            and node.value.id == "sys")


def sys_path_edits() -> list[str]:
    """``file:line`` of every edit of ``sys.path`` (a call of one of its methods that change it, an
    assignment to it or to an item of it, a ``del``) in the repository's Python files."""
    edits = []
    for path in sorted(REPO.glob("*/**/*.py")):
        if path.relative_to(REPO).parts[0] not in (*PACKAGES, "tests"):
            continue
        for node in ast.walk(ast.parse(path.read_text(), str(path))):
            if isinstance(node, ast.Call) and isinstance(node.func, ast.Attribute):
                edited = _is_sys_path(node.func.value) and node.func.attr in MUTATORS
            elif isinstance(node, (ast.Assign, ast.AugAssign, ast.AnnAssign, ast.Delete)):
                targets = node.targets if isinstance(node, (ast.Assign, ast.Delete)) else [node.target]
                edited = any(_is_sys_path(t) or isinstance(t, ast.Subscript) and _is_sys_path(t.value) for t in targets)
            else:
                edited = False
            if edited:
                edits.append(f"{path.relative_to(REPO)}:{node.lineno}")
    return edits


MUTATORS = ("append", "insert", "extend", "remove", "pop", "clear", "sort", "reverse", "__setitem__", "__iadd__")


def test_no_file_edits_sys_path():
    assert sys_path_edits() == []


EACH_FIRST = """
import importlib, sys
from pathlib import Path

names = sorted(".".join(p.with_suffix("").parts).removesuffix(".__init__")
               for package in ("spfem_core", "workflows") for p in Path(package).rglob("*.py"))
failed = []
for name in names:
    for loaded in [key for key in sys.modules if key.split(".")[0] in ("spfem_core", "workflows")]:
        del sys.modules[loaded]
    try:
        importlib.import_module(name)
    except ImportError as error:
        failed.append(f"{name}: {error}")
print(len(names))
print("\\n".join(failed))
"""


def test_every_module_imports_as_the_first_one():
    done = subprocess.run([sys.executable, "-c", EACH_FIRST], cwd=REPO, capture_output=True, text=True, check=True)
    count, *failed = done.stdout.strip().splitlines()
    assert int(count) > 50 and failed == [], failed


if __name__ == "__main__":
    graph = import_graph()
    for depth, name in ((1, "packages"), (2, "sub-packages")):
        found = arrows(graph, depth)
        print(f"{len(found)} arrows between {name}:")
        print("\n".join(f"  {a} -> {b}" for a, b in found))
    rooms = rooms_graph(graph)
    found = sorted((a, b) for a in rooms.modules for b in rooms.find_modules_directly_imported_by(a)
                   if a.startswith("workflows"))
    print(f"{len(found)} arrows between the rooms of workflows, declarations apart:")
    print("\n".join(f"  {a} -> {b}" for a, b in found))
    print("cycles of modules:", cycles(graph) or "none")
    print("cycles of rooms:", cycles(rooms) or "none")

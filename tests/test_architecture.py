"""The code keeps to docs/architecture.md: layers, no circles, public names, local imports."""

from __future__ import annotations

import ast
import re
from collections import defaultdict
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
SRC = ROOT / "src" / "liquidtouch"
ARCHITECTURE = ROOT / "docs" / "architecture.md"
MAX_LOCAL_IMPORTS = 20  # of liquidtouch's own modules, outside the CLI
SIM_MAY_IMPORT = ("liquidtouch.sim", "liquidtouch.io", "liquidtouch.protocols")


def _module_names() -> dict[str, Path]:
    names = {}
    for path in SRC.rglob("*.py"):
        parts = path.relative_to(SRC.parent).with_suffix("").parts
        name = ".".join(parts[:-1] if parts[-1] == "__init__" else parts)
        names[name] = path
    return names


MODULES = _module_names()


def _layer_table() -> dict[str, int]:
    """``module prefix -> layer`` from the table in docs/architecture.md."""
    table = {}
    for line in ARCHITECTURE.read_text().splitlines():
        match = re.match(r"\|\s*(\d+)\s*\|([^|]*)\|", line)
        if match:
            for prefix in re.findall(r"`([\w.]+)`", match.group(2)):
                table[prefix] = int(match.group(1))
    return table


LAYERS = _layer_table()


def layer_of(module: str) -> int:
    best = max((p for p in LAYERS if module == p or module.startswith(p + ".")), key=len)
    return LAYERS[best]


def _resolve(importer: str, node: ast.ImportFrom | ast.Import) -> list[tuple[str, str]]:
    """``(module, imported name or '')`` pairs of liquidtouch modules an import statement names."""
    if isinstance(node, ast.Import):
        return [(a.name, "") for a in node.names if a.name.split(".")[0] == "liquidtouch"]
    base = node.module or ""
    if node.level:
        parts = importer.split(".")
        if not str(MODULES[importer]).endswith("__init__.py"):
            parts = parts[:-1]
        parts = parts[: len(parts) - node.level + 1]
        base = ".".join([*parts, base] if base else parts)
    if base.split(".")[0] != "liquidtouch":
        return []
    out = []
    for alias in node.names:
        full = f"{base}.{alias.name}"
        out.append((full, "") if full in MODULES else (base, alias.name))
    return out


class _Imports(ast.NodeVisitor):
    """Every liquidtouch import of one module: (target, name, line, local?, type-checking?)."""

    def __init__(self, module: str) -> None:
        self.module = module
        self.found: list[tuple[str, str, int, bool, bool]] = []
        self.depth = 0
        self.type_checking = 0

    def visit_FunctionDef(self, node: ast.AST) -> None:
        self.depth += 1
        self.generic_visit(node)
        self.depth -= 1

    visit_AsyncFunctionDef = visit_FunctionDef

    def visit_If(self, node: ast.If) -> None:
        guarded = "TYPE_CHECKING" in ast.unparse(node.test)
        self.type_checking += guarded
        for child in node.body:
            self.visit(child)
        self.type_checking -= guarded
        for child in node.orelse:
            self.visit(child)

    def _add(self, node: ast.Import | ast.ImportFrom) -> None:
        for target, name in _resolve(self.module, node):
            while target not in MODULES and "." in target:
                target = target.rsplit(".", 1)[0]
            local, guarded = self.depth > 0, self.type_checking > 0
            self.found.append((target, name, node.lineno, local, guarded))

    visit_Import = _add
    visit_ImportFrom = _add


def _imports() -> dict[str, list[tuple[str, str, int, bool, bool]]]:
    out = {}
    for module, path in MODULES.items():
        visitor = _Imports(module)
        visitor.visit(ast.parse(path.read_text(), str(path)))
        out[module] = visitor.found
    return out


IMPORTS = _imports()


def _cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """Strongly connected components with more than one node (Tarjan, iterative)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    found = []
    counter = 0
    for root in sorted(graph):
        if root in index:
            continue
        work = [(root, iter(sorted(graph.get(root, ()))))]
        index[root] = low[root] = counter
        counter += 1
        stack.append(root)
        on_stack.add(root)
        while work:
            node, children = work[-1]
            for child in children:
                if child not in index:
                    index[child] = low[child] = counter
                    counter += 1
                    stack.append(child)
                    on_stack.add(child)
                    work.append((child, iter(sorted(graph.get(child, ())))))
                    break
                if child in on_stack:
                    low[node] = min(low[node], index[child])
            else:
                work.pop()
                if work:
                    low[work[-1][0]] = min(low[work[-1][0]], low[node])
                if low[node] == index[node]:
                    component = []
                    while True:
                        member = stack.pop()
                        on_stack.discard(member)
                        component.append(member)
                        if member == node:
                            break
                    if len(component) > 1:
                        found.append(sorted(component))
    return found


def _stage(module: str) -> str:
    return ".".join(module.split(".")[:2])


def test_every_module_has_a_layer() -> None:
    missing = [m for m in MODULES if not any(m == p or m.startswith(p + ".") for p in LAYERS)]
    assert LAYERS and missing == [], f"modules missing from the layer table: {missing}"


def test_no_import_runs_up_the_layers() -> None:
    against = [
        f"{module}:{line} imports {target} (layer {layer_of(module)} -> {layer_of(target)})"
        for module, found in IMPORTS.items()
        for target, _, line, _, _ in found
        if layer_of(target) > layer_of(module)
    ]
    assert against == []


def test_no_import_circles() -> None:
    modules: dict[str, set[str]] = defaultdict(set)
    stages: dict[str, set[str]] = defaultdict(set)
    for module, found in IMPORTS.items():
        for target, _, _, _, guarded in found:
            if guarded or target == module:
                continue
            # a package's __init__ re-exporting its own submodules is not a circle
            if not target.startswith(module + "."):
                modules[module].add(target)
            if _stage(target) != _stage(module) and module != "liquidtouch":
                stages[_stage(module)].add(_stage(target))
    assert _cycles(modules) == []
    assert _cycles(stages) == []


def test_the_simulator_imports_no_analysis_stage() -> None:
    leaked = [
        f"{module} imports {target}"
        for module, found in IMPORTS.items()
        if module.startswith("liquidtouch.sim")
        for target, _, _, _, _ in found
        if layer_of(target) > 0 and not target.startswith(SIM_MAY_IMPORT)
    ]
    assert leaked == []


def test_few_function_local_imports_each_with_a_reason() -> None:
    local = [
        (module, line)
        for module, found in IMPORTS.items()
        if not module.startswith("liquidtouch.cli")
        for _, _, line, is_local, _ in found
        if is_local
    ]
    statements = sorted(set(local))
    assert len(statements) <= MAX_LOCAL_IMPORTS, "\n".join(f"{m}:{n}" for m, n in statements)
    unexplained = []
    for module, line in statements:
        lines = MODULES[module].read_text().splitlines()
        here, above = lines[line - 1], lines[line - 2].strip()
        if "#" not in here and not above.startswith("#"):
            unexplained.append(f"{module}:{line}")
    assert unexplained == [], "function-local imports need a comment saying why"


def test_nothing_private_crosses_a_module_boundary() -> None:
    crossing = [
        f"{module}:{line} imports {name} from {target}"
        for module, found in IMPORTS.items()
        for target, name, line, _, _ in found
        if name.startswith("_") and not name.startswith("__") and target != module
    ]
    assert crossing == []


def _all_names(path: Path) -> list[str]:
    for node in ast.parse(path.read_text()).body:
        if isinstance(node, ast.Assign) and any(
            isinstance(t, ast.Name) and t.id == "__all__" for t in node.targets
        ):
            try:
                return list(ast.literal_eval(node.value))
            except ValueError:  # built from another list: checked at import by the API test
                return []
    return []


@pytest.mark.parametrize("module", sorted(MODULES))
def test_no_private_name_in_all(module: str) -> None:
    private = [n for n in _all_names(MODULES[module]) if n.startswith("_") and n != "__version__"]
    assert private == []


@pytest.mark.parametrize("module", sorted(m for m, p in MODULES.items() if p.name != "__init__.py"))
def test_a_module_exports_only_what_it_defines(module: str) -> None:
    """One import path per name: re-exporting is for a stage package's ``__init__``."""
    tree = ast.parse(MODULES[module].read_text())
    imported = {
        alias.asname or alias.name
        for node in tree.body
        if isinstance(node, ast.ImportFrom)
        for alias in node.names
    }
    assert [name for name in _all_names(MODULES[module]) if name in imported] == []


def test_the_ring_down_stage_is_used_through_its_face() -> None:
    """Stages above the ring-down import ``liquidtouch.ring_down``, not its modules."""
    reaching_in = [
        f"{module}:{line} imports {target}"
        for module, found in IMPORTS.items()
        if not module.startswith("liquidtouch.ring_down")
        for target, _, line, _, _ in found
        if target.startswith("liquidtouch.ring_down.")
    ]
    assert reaching_in == []


def test_the_tests_mirror_the_stages() -> None:
    """``tests/<stage>/`` holds the tests of ``liquidtouch.<stage>``; the root holds the
    whole-repository ones (architecture, README, notebook)."""
    folders = {
        p.name
        for p in (ROOT / "tests").iterdir()
        if p.is_dir() and not p.name.startswith((".", "_")) and p.name != "data"
    }
    stages = {p.name for p in SRC.iterdir() if (p / "__init__.py").exists()}
    assert folders and folders <= stages, sorted(folders - stages)


BENCHMARKS = ROOT / "benchmarks"


def _imported_modules(path: Path) -> list[tuple[str, list[str], int]]:
    """``(module, imported names, line)`` of every absolute import in the file at ``path``."""
    found = []
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"), str(path))):
        if isinstance(node, ast.Import):
            found += [(alias.name, [], node.lineno) for alias in node.names]
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            found.append((node.module, [a.name for a in node.names], node.lineno))
    return found


def _is_script(path: Path) -> bool:
    return 'if __name__ == "__main__":' in path.read_text(encoding="utf-8")


def test_no_test_imports_the_benchmarks() -> None:
    """What tests and benchmarks share lives in ``liquidtouch.testing``."""
    offences = [
        f"{path.relative_to(ROOT)}:{line} imports {module}"
        for path in sorted((ROOT / "tests").rglob("*.py"))
        for module, _, line in _imported_modules(path)
        if module.split(".")[0] == "benchmarks"
    ]
    assert offences == []


def test_benchmarks_import_only_public_names_and_no_other_benchmark() -> None:
    """A benchmark imports no private name, nothing of ``liquidtouch._core`` and no other
    benchmark script; a module beside it named after it (``time_to_answer_tables.py`` of
    ``time_to_answer.py``) is its own part, not a script."""
    scripts = sorted(BENCHMARKS.rglob("*.py"))
    assert len(scripts) > 20 and all(p.parent != BENCHMARKS for p in scripts)  # stage folders
    by_stem = {p.stem: p for p in scripts}
    offences = []
    for path in scripts:
        where = path.relative_to(ROOT)
        for module, names, line in _imported_modules(path):
            parts = module.split(".")
            private = [n for n in [*parts, *names] if n.startswith("_") and n != "__future__"]
            if private:
                offences.append(f"{where}:{line} imports private {private} ({module})")
            sibling = by_stem.get(parts[0])
            own_part = (
                sibling is not None
                and sibling.parent == path.parent
                and parts[0].startswith(path.stem + "_")
                and not _is_script(sibling)
            )
            if parts[0] == "benchmarks" or (sibling is not None and not own_part):
                offences.append(f"{where}:{line} imports the benchmark {module}")
        if "sys.path" in path.read_text(encoding="utf-8"):
            offences.append(f"{where} changes sys.path")
    assert offences == []

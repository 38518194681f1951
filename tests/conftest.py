"""Test-suite conventions, enforced at collection.

Shared helpers live in plain modules that test modules import; a test module
never imports another test module (that would import it twice, under two
names, and run its module-level code outside pytest's control):

- ``tests/helpers.py``: synthetic GelSight marker images (``render_blobs``, ``grid``);
- ``benchmarks/synthetic_tables.py``: synthetic (λ, ω) feature tables with labels,
  shared with ``benchmarks/regression.py``.

pytest's ``pythonpath`` (pyproject.toml) holds the repository root and ``tests/``,
so these import as ``from helpers import ...`` and
``from benchmarks.synthetic_tables import ...``.

Tests marked ``slow`` (the end-to-end runs, tens of seconds each) run first, so
that under ``pytest -n 2 --dist worksteal`` (``make test``) the other worker takes
the many short tests meanwhile and no long test starts last, alone, on an
otherwise idle machine. Their module-scoped fixtures serve slow tests only (keep it
so), so moving them costs no extra fixture set-up.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest


def _imports_of_test_modules(path: Path) -> list[str]:
    """Names of test modules (``test_*``, ``tests.test_*``) that the file at ``path`` imports."""
    tree = ast.parse(path.read_text(encoding="utf-8"), filename=str(path))
    names: list[str] = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            names += [alias.name for alias in node.names]
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            names.append(node.module)
    return [n for n in names if n.split(".")[-1].startswith("test_")]


def pytest_collection_modifyitems(session: pytest.Session, config, items) -> None:
    """Refuse to run when a test module imports another test module; ``slow`` tests first."""
    files = {Path(str(item.fspath)) for item in items}
    offences = [
        f"{path.name} imports {name}"
        for path in sorted(files)
        if path.suffix == ".py"
        for name in _imports_of_test_modules(path)
    ]
    if offences:
        raise pytest.UsageError(
            "test modules must not import each other; move shared code to tests/helpers.py: "
            + "; ".join(offences)
        )
    # stable: the slow tests keep their order, and so do the others (module by module)
    items.sort(key=lambda item: item.get_closest_marker("slow") is None)

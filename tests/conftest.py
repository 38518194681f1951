"""Test-suite conventions, enforced at collection.

Shared helpers live in plain modules that test modules import; a test module
never imports another test module (that would import it twice, under two
names, and run its module-level code outside pytest's control):

- ``tests/helpers.py``: synthetic GelSight marker images (``render_blobs``, ``grid``);
- ``benchmarks/synthetic_tables.py``: synthetic (λ, ω) feature tables with labels,
  shared with ``benchmarks/regression.py``.

Fixtures shared by several modules live here: ``synthetic_report`` (the experiments'
report on the synthetic tables, built once per run for all workers).

pytest's ``pythonpath`` (pyproject.toml) holds the repository root and ``tests/``,
so these import as ``from helpers import ...`` and
``from benchmarks.synthetic_tables import ...``.

Tests marked ``slow`` (the end-to-end runs, tens of seconds each) run first (after
the tests of ``synthetic_report``, whose one build starts at once), so that under
``pytest -n 2 --dist worksteal`` (``make test``) the other worker takes the many
short tests meanwhile and no long test starts last, alone, on an otherwise idle
machine. Their module-scoped fixtures serve slow tests only (keep it
so), so moving them costs no extra fixture set-up.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest
from helpers import built_once

from benchmarks.experiment_tables import experiment_features
from liquidtouch.experiments.report import write_report
from liquidtouch.experiments.reproduce import failure_note, run_experiments


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
    """Refuse to run when a test module imports another test module; long set-ups first."""
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
    # stable: the tests of the report built once per run (conftest's synthetic_report), then
    # the slow tests, then the others, each in collection order (module by module)
    items.sort(key=_start_rank)


def _start_rank(item: pytest.Item) -> int:
    """0 for the tests that read ``synthetic_report``, 1 for ``slow`` ones, 2 for the rest.

    The report's tests go first, so that its one build starts at once on one worker and
    is finished before the other worker, if it takes some of them over, would have to
    wait for it.
    """
    if "synthetic_report" in getattr(item, "fixturenames", ()):
        return 0
    return 1 if item.get_closest_marker("slow") is not None else 2


@pytest.fixture(scope="session")
def synthetic_report(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """Directory of the seven experiments' report on ``experiment_features()``, full draws.

    ~55 CPU-s, built once per run (``helpers.built_once``) and read by
    ``test_experiments.py`` (the experiments' numbers) and ``test_report_browser.py``
    (the page in Chromium): report.md, report.html, summary.csv, the figures and tables.
    """

    def build(out: Path) -> None:
        features = experiment_features()
        results = run_experiments(features, out)
        provenance = {"liquidtouch": "test", "git commit": "none (test)"}
        write_report(
            results, out, title="test", preamble=failure_note(features), provenance=provenance
        )

    return built_once(tmp_path_factory, "synthetic_report", build)

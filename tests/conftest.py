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

Tests marked ``slow(seconds=...)`` (the end-to-end runs, seconds to minutes each) and
the tests of ``synthetic_report`` (a long build) start the two halves of the test list
(``_long_tests_spread``): under ``pytest -n 2 --dist worksteal`` (``make test``) each
worker begins with its share of the long tests, the short ones follow, and no long test
starts last, alone, on an otherwise idle machine. The ``exclusive`` ones (a pool, a rig
in real time) share one worker, so that they never run beside each other. A module's
slow tests stay together, and their module-scoped fixtures serve slow tests only (keep
it so), so moving them costs no extra set-up.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest
from helpers import built_once

from benchmarks.experiment_tables import experiment_features
from liquidtouch.experiments.report import write_report
from liquidtouch.experiments.reproduce import failure_note
from liquidtouch.experiments.suite import run_experiments


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


@pytest.hookimpl(trylast=True)  # after -k/-m deselection: the order of the tests that run
def pytest_collection_modifyitems(session: pytest.Session, config, items) -> None:
    """Refuse to run when a test module imports another test module; long tests spread."""
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
    items[:] = _long_tests_spread(items)


#: rough time [s] of the synthetic report's one build (``synthetic_report``)
REPORT_BUILD_S = 55.0


def _long_tests_spread(items: list[pytest.Item]) -> list[pytest.Item]:
    """The tests in an order that starts each half with its share of the long tests.

    ``--dist worksteal`` hands the first half of the list to one worker and the second half
    to the other, and later moves tests from the end of a worker's queue to the other.
    The long tests (``slow(seconds=...)``, and the tests of ``synthetic_report``, whose
    build is long) are grouped by module, so that a module-scoped fixture is set up on
    one worker only. The ``exclusive`` ones (a pool of workers, or a rig or cameras in
    real time) all go to the first half, one after the other, so that no two of them
    share the two cores at once (a starved real-time rig drops frames); the other long
    groups are dealt, longest first, to the half with fewer seconds so far. Each half
    begins with its long groups, longest first; the short tests fill the rest of each
    half, in collection order. Without xdist this is just an order.
    """
    groups: dict[str, list[pytest.Item]] = {}
    seconds: dict[str, float] = {}
    exclusive: set[str] = set()
    short = []
    for item in items:
        marker = item.get_closest_marker("slow")
        if "synthetic_report" in getattr(item, "fixturenames", ()):
            key = "synthetic_report"
            seconds[key] = REPORT_BUILD_S
        elif marker is not None:
            key = str(item.fspath)
            seconds[key] = seconds.get(key, 0.0) + float(marker.kwargs.get("seconds", 10.0))
            if marker.kwargs.get("exclusive", False):
                exclusive.add(key)
        else:
            short.append(item)
            continue
        groups.setdefault(key, []).append(item)
    halves: tuple[list[pytest.Item], list[pytest.Item]] = ([], [])
    loads = [0.0, 0.0]
    # the exclusive groups first (all to the first half), then the others by length
    for key in sorted(groups, key=lambda k: (k not in exclusive, -seconds[k])):
        half = 0 if key in exclusive or loads[0] <= loads[1] else 1
        halves[half].extend(groups[key])
        loads[half] += seconds[key]
    fill = max(len(items) // 2 - len(halves[0]), 0)  # worksteal's first share: len // 2
    return [*halves[0], *short[:fill], *halves[1], *short[fill:]]


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

"""Test-suite conventions, enforced at collection.

Shared helpers live in plain modules that test modules import; a test module
never imports another test module (that would import it twice, under two
names, and run its module-level code outside pytest's control):

- ``tests/helpers.py``: synthetic GelSight marker images (``render_blobs``, ``grid``);
- ``liquidtouch.testing`` (in the package, shared with the benchmarks): synthetic (λ, ω)
  feature tables with labels, marker tracks without rendering, the browser checks.

Fixtures shared by several modules live here: ``synthetic_report`` (the experiments'
report on the synthetic tables, built once per run for all workers).

pytest's ``pythonpath`` (pyproject.toml) holds the repository root and ``tests/``,
so these import as ``from helpers import ...`` and
``from liquidtouch.testing.synthetic_tables import ...``; no test imports ``benchmarks``.

Tests marked ``slow(seconds=...)`` (the end-to-end runs, seconds to minutes each) and
the tests of ``synthetic_report`` (a long build) start the workers' shares of the test
list (``_long_tests_spread``): under ``pytest -n 3 --dist worksteal`` (``make test``) each
worker begins with its share of the long tests, the short ones follow, and no long test
starts last, alone, on an otherwise idle machine. The ``exclusive`` ones (a pool, a rig
in real time) share one worker, so that they never run beside each other, and the other
workers lower their priority (``pytest_runtest_setup``), so that with three workers on
two cores the real-time tests still get a core. A module's
slow tests stay together, and their module-scoped fixtures serve slow tests only (keep
it so), so moving them costs no extra set-up.
"""

from __future__ import annotations

import ast
import os
from pathlib import Path

import pytest
from helpers import built_once

from liquidtouch.experiments.report import write_report
from liquidtouch.experiments.reproduce import failure_note
from liquidtouch.experiments.suite import run_experiments
from liquidtouch.testing.experiment_tables import experiment_features


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
    items[:] = _long_tests_spread(items, _workers())


def _workers() -> int:
    """The number of xdist workers the tests are shared among (1 without xdist)."""
    return int(os.environ.get("PYTEST_XDIST_WORKER_COUNT", "1"))  # set on each worker


#: rough time [s] of the synthetic report's one build (``synthetic_report``)
REPORT_BUILD_S = 55.0


def _long_tests_spread(items: list[pytest.Item], parts: int) -> list[pytest.Item]:
    """The tests in an order that starts each worker's share with its long tests.

    ``--dist worksteal`` hands each of the ``parts`` workers an equal contiguous share of
    the list, and later moves tests from the end of a worker's queue to a worker that ran
    dry. The long tests (``slow(seconds=...)``, and the tests of ``synthetic_report``,
    whose build is long) are grouped by module, so that a module-scoped fixture is set up
    on one worker only. The ``exclusive`` ones (a pool of workers, or a rig or cameras in
    real time) all go to the first share, one after the other, so that no two of them
    share the cores at once (a starved real-time rig drops frames); the other long groups
    are dealt, longest first, to the share with the fewest seconds so far. Each share
    begins with its long groups, longest first; the short tests fill the rest of each
    share, in collection order. Without xdist this is just an order.
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
    shares: list[list[pytest.Item]] = [[] for _ in range(max(parts, 1))]
    loads = [0.0] * len(shares)
    # the exclusive groups first (all to the first share), then the others by length
    for key in sorted(groups, key=lambda k: (k not in exclusive, -seconds[k])):
        share = 0 if key in exclusive else loads.index(min(loads))
        shares[share].extend(groups[key])
        loads[share] += seconds[key]
    ordered: list[pytest.Item] = []
    for k, share in enumerate(shares):  # worksteal's first shares: len // parts each
        end = (k + 1) * len(items) // len(shares)
        fill = max(end - len(ordered) - len(share), 0) if k < len(shares) - 1 else len(short)
        ordered += share + short[:fill]
        short = short[fill:]
    return ordered


#: niceness a worker takes when its first test is not an exclusive one: the worker that
#: runs the real-time tests keeps the cores first when three workers share two
OTHER_WORKERS_NICE = 5
_first_test_seen = False


def pytest_runtest_setup(item: pytest.Item) -> None:
    """Under xdist, a worker whose first test is not ``exclusive`` lowers its priority.

    The exclusive tests (a rig or cameras in real time) begin the first worker's share
    (``_long_tests_spread``); the others' CPU-bound tests then wait for them, as they
    would with one worker per core, instead of starving them (frames dropped, deadlines
    missed). Never raised back: a niceness can only be lowered by a privileged process.
    """
    global _first_test_seen
    if _first_test_seen or "PYTEST_XDIST_WORKER" not in os.environ:
        return
    _first_test_seen = True
    marker = item.get_closest_marker("slow")
    if marker is None or not marker.kwargs.get("exclusive", False):
        try:
            os.nice(OTHER_WORKERS_NICE)
        except OSError:  # no such thing on this platform: run as is
            pass


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

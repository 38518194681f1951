"""Layering: the models layer trains on feature tables without the video stages.

``liquidtouch.models`` (with ``liquidtouch.io.tables``) must work without PyAV,
OpenCV, marker tracking or signal extraction: a machine that only trains and
predicts from a features CSV need not import them.
"""

from __future__ import annotations

import ast
import os
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

import liquidtouch
from liquidtouch.testing.synthetic_tables import PAPER_CONCENTRATIONS, PAPER_HEIGHTS_MM, sugar_table

FORBIDDEN = ("av", "cv2", "liquidtouch.tracking", "liquidtouch.extraction.pipeline")
SRC = Path(liquidtouch.__file__).resolve().parents[1]

# Runs in a fresh interpreter: train, save and load through the public models API.
SCRIPT = textwrap.dedent(
    """
    import sys

    {preamble}
    import numpy as np

    import liquidtouch.models as models
    from liquidtouch.io.tables import numeric_column, read_feature_table

    csv, out = sys.argv[1], sys.argv[2]
    table, X = read_feature_table(csv)
    targets = {{t: numeric_column(table, t) for t in ("height_mm", "log10_viscosity_cst")}}
    model = models.train_regression(X, targets, "gpr")
    again = models.load_model(models.save_model(model, out))
    before, after = model.predict(X), again.predict(X)
    assert all(np.array_equal(before[t][0], after[t][0]) for t in targets)
    predicted = again.predict_table(table)
    assert np.mean(np.abs(predicted["predicted_height_mm"] - table["height_mm"])) < 1.0

    forbidden = {forbidden!r}
    loaded = sorted(
        n for n in sys.modules if any(n == f or n.startswith(f + ".") for f in forbidden)
    )
    if loaded:
        sys.exit("the models layer imported: " + ", ".join(loaded))
    print("ok")
    """
)


def _run(tmp_path: Path, preamble: str = "") -> subprocess.CompletedProcess:
    csv = tmp_path / "features.csv"
    sugar_table(PAPER_HEIGHTS_MM[::4], PAPER_CONCENTRATIONS[::3], seed=50).to_csv(csv, index=False)
    env = {
        **os.environ,
        "PYTHONPATH": os.pathsep.join([str(SRC), os.environ.get("PYTHONPATH", "")]),
    }
    script = SCRIPT.format(preamble=preamble, forbidden=FORBIDDEN)
    return subprocess.run(
        [sys.executable, "-c", script, str(csv), str(tmp_path / "model.json")],
        capture_output=True,
        text=True,
        env=env,
        timeout=300,
        check=False,
    )


def test_models_train_save_load_without_video_stages(tmp_path) -> None:
    result = _run(tmp_path)
    assert result.returncode == 0, result.stderr
    assert result.stdout.strip() == "ok"
    assert (tmp_path / "model.json").is_file()


@pytest.mark.parametrize("module", ["liquidtouch.tracking", "liquidtouch.extraction.pipeline"])
def test_the_layer_check_catches_a_forbidden_import(tmp_path, module) -> None:
    """The check itself works: the same run with a forbidden import must fail."""
    result = _run(tmp_path, preamble=f"import {module}")
    assert result.returncode != 0
    assert "the models layer imported:" in result.stderr and module in result.stderr


def _imported_modules(path: Path) -> set[str]:
    """Absolute module names imported anywhere in a file (also inside functions)."""
    names = set()
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.Import):
            names |= {alias.name for alias in node.names}
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            names.add(node.module)
            names |= {f"{node.module}.{alias.name}" for alias in node.names}
    return names


def _module_file(name: str) -> Path | None:
    parts = name.split(".")
    if parts[0] != "liquidtouch":
        return None
    base = SRC.joinpath(*parts)
    for candidate in (base.with_suffix(".py"), base / "__init__.py"):
        if candidate.is_file():
            return candidate
    return None


def test_no_lazy_import_of_the_video_stages_either() -> None:
    """Imports inside functions do not run in the smoke test: follow them statically.

    Every liquidtouch module reachable from ``liquidtouch.models`` by any import
    statement (lazy ones included) must avoid the forbidden modules.
    """
    todo = ["liquidtouch.models", "liquidtouch.io.tables"]
    todo += [f"liquidtouch.models.{p.stem}" for p in (SRC / "liquidtouch" / "models").glob("*.py")]
    seen: dict[str, set[str]] = {}
    while todo:
        name = todo.pop()
        path = _module_file(name)
        if path is None or name in seen:
            continue
        seen[name] = _imported_modules(path)
        todo += [n for n in seen[name] if n.startswith("liquidtouch.")]
        # importing liquidtouch.a.b runs liquidtouch/a/__init__.py too
        parts = name.split(".")
        todo += [".".join(parts[:i]) for i in range(2, len(parts))]
    offences = sorted(
        f"{module} imports {imported}"
        for module, imports in seen.items()
        for imported in imports
        if any(imported == f or imported.startswith(f + ".") for f in FORBIDDEN)
    )
    assert "liquidtouch.models.regressors" in seen and "liquidtouch.io.tables" in seen
    assert not offences, offences


def test_the_static_check_sees_imports_inside_functions(tmp_path) -> None:
    module = tmp_path / "lazy.py"
    module.write_text("def f():\n    import cv2\n    from liquidtouch import extraction\n")
    assert {"cv2", "liquidtouch.extraction"} <= _imported_modules(module)

"""A model file bounds every parameter that sets what loading it costs (issue 41, item 5).

A 17 KB classifier file with SVM C = 1e12 passed every check, then ``predict`` and
``live --model`` refitted it for minutes (still running at 600 s). Each parameter that
sets the refit's cost is bounded by what liquidtouch trains (C, gamma: the grids it
searches; a GP's kernel: the bounds its fit searches, its restarts), and a file beyond
them is refused at load with one ``error:`` line, before the refit. The checksum does not
protect against this: whoever edits the file can recompute it.
"""

from __future__ import annotations

import json
import time

import numpy as np
import pytest

from liquidtouch.cli import main
from liquidtouch.errors import ModelFileError, TableError
from liquidtouch.models.classifier import C_BOUNDS, GAMMA_BOUNDS, LiquidClassifier
from liquidtouch.models.modelfile import load_model, save_model
from liquidtouch.models.modelfile_checks import document_sha256, training_sha256
from liquidtouch.models.regressors import GPRegressor
from liquidtouch.models.training import train_classifier, train_regression


def _classifier_file(tmp_path):
    rng = np.random.default_rng(0)
    centres = {"water": (0.2, 14.0), "oil": (1.0, 13.0), "mirin": (0.5, 15.0)}
    rows = [(c, rng.normal(m, (0.05, 0.2))) for c, m in centres.items() for _ in range(8)]
    labels = [c for c, _ in rows]
    X = np.array([x for _, x in rows])
    return save_model(train_classifier(X, labels), tmp_path / "clf.json")


def _edited(path, change) -> None:
    """Edit a model file and make its checksums match again (as a hostile editor would)."""
    doc = json.loads(path.read_text())
    change(doc)
    if doc.get("provenance"):
        doc["provenance"]["training_sha256"] = training_sha256(doc)
    doc["sha256"] = document_sha256(doc)
    path.write_text(json.dumps(doc))


@pytest.mark.parametrize(
    ("key", "value"),
    [("C", 1e12), ("C", 1e4), ("C", 1e-6), ("gamma", 1e6), ("gamma", 1e-9)],
)
def test_a_classifier_whose_refit_would_take_minutes_is_refused_at_load(
    tmp_path, capsys, key, value
):
    path = _classifier_file(tmp_path)
    _edited(path, lambda doc: doc["classifier"].__setitem__(key, value))
    start = time.monotonic()
    with pytest.raises(ModelFileError, match=f"classifier.{key}: Input should be"):
        load_model(path)
    features = tmp_path / "f.csv"
    features.write_text("trial,decay_rate,angular_frequency\na,0.2,14.0\n")
    assert main(["predict", str(path), str(features)]) == 2
    err = capsys.readouterr().err
    assert err.startswith("error: ") and err.count("\n") == 1 and f"classifier.{key}" in err
    assert time.monotonic() - start < 30  # before: > 600 s at C = 1e12


def test_the_bounds_are_the_grids_liquidtouch_trains_on(tmp_path):
    path = _classifier_file(tmp_path)
    for key, bounds in (("C", C_BOUNDS), ("gamma", GAMMA_BOUNDS)):
        _edited(path, lambda doc, k=key, b=bounds: doc["classifier"].__setitem__(k, b[1]))
        assert load_model(path) is not None  # the largest trained value still loads
    with pytest.raises(TableError, match=r"C 10000 is outside 0\.1-1000"):  # nor trained beyond
        LiquidClassifier(C=1e4).fit(np.random.default_rng(0).normal(size=(9, 2)), [0, 1, 2] * 3)


@pytest.mark.parametrize(
    ("change", "where"),
    [
        (lambda s: s["kernel"].__setitem__("noise_level", 1e-300), "kernel.noise_level"),
        (lambda s: s["kernel"].__setitem__("length_scale", [1e-9, 1.0]), "kernel.length_scale"),
        (lambda s: s["kernel"].__setitem__("constant", 1e30), "kernel.constant"),
        (lambda s: s.__setitem__("n_restarts", 10**9), "n_restarts"),
    ],
)
def test_a_gp_kernel_outside_the_fits_bounds_is_refused_at_load(tmp_path, change, where):
    rng = np.random.default_rng(1)
    X = np.column_stack([rng.uniform(0.1, 1, 30), rng.uniform(12, 16, 30)])
    model = train_regression(X, {"height_mm": 2.0 * X[:, 1]}, model="gpr")
    path = save_model(model, tmp_path / "gp.json")
    _edited(path, lambda doc: change(doc["regressors"]["height_mm"]))
    with pytest.raises(ModelFileError, match=f"height_mm.gpr.{where}"):
        load_model(path)
    with pytest.raises(TableError, match="n_restarts must be at most"):
        GPRegressor(n_restarts=10**9).fit(X, 2.0 * X[:, 1])

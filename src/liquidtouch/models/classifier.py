"""Classifying the liquid from (λ, ω): an RBF-kernel SVM with class probabilities.

Inputs are standardised; ``C`` and ``gamma`` are chosen by stratified
cross-validation over a small grid unless given. Probabilities come from
sigmoid (Platt) calibration on cross-validated decision values
(``CalibratedClassifierCV(SVC(), ensemble=False)``, scikit-learn's replacement
for ``SVC(probability=True)``). Everything is deterministic, so a model file
storing the training data and the chosen ``C``/``gamma`` rebuilds it exactly.

**"unknown": far from every trained class.** An SVM names one of its classes wherever
it is asked, with confidence (mirin, between water and olive oil, comes out "water" or
"olive oil" at p ≈ 0.7-0.8). So each class also keeps the mean and covariance of its
training rows in ``z = (log λ, ω)`` (log: λ's spread is relative and spans decades), and
a row is *unknown* when it lies outside every class's **prediction region**: for a class
of ``n`` rows in ``p = 2`` features, a new row drawn from the same (Gaussian)
distribution has Hotelling's

    T² = (z − z̄)ᵀ [S (1 + 1/n) + Σ]⁻¹ (z − z̄) ~ p (n − 1) / (n − p) · F(p, n − p)

(``S`` the class's sample covariance; ``Σ`` the row's own measurement covariance when
it is known, e.g. a streaming fit's λ and ω std, else 0), so the row is unknown when
``T²`` exceeds the ``1 − alpha`` quantile of that distribution for every class. The one
setting, ``alpha`` (:data:`UNKNOWN_ALPHA`, 0.001), is a false-alarm rate: if a class's
rows are Gaussian, one trial of that class in a thousand is called unknown. A class of
few rows has a wide region (n = 3: the quantile is ~4000), a class of many a tight one
(→ the χ²₂ quantile, 13.8). The rule extrapolates nothing: fill heights outside the
trained range count as unknown too (they are outside what the model knows).

**When the rule is available.** A class of few rows has so wide a region that nothing
near it is ever unknown: with 4 rows per class (the tour's classifier) the limit is 2997,
and unseen mirin is named "water". The rule is *available* when every class has at least
:func:`unknown_rows_needed` rows (15 at ``alpha`` 0.001): its limit is then within
:data:`UNKNOWN_REGION_FACTOR` of the large-sample χ²₂ quantile, so a liquid as near a trained
one as simulated mirin is to olive oil (T² 27-58, ``docs/formats.md``) is flagged.
Otherwise :meth:`LiquidClassifier.unknown_status` says ``"unavailable, needs N rows per
class"`` (``classify`` warns; the model file and every prediction carry it).
"""

from __future__ import annotations

from typing import Any

import numpy as np
from scipy import stats
from sklearn.base import BaseEstimator, ClassifierMixin
from sklearn.utils.validation import check_is_fitted

from liquidtouch._core.checks import check_positive
from liquidtouch.errors import ModelFileError, TableError
from liquidtouch.models.kernel_limits import check_kernel_rows, single_threaded_blas
from liquidtouch.models.validation import mean_and_scale, validate_X, validate_X_y

MIN_ROWS_PER_CLASS = 3
# Moderate values first: on a tie of cross-validated accuracy (small, well-separated
# training sets score 100 % everywhere) the first is taken, and the most regularised
# corner (C = 0.1, γ = 0.1) underfits so much that it misclassifies its own training data.
#: false-alarm rate of the "unknown" rule (module docstring): the prediction-region level
UNKNOWN_ALPHA = 0.001
#: the name given to a row far from every trained class
UNKNOWN = "unknown"
#: the "unknown" rule is available when each class's T² limit is at most this many times the
#: large-sample (χ²₂) one: twice 13.8 is 27.6, the nearest simulated mirin comes to olive oil
#: (T² 27-58 with 8 or 32 rows per class: docs/formats.md, Model files)
UNKNOWN_REGION_FACTOR = 2.0
#: the features of the "unknown" rule: (log λ, ω)
NOVELTY_FEATURES = ("log_decay_rate", "angular_frequency")
#: λ below this [1/s] is clipped before its log (a mapped λ can be ≤ 0: far from any class)
MIN_LOG_DECAY_RATE = 1e-9
C_GRID = (10.0, 1.0, 100.0, 0.1, 1000.0)
GAMMA_GRID = (1.0, 0.3, 3.0, 0.1, 10.0)
#: the C and gamma a classifier takes (and a model file may hold): the grids' ranges. The
#: SVM's refit on loading grows with both: on 400 rows of random labels C = 1e4 took
#: 1.2 s, 1e5 8 s, 1e6 68 s (a 17 KB file at C = 1e12 ran past 600 s); on 2000 rows
#: gamma = 10 took 6 s
C_BOUNDS = (min(C_GRID), max(C_GRID))
GAMMA_BOUNDS = (min(GAMMA_GRID), max(GAMMA_GRID))


class LiquidClassifier(ClassifierMixin, BaseEstimator):
    """RBF-kernel SVM on standardised (λ, ω) with calibrated class probabilities.

    A scikit-learn classifier. ``C`` and ``gamma`` (in standardised units)
    default to ``None``: choose them by stratified cross-validated accuracy on
    :data:`C_GRID` × :data:`GAMMA_GRID`. Needs at least 2 classes and
    :data:`MIN_ROWS_PER_CLASS` rows of each, and at most
    :data:`~liquidtouch.models.kernel_limits.MAX_KERNEL_ROWS` rows. Class labels keep their type
    (model files store them as strings; ``train_classifier`` converts them).

    ``alpha`` is the false-alarm rate of the "unknown" rule (module docstring):
    :meth:`unknown` tells which rows are far from every class, :meth:`class_t2` their
    statistics; :meth:`predict` still names a trained class (scikit-learn's contract).

    Fitted attributes: ``classes_``, ``C_``, ``gamma_`` (the values used),
    ``model_`` (the calibrated SVM), ``X_train_``, ``labels_train_``, ``x_mean_``,
    ``x_scale_``, ``n_features_in_``; for the "unknown" rule ``class_n_`` (k,),
    ``class_mean_`` (k, 2) and ``class_cov_`` (k, 2, 2) of the training rows in
    ``(log λ, ω)``, in the order of ``classes_``.
    """

    model_name = "svm"

    def __init__(
        self, C: float | None = None, gamma: float | None = None, alpha: float = UNKNOWN_ALPHA
    ) -> None:
        self.C = C
        self.gamma = gamma
        self.alpha = alpha

    def _folds(self, labels: np.ndarray) -> int:
        _, counts = np.unique(labels, return_counts=True)
        return int(min(5, counts.min()))

    def _select(self, Z: np.ndarray, labels: np.ndarray) -> tuple[float, float]:
        from sklearn.model_selection import GridSearchCV, StratifiedKFold
        from sklearn.svm import SVC

        grid = {
            "C": [float(self.C)] if self.C is not None else list(C_GRID),
            "gamma": [float(self.gamma)] if self.gamma is not None else list(GAMMA_GRID),
        }
        if len(grid["C"]) * len(grid["gamma"]) == 1:
            return grid["C"][0], grid["gamma"][0]
        search = GridSearchCV(SVC(kernel="rbf"), grid, cv=StratifiedKFold(self._folds(labels)))
        search.fit(Z, labels)
        return float(search.best_params_["C"]), float(search.best_params_["gamma"])

    def fit(self, X: Any, y: Any) -> LiquidClassifier:
        """Fit on (n, d) features ``X`` and class labels ``y`` (n,); return ``self``.

        Raises :class:`TableError` for C or gamma not > 0, bad features, continuous
        labels, fewer than 2 classes or fewer than 3 rows of a class.
        """
        from sklearn.calibration import CalibratedClassifierCV
        from sklearn.model_selection import StratifiedKFold
        from sklearn.svm import SVC

        for name, (low, high) in (("C", C_BOUNDS), ("gamma", GAMMA_BOUNDS)):
            value = getattr(self, name)
            if value is not None and not low <= check_positive(value, name) <= high:
                raise TableError(
                    f"{name} {value:g} is outside {low:g}-{high:g}, the grid liquidtouch "
                    "searches (a model file holds no more: its refit grows with both)"
                )
        if not 0 < float(self.alpha) < 1:
            raise TableError(f"alpha must be a probability in (0, 1); got {self.alpha!r}")
        X, labels = validate_X_y(self, X, y, classification=True)
        check_kernel_rows(self, X.shape[0])
        classes, counts = np.unique(labels, return_counts=True)
        if classes.size < 2:
            raise TableError(
                f"classification needs at least 2 classes; got 1 class: {classes.tolist()}"
            )
        if counts.min() < MIN_ROWS_PER_CLASS:
            few = ", ".join(
                f"{c} ({n})" for c, n in zip(classes, counts, strict=True) if n < MIN_ROWS_PER_CLASS
            )
            raise TableError(
                f"classification needs at least {MIN_ROWS_PER_CLASS} rows per class; "
                f"too few for: {few} (add trials)"
            )
        self.X_train_, self.labels_train_ = X, labels
        self.x_mean_, self.x_scale_ = mean_and_scale(X)
        Z = (X - self.x_mean_) / self.x_scale_
        with single_threaded_blas():  # small problems: BLAS threads only contend (3× slower)
            self.C_, self.gamma_ = self._select(Z, labels)
            self.model_ = CalibratedClassifierCV(
                SVC(kernel="rbf", C=self.C_, gamma=self.gamma_),
                method="sigmoid",
                cv=StratifiedKFold(self._folds(labels)),
                ensemble=False,
            ).fit(Z, labels)
        self.classes_ = self.model_.classes_
        self._class_statistics()
        return self

    def _class_statistics(self) -> None:
        """Each class's rows in (log λ, ω): count, mean and sample covariance."""
        z = novelty_features(self.X_train_)
        groups = [z[self.labels_train_ == c] for c in self.classes_]
        self.class_n_ = np.array([g.shape[0] for g in groups])
        self.class_mean_ = np.array([g.mean(axis=0) for g in groups])
        d = z.shape[1]
        self.class_cov_ = np.array([np.cov(g, rowvar=False).reshape(d, d) for g in groups])

    def class_t2(self, X: Any, X_std: Any = None) -> np.ndarray:
        """Hotelling's T² (n, k) of each row to each class (module docstring).

        ``X_std`` (n, 2): the rows' λ and ω std (their measurement uncertainty, added to
        each class's predictive covariance); ``None`` or NaN: 0.
        """
        check_is_fitted(self, "model_")
        Xv = validate_X(self, X)
        z = novelty_features(Xv)
        var = np.zeros_like(z)
        if X_std is not None:
            std = np.nan_to_num(np.abs(np.asarray(X_std, dtype=float).reshape(z.shape)))
            lam = np.maximum(Xv[:, 0], MIN_LOG_DECAY_RATE)
            var = std**2
            var[:, 0] = (std[:, 0] / lam) ** 2
        out = np.empty((z.shape[0], len(self.classes_)))
        for j, (n, mean, cov) in enumerate(
            zip(self.class_n_, self.class_mean_, self.class_cov_, strict=True)
        ):
            d = z - mean
            base = cov * (1 + 1 / n)
            base = base + 1e-12 * np.trace(base) * np.eye(len(mean))  # invertible, no more
            for i in range(z.shape[0]):
                out[i, j] = d[i] @ np.linalg.solve(base + np.diag(var[i]), d[i])
        return out

    def t2_limits(self) -> np.ndarray:
        """Each class's T² limit (k,): the ``1 − alpha`` quantile of p(n−1)/(n−p)·F(p, n−p)."""
        check_is_fitted(self, "model_")
        return t2_limit(self.class_n_, float(self.alpha), self.class_mean_.shape[1])

    def unknown_status(self) -> str:
        """``"available"``, or ``"unavailable, needs N rows per class"`` when a class has fewer
        than :func:`unknown_rows_needed` rows (module docstring)."""
        check_is_fitted(self, "model_")
        needed = unknown_rows_needed(float(self.alpha))
        if int(self.class_n_.min()) >= needed:
            return "available"
        return f"unavailable, needs {needed} rows per class"

    def unknown(self, X: Any, X_std: Any = None) -> np.ndarray:
        """Boolean (n,): the rows outside every class's prediction region (module docstring)."""
        return (self.class_t2(X, X_std) > self.t2_limits()).all(axis=1)

    def _z(self, X: Any) -> np.ndarray:
        check_is_fitted(self, "model_")
        return (validate_X(self, X) - self.x_mean_) / self.x_scale_

    def predict(self, X: Any) -> np.ndarray:
        """The most probable class of each row (consistent with :meth:`predict_proba`)."""
        check_is_fitted(self, "model_")
        return self.classes_[np.argmax(self.predict_proba(X), axis=1)]

    def predict_proba(self, X: Any) -> np.ndarray:
        """Calibrated class probabilities (n, n_classes), columns in the order of ``classes_``."""
        Z = self._z(X)
        return self.model_.predict_proba(Z)

    def describe(self) -> str:
        """The chosen hyperparameters and class names."""
        check_is_fitted(self, "model_")
        return (
            f"RBF SVM, C={self.C_:.3g}, gamma={self.gamma_:.3g} (standardised λ, ω); "
            f"classes: {', '.join(map(str, self.classes_))}"
        )

    def to_state(self) -> dict[str, Any]:
        """Plain-data state: chosen hyperparameters and training data (labels as strings)."""
        check_is_fitted(self, "model_")
        if not all(isinstance(label, str) for label in self.labels_train_.tolist()):
            raise ModelFileError(
                "a model file stores class names as strings; fit the classifier on string "
                "labels (train_classifier converts them)"
            )
        return {
            "model": self.model_name,
            "C": self.C_,
            "gamma": self.gamma_,
            "X_train": self.X_train_.tolist(),
            "labels_train": self.labels_train_.tolist(),
            "unknown": {
                "rule": "hotelling-t2",
                "status": self.unknown_status(),
                "features": list(NOVELTY_FEATURES),
                "alpha": float(self.alpha),
                "classes": {
                    str(c): {"n": int(n), "mean": m.tolist(), "cov": v.tolist()}
                    for c, n, m, v in zip(
                        self.classes_,
                        self.class_n_,
                        self.class_mean_,
                        self.class_cov_,
                        strict=True,
                    )
                },
            },
        }

    @classmethod
    def from_state(cls, state: dict[str, Any]) -> LiquidClassifier:
        """Rebuild exactly by the deterministic refit with the stored C and gamma.

        The "unknown" rule's ``alpha`` and class statistics are the stored ones (they
        must match the training rows: a file whose statistics do not is refused); a
        file without them (format version ≤ 2) gets the rule at :data:`UNKNOWN_ALPHA`
        from its training rows.
        """
        labels = np.asarray(state["labels_train"], dtype=str)
        rule = state.get("unknown")
        alpha = UNKNOWN_ALPHA if rule is None else rule["alpha"]
        clf = cls(C=state["C"], gamma=state["gamma"], alpha=alpha).fit(state["X_train"], labels)
        if rule is not None and rule.get("status") not in (None, clf.unknown_status()):
            raise ModelFileError(
                f"unknown.status {rule['status']!r} does not match the training rows "
                f"({clf.unknown_status()!r})"
            )
        if rule is not None:
            stored = rule["classes"]
            if sorted(stored) != sorted(map(str, clf.classes_)):
                raise ModelFileError("unknown.classes must name the classes of labels_train")
            for j, c in enumerate(clf.classes_):
                entry = stored[str(c)]
                same = (
                    entry["n"] == clf.class_n_[j]
                    and np.allclose(entry["mean"], clf.class_mean_[j], rtol=1e-9, atol=1e-12)
                    and np.allclose(entry["cov"], clf.class_cov_[j], rtol=1e-9, atol=1e-12)
                )
                if not same:
                    raise ModelFileError(
                        f"unknown.classes[{c!r}] does not match the training rows of that class"
                    )
        return clf


def t2_limit(n: np.ndarray | float, alpha: float, p: int = 2) -> np.ndarray:
    """The T² limit of a class of ``n`` rows in ``p`` features at false-alarm rate ``alpha``:
    the ``1 − alpha`` quantile of p(n−1)/(n−p)·F(p, n−p) (inf for n ≤ p)."""
    n = np.asarray(n, dtype=float)
    with np.errstate(divide="ignore", invalid="ignore"):
        limit = p * (n - 1) / (n - p) * stats.f.ppf(1 - float(alpha), p, n - p)
    return np.where(n > p, limit, np.inf)


def unknown_rows_needed(alpha: float = UNKNOWN_ALPHA, p: int = 2) -> int:
    """Fewest rows per class for which the "unknown" rule is available (module docstring):
    the T² limit within :data:`UNKNOWN_REGION_FACTOR` of the χ²_p quantile (15 at 0.001)."""
    target = UNKNOWN_REGION_FACTOR * stats.chi2.ppf(1 - float(alpha), p)
    n = np.arange(p + 1, 10_000)
    return int(n[np.argmax(t2_limit(n, alpha, p) <= target)])


def novelty_features(X: np.ndarray) -> np.ndarray:
    """(n, 2) (λ, ω) → (log λ, ω), the features of the "unknown" rule (λ clipped > 0)."""
    z = np.array(X, dtype=float)
    z[:, 0] = np.log(np.maximum(z[:, 0], MIN_LOG_DECAY_RATE))
    return z

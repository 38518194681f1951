"""The GP regressor's own log marginal likelihood against scikit-learn's, and the fit it gives."""

from __future__ import annotations

import numpy as np
import pytest
from sklearn.gaussian_process import GaussianProcessRegressor
from sklearn.gaussian_process.kernels import RBF, ConstantKernel, WhiteKernel

import liquidtouch.models.regressors as regressors
from liquidtouch.models.gp_likelihood import LikelihoodOptimizer, log_marginal_likelihood
from liquidtouch.models.regressors import GP_JITTER, GPRegressor


def _kernel(dims: int):
    return ConstantKernel(1.0, (1e-2, 1e2)) * RBF([1.0] * dims, (0.3, 100.0)) + WhiteKernel(
        0.1, (1e-5, 1.0)
    )


@pytest.mark.parametrize("per_row", [False, True])
@pytest.mark.parametrize("dims", [1, 2, 3])
def test_value_and_gradient_equal_scikit_learn_s(dims, per_row) -> None:
    """The same value and gradient, with one jitter or each row's own noise on the diagonal."""
    rng = np.random.default_rng(dims)
    Z = rng.normal(size=(40, dims))
    r = np.sin(Z.sum(axis=1)) + rng.normal(0, 0.1, 40)
    diagonal = GP_JITTER + (rng.uniform(0.0, 0.2, 40) if per_row else 0.0)
    reference = GaussianProcessRegressor(_kernel(dims), optimizer=None, alpha=diagonal).fit(Z, r)
    steps = LikelihoodOptimizer(Z, r, diagonal).squared_steps
    for _ in range(20):
        theta = rng.uniform(reference.kernel_.bounds[:, 0], reference.kernel_.bounds[:, 1])
        expected, expected_gradient = reference.log_marginal_likelihood(theta, eval_gradient=True)
        value, gradient = log_marginal_likelihood(theta, steps, r, diagonal)
        assert value == pytest.approx(expected, rel=1e-9, abs=1e-9)
        np.testing.assert_allclose(gradient, expected_gradient, rtol=1e-6, atol=1e-8)


def test_a_kernel_that_is_not_positive_definite_gives_minus_infinity() -> None:
    Z = np.zeros((5, 1))  # five identical rows, no noise, no jitter: K = C · ones, singular
    steps = LikelihoodOptimizer(Z, np.ones(5), 0.0).squared_steps
    value, gradient = log_marginal_likelihood(
        np.log([1.0, 1.0, 1e-300]), steps, np.arange(5.0), 0.0
    )
    assert value == -np.inf and not gradient.any()


def test_the_fit_equals_the_one_scikit_learn_s_optimiser_gives(monkeypatch) -> None:
    """Same starts, same objective: the same hyperparameters and predictions to the
    optimiser's tolerance, on tables of 8 to 200 rows."""
    for seed in range(8):
        rng = np.random.default_rng(seed)
        n = int(rng.integers(8, 200))
        X = np.c_[rng.uniform(0.05, 3, n), rng.uniform(8, 20, n)]
        y = 40 - 1.5 * X[:, 1] + 3 * np.log(X[:, 0]) + rng.normal(0, [0.01, 0.3, 2][seed % 3], n)
        ours = GPRegressor(random_state=seed).fit(X, y)
        with monkeypatch.context() as patched:
            patched.setattr(regressors, "LikelihoodOptimizer", lambda Z, r, j: "fmin_l_bfgs_b")
            theirs = GPRegressor(random_state=seed).fit(X, y)
        Xq = np.c_[rng.uniform(0.05, 3, 50), rng.uniform(8, 20, 50)]
        np.testing.assert_allclose(ours.predict(Xq), theirs.predict(Xq), atol=1e-5 * np.std(y))
        assert ours.gp_.log_marginal_likelihood_value_ == pytest.approx(
            theirs.gp_.log_marginal_likelihood_value_, abs=1e-6
        )


def test_the_mean_is_scikit_learn_s_to_the_bit() -> None:
    rng = np.random.default_rng(3)
    for dims in (1, 2):
        X = rng.uniform(0, 5, (30, dims))
        model = GPRegressor().fit(X, np.sin(X).sum(axis=1) + rng.normal(0, 0.1, 30))
        Z = (rng.uniform(-1, 6, (200, dims)) - model.x_mean_) / model.x_scale_
        assert np.array_equal(model._gp_mean(Z), model.gp_.predict(Z))

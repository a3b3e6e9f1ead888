"""The base regressor evaluated by a compiled C loop equals the NumPy evaluation (symbolic.codegen.compiled_regressor)."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

import symbolic
from symbolic.identify.least_squares import _ols, _rank
from symbolic.identify.model import base_regressor
from symbolic.codegen.compiled import compiler

pytestmark = pytest.mark.skipif(compiler() is None, reason="needs a C compiler (gcc, cc or clang)")


def _model(name: str):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return symbolic.derive(symbolic.robots.load(name))


@pytest.mark.parametrize("name", ["puma560", "janot_branch", "emps"])
def test_compiled_base_regressor_equals_numpy(name: str) -> None:
    model = _model(name)
    rng = np.random.default_rng(3)
    q, qd, qdd = (rng.uniform(-2, 2, (257, model.n)) for _ in range(3))
    p = np.array(list(model.parameters.values())) * rng.uniform(0.5, 1.5, len(model.parameters))
    fast = base_regressor(model, p, compiled=True)(q, qd, qdd)
    slow = base_regressor(model, p, compiled=False)(q, qd, qdd)
    assert fast.shape == slow.shape == (257, model.n, slow.shape[2])
    # same straight-line program, same operation order up to the compiler's contraction: rounding only
    np.testing.assert_allclose(fast, slow, rtol=1e-12, atol=1e-12 * np.abs(slow).max())


def test_qr_least_squares_equals_the_svd_solution() -> None:
    """β̂, cond(W) and σ from the QR factor of [W y] equal the thin-SVD formulas (Gautier's IDIM-LS statistics)."""
    rng = np.random.default_rng(5)
    W = rng.normal(size=(4000, 9)) @ np.diag(np.logspace(0, 3, 9))  # noqa: N806
    y = W @ rng.normal(size=9) + rng.normal(scale=0.1, size=4000)
    beta, covariance, cond, sigma = _ols(y, W, tuple("abcdefghi"))
    U, s, Vt = np.linalg.svd(W, full_matrices=False)  # noqa: N806
    reference = Vt.T @ ((U.T @ y) / s)
    residual = y - W @ reference
    variance = residual @ residual / (4000 - 9)
    np.testing.assert_allclose(beta, reference, rtol=1e-10)
    np.testing.assert_allclose(covariance, (Vt.T / s**2) @ Vt * variance, rtol=1e-9)
    assert cond == pytest.approx(s[0] / s[-1], rel=1e-10)
    assert sigma == pytest.approx(np.sqrt(variance), rel=1e-10)
    assert _rank(W) == 9 and _rank(W[:, [0, 1, 1]]) == 2

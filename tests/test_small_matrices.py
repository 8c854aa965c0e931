"""The small dense kernels of core.small_matrices against numpy, Python and compiled alike."""

from __future__ import annotations

import numpy as np
import pytest

from radarslam.core.small_matrices import abt_plus_cdt_into, cholesky_into, hpht_plus, matmul_into, solve_spd


def _compiled():
    from radarslam.core.jit import compile_kernels
    from radarslam.core import small_matrices

    return compile_kernels(*small_matrices.KERNELS)


@pytest.mark.parametrize("n", [2, 3, 5])
def test_small_products_and_solves_match_numpy_python_and_compiled(n):
    """matmul_into, hpht_plus and abt_plus_cdt_into equal numpy's products to rounding;
    cholesky_into + solve_spd solve an SPD system to 1e-12 relative; the compiled forms equal the
    Python ones to the bit."""
    rng = np.random.default_rng(n)
    A = rng.normal(size=(n, 3))
    P = rng.normal(size=(3, 3))
    P = P @ P.T + np.eye(3)
    Rn = np.diag(rng.uniform(0.5, 2.0, n))
    HP = A @ P
    S = HP @ A.T + Rn
    B = rng.normal(size=(n, 4))
    K = _compiled()
    out = {}
    for name, (mm, hp, ch, so) in {"py": (matmul_into, hpht_plus, cholesky_into, solve_spd),
                                   "nb": (K["matmul_into"], K["hpht_plus"], K["cholesky_into"], K["solve_spd"])}.items():
        prod = mm(A, P, np.empty((n, 3)))
        Sy = np.empty((n, n))
        hp(prod, A, Rn, Sy)
        Y = so(ch(Sy, np.zeros((n, n))), B, np.empty((n, 4)))
        np.testing.assert_allclose(prod, HP, rtol=1e-13, atol=1e-13)
        np.testing.assert_allclose(Sy, S, rtol=1e-13, atol=1e-13)
        np.testing.assert_allclose(Y, np.linalg.solve(S, B), rtol=1e-12, atol=1e-12)
        out[name] = (prod, Sy, Y)
    F = rng.normal(size=(3, 3))
    G = rng.normal(size=(3, n))
    U = np.diag(rng.uniform(0.1, 1.0, n))
    pair = [kernel(F @ P, F, G @ U, G, np.empty((3, 3))) for kernel in (abt_plus_cdt_into, K["abt_plus_cdt_into"])]
    np.testing.assert_allclose(pair[0], F @ P @ F.T + G @ U @ G.T, rtol=1e-13, atol=1e-13)   # a propagation
    assert np.array_equal(pair[0], pair[1])
    for a, b in zip(out["py"], out["nb"]):
        assert np.array_equal(a, b)


def test_cholesky_of_an_indefinite_matrix_is_nan_not_a_wrong_number():
    """Negative control: a matrix with a negative eigenvalue gives a NaN factor, so a solve with it
    is NaN (view_update then leaves the shape unchanged) rather than a finite wrong answer."""
    A = np.array([[1.0, 2.0], [2.0, 1.0]])                  # eigenvalues 3 and -1
    L = cholesky_into(A, np.zeros((2, 2)))
    assert np.isnan(L[1, 1])
    assert np.isnan(solve_spd(L, np.ones((2, 1)), np.empty((2, 1)))).all()

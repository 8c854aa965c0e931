"""Products and solves of small dense matrices by loops (docs/architecture.md "Backends").

The partial view's shape update (:mod:`radarslam.extent.view_estimator`, a.12.7) and the fused
engine's prediction multiply and solve 2x2 to 5x5 matrices thousands of times per trial; numpy's
BLAS and LAPACK calls cost more than the arithmetic at that size, and each result would be a new
array. These kernels (:mod:`radarslam.core.jit`) write into arrays the caller holds, sum each entry
in index order (so the Python and compiled forms agree to the bit), and allocate nothing.
"""

from __future__ import annotations

import math

import numpy as np


def matmul_into(A: np.ndarray, B: np.ndarray, out: np.ndarray) -> np.ndarray:
    """``out = A B`` by loops (small matrices: no BLAS call), returned. A kernel."""
    for i in range(A.shape[0]):
        for j in range(B.shape[1]):
            acc = 0.0
            for k in range(A.shape[1]):
                acc += A[i, k] * B[k, j]
            out[i, j] = acc
    return out


def hpht_plus(HP: np.ndarray, H: np.ndarray, Rn: np.ndarray, Sy: np.ndarray) -> None:
    """``Sy = (H P) H^T + Rn`` in place, from ``HP = H P``. A kernel."""
    for i in range(HP.shape[0]):
        for j in range(H.shape[0]):
            acc = 0.0
            for k in range(H.shape[1]):
                acc += HP[i, k] * H[j, k]
            Sy[i, j] = acc + Rn[i, j]


def abt_plus_cdt_into(A: np.ndarray, B: np.ndarray, C: np.ndarray, D: np.ndarray, out: np.ndarray) -> np.ndarray:
    """``out = A B^T + C D^T`` (each product summed in index order, then the two added), returned:
    the two halves of a covariance propagation ``F P F^T + G U G^T`` from ``A = F P``, ``C = G U``,
    or of a Joseph update. A kernel."""
    for i in range(A.shape[0]):
        for j in range(B.shape[0]):
            s1 = 0.0
            for k in range(A.shape[1]):
                s1 += A[i, k] * B[j, k]
            s2 = 0.0
            for k in range(C.shape[1]):
                s2 += C[i, k] * D[j, k]
            out[i, j] = s1 + s2
    return out


def cholesky_into(A: np.ndarray, L: np.ndarray) -> np.ndarray:
    """The lower Cholesky factor of a small symmetric positive definite ``A (n, n)`` into ``L``
    (its upper triangle untouched); NaN on the diagonal where ``A`` is not positive definite.
    Returns ``L``. A kernel."""
    n = A.shape[0]
    for i in range(n):
        for j in range(i + 1):
            acc = A[i, j]
            for k in range(j):
                acc -= L[i, k] * L[j, k]
            if i == j:
                L[i, i] = math.sqrt(acc) if acc > 0.0 else math.nan
            else:
                L[i, j] = acc / L[j, j]
    return L


def solve_spd(L: np.ndarray, B: np.ndarray, Y: np.ndarray) -> np.ndarray:
    """``Y = A^-1 B`` from the Cholesky factor ``L`` of ``A`` (:func:`cholesky_into`), ``B (n, k)``
    and ``Y (n, k)`` given (no allocation). Returns ``Y``. A kernel."""
    n = L.shape[0]
    for c in range(B.shape[1]):
        for i in range(n):
            acc = B[i, c]
            for k in range(i):
                acc -= L[i, k] * Y[k, c]
            Y[i, c] = acc / L[i, i]
        for i in range(n - 1, -1, -1):
            acc = Y[i, c]
            for k in range(i + 1, n):
                acc -= L[k, i] * Y[k, c]
            Y[i, c] = acc / L[i, i]
    return Y


#: The kernels of this module.
KERNELS = (matmul_into, hpht_plus, abt_plus_cdt_into, cholesky_into, solve_spd)

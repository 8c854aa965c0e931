"""Reference linear algebra for the tests: general eigendecomposition-based square roots, eigenvalue
floors and a PSD check, independent of the closed-form 2 x 2 kernels of ``radarslam.extent._sym2``
that the package uses."""

from __future__ import annotations

import numpy as np

#: Eigenvalue clip used inside square roots (docs/method.md h.6).
SQRT_EIG_CLIP = 1e-12


def symmetrize(A: np.ndarray) -> np.ndarray:
    """``(A + A^T) / 2``."""
    return 0.5 * (A + A.T)


def spd_sqrt(A: np.ndarray, clip: float = SQRT_EIG_CLIP) -> np.ndarray:
    """Symmetric PSD square root ``U sqrt(L) U^T`` with eigenvalues clipped at ``clip`` (h.6)."""
    lam, U = np.linalg.eigh(symmetrize(A))
    return (U * np.sqrt(np.maximum(lam, clip))) @ U.T


def spd_inv_sqrt(A: np.ndarray, clip: float = SQRT_EIG_CLIP) -> np.ndarray:
    """Symmetric inverse square root ``U L^{-1/2} U^T`` with eigenvalues clipped at ``clip``."""
    lam, U = np.linalg.eigh(symmetrize(A))
    return (U / np.sqrt(np.maximum(lam, clip))) @ U.T


def floor_eigenvalues(A: np.ndarray, floor: float) -> np.ndarray:
    """Symmetrize ``A`` and raise its eigenvalues to at least ``floor``."""
    lam, U = np.linalg.eigh(symmetrize(A))
    if lam[0] >= floor:
        return symmetrize(A)
    return (U * np.maximum(lam, floor)) @ U.T


def is_psd(A: np.ndarray, tol: float = 1e-9) -> bool:
    """True when ``A`` is symmetric and its smallest eigenvalue is >= ``-tol * max(1, |A|)``."""
    scale = max(1.0, float(np.max(np.abs(A)))) if A.size else 1.0
    if not np.allclose(A, A.T, atol=tol * scale, rtol=0.0):
        return False
    return bool(np.linalg.eigvalsh(symmetrize(A))[0] >= -tol * scale) if A.size else True


def central_jacobian(fun, x0: np.ndarray, h: float) -> np.ndarray:
    """``d fun / d x`` at ``x0`` by central differences of step ``h`` (columns by coordinate)."""
    cols = []
    for j in range(x0.size):
        e = np.zeros_like(x0)
        e[j] = h
        cols.append((fun(x0 + e) - fun(x0 - e)) / (2 * h))
    return np.column_stack(cols)

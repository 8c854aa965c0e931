"""Argument checks for public boundaries.

These run once per public call, never inside an inner loop that has already validated its input.
"""

from __future__ import annotations

import numpy as np

from radarslam.core.errors import InputError


def _shape_str(shape: tuple[int | None, ...]) -> str:
    return "(" + ", ".join("N" if s is None else str(s) for s in shape) + ("," if len(shape) == 1 else "") + ")"


def as_array(
    name: str,
    value: object,
    shape: tuple[int | None, ...],
    *,
    finite: bool = True,
) -> np.ndarray:
    """Convert ``value`` to a float64 array of ``shape`` (``None`` = any length), or raise.

    Raises
    ------
    InputError
        Naming ``name``, the expected shape and the shape given, or the first non-finite entry.
    """
    try:
        arr = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise InputError(f"{name}: expected a float array of shape {_shape_str(shape)}, got {type(value).__name__} ({exc})") from None
    if arr.ndim != len(shape) or any(s is not None and s != a for s, a in zip(shape, arr.shape)):
        raise InputError(f"{name}: expected shape {_shape_str(shape)}, got {arr.shape}")
    if finite and arr.size and not np.all(np.isfinite(arr)):
        bad = np.argwhere(~np.isfinite(arr))[0]
        raise InputError(f"{name}: expected finite values, got {arr[tuple(bad)]} at index {tuple(int(i) for i in bad)}")
    return arr


def as_points(name: str, value: object) -> np.ndarray:
    """A finite ``(N, 2)`` float64 point set; ``N = 0`` is allowed."""
    arr = np.asarray(value, dtype=np.float64) if not isinstance(value, np.ndarray) else value
    if isinstance(arr, np.ndarray) and arr.ndim == 1 and arr.size == 0:
        return np.empty((0, 2))
    return as_array(name, arr, (None, 2))


def as_scalar(name: str, value: object, *, low: float | None = None, high: float | None = None,
              low_open: bool = False) -> float:
    """A finite float within ``[low, high]`` (``(low, high]`` when ``low_open``)."""
    try:
        x = float(value)  # type: ignore[arg-type]
    except (TypeError, ValueError):
        raise InputError(f"{name}: expected a finite number, got {value!r}") from None
    if not np.isfinite(x):
        raise InputError(f"{name}: expected a finite number, got {x}")
    if low is not None and (x < low or (low_open and x == low)):
        raise InputError(f"{name}: expected a value {'>' if low_open else '>='} {low}, got {x}")
    if high is not None and x > high:
        raise InputError(f"{name}: expected a value <= {high}, got {x}")
    return x


def as_spd(name: str, value: object, n: int, *, tol: float = 1e-9) -> np.ndarray:
    """A finite, symmetric positive semi-definite ``(n, n)`` matrix."""
    arr = as_array(name, value, (n, n))
    scale = max(1.0, float(np.max(np.abs(arr))))
    if np.max(np.abs(arr - arr.T)) > tol * scale:
        raise InputError(f"{name}: expected a symmetric matrix, got asymmetry {np.max(np.abs(arr - arr.T)):.3g}")
    lam = np.linalg.eigvalsh(arr)
    if lam[0] < -tol * scale:
        raise InputError(f"{name}: expected a positive semi-definite matrix, got smallest eigenvalue {lam[0]:.3g}")
    return arr

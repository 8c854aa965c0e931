"""The checks of an event's input that both drivers make before it reaches the filter (docs/architecture.md
"Bad input"): a number that must be finite, a scan's detections, and a state that must stay finite."""

from __future__ import annotations

import math

import numpy as np

from radarslam.core.errors import InputError
from radarslam.core.types import Scan
from radarslam.core.validation import as_array

__all__ = ["check_finite", "finite_number", "scan_polar"]


def finite_number(value, name: str) -> float:
    """``value`` as a finite float, or an :class:`InputError` naming ``name``."""
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise InputError(f"{name}: expected a finite number, got {value!r}") from None
    if not math.isfinite(v):
        raise InputError(f"{name}: expected a finite number, got {value!r}")
    return v


def check_finite(x: np.ndarray, P: np.ndarray, what: str) -> None:
    """Never hand back a non-finite state: name the input that produced one."""
    if not (np.all(np.isfinite(x)) and np.all(np.isfinite(P))):
        raise InputError(f"{what}: expected an input that keeps the state finite, got one that makes it non-finite")


def scan_polar(scan: Scan) -> np.ndarray:
    """The scan's detections as a checked ``(m, 2)`` float array (finite numbers, ranges >= 0)."""
    polar = scan.polar
    if np.size(polar) == 0:
        return np.empty((0, 2))
    polar = as_array("scan.polar", polar, (None, 2))
    if np.any(polar[:, 0] < 0):
        raise InputError(f"scan.polar: expected ranges >= 0, got min {polar[:, 0].min()}")
    return polar

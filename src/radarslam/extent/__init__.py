"""Elliptical landmark extents: ellipse <-> matrix, random-matrix (RMA) filter, EFA fit, GWD.

Public functions validate their input and call an unvalidated kernel of the same name with a
leading underscore (``_rm_update``, ``_rm_predict``, ``_fit_ellipse``, ...), which the SLAM loop
calls directly with trusted float64 arrays; the kernels' docstrings state their contracts.

:func:`gaussian_wasserstein_distance` and :func:`gaussian_wasserstein_distances` live in
:mod:`radarslam.metrics.gwd` and are re-exported here lazily, so that importing either package
first never forms an import cycle.
"""

from __future__ import annotations

from radarslam.extent.ellipse import ellipse_to_matrix, li_orientation, matrix_to_ellipse
from radarslam.extent.ellipse_fit import FIT_FAILED, fit_ellipse
from radarslam.extent.measurement import (
    W_MODES,
    converted_measurement_cov,
    converted_measurement_covs,
    select_scan_W,
)
from radarslam.extent.random_matrix import rm_predict, rm_update


__all__ = [
    "FIT_FAILED",
    "W_MODES",
    "converted_measurement_cov",
    "converted_measurement_covs",
    "ellipse_to_matrix",
    "fit_ellipse",
    "li_orientation",
    "matrix_to_ellipse",
    "rm_predict",
    "rm_update",
    "select_scan_W",
]

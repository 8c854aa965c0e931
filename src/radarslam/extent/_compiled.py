"""The extent step and the extent-aware sifting test compiled with numba (``filter.backend = "numba"``).

Built from the reference's own kernels, compiled as they are by
:func:`radarslam.core.jit.compile_kernels`: ``W`` of seed eq. (5) (:mod:`.measurement`), the
random-matrix prediction and update (:mod:`.random_matrix`, seed eqs. 8-20) and the EFA
(:mod:`.ellipse_fit`, d.3). Only the loops over landmarks, detections and landmarks are written
for numba: one call per scan instead of one Python call chain per landmark, and no
``(m, N, 2, 2)`` temporaries in the sifting test.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from radarslam.core.jit import compile_kernels
from radarslam.extent import (_sym2, buffering, ellipse, ellipse_fit, measurement, mem_ekf_kernels, partial_view,
                              partial_view_jac, random_matrix, rows, sifting, view_kernels, arc_kernels)

_K = compile_kernels(measurement._w_entries, measurement.max_trace_w_entries, measurement.scan_w_entries, random_matrix.rm_update_entries,
                     random_matrix.rm_predict_alpha, ellipse_fit.fit_entries, _sym2.spectral, _sym2.from_spectral,
                     _sym2.sqrt2, _sym2.inv_sqrt2, _sym2.floor2, _sym2.mean_and_scatter, *buffering.KERNELS,
                     *mem_ekf_kernels.KERNELS, ellipse._ellipse_to_matrix, *rows.KERNELS)
_w_entries = _K["_w_entries"]
_max_trace_w_entries = _K["max_trace_w_entries"]
scan_w_entries = _K["scan_w_entries"]
detections = _K["detections"]
_fit_entries = _K["fit_entries"]
#: The extent's buffering and initialisation (a.3) and the merge's outcome (c.9), for the fused engine.
buffer_and_fit = _K["buffer_and_fit"]
merge_outcome = _K["merge_outcome"]
buffered_scatter = _K["buffered_scatter"]
#: The extent step over array-held states (extent.rows), for the fused engine.
buffer_need = _K["buffer_need"]
initialise_rows = _K["initialise_rows"]
rma_efa_rows = _K["rma_efa_rows"]
sliding_efa_rows = _K["sliding_efa_rows"]
mem_ekf_initialise_rows = _K["mem_ekf_initialise_rows"]
mem_ekf_rows = _K["mem_ekf_rows"]
merge_rows = _K["merge_rows"]

#: The visible-arc kernels (docs/method.md a.9): a scan's widths of every landmark, and the trunk's diameter.
_A = compile_kernels(arc_kernels.arc_width_diameter, arc_kernels.gated_diameter, arc_kernels.arc_widths_rows,
                     rows.detections)
arc_widths_rows = _A["arc_widths_rows"]
gated_diameter = _A["gated_diameter"]

#: The literal and measurement contours of a.7.1, compiled as they are for the fused engine.
_S = compile_kernels(sifting.literal_inside, sifting.contour_inside)
literal_inside = _S["literal_inside"]
contour_inside = _S["contour_inside"]

#: The partial-view kernels (docs/method.md a.12), compiled as they are.
_PV = compile_kernels(*partial_view.KERNELS, *partial_view_jac.KERNELS, *view_kernels.KERNELS)
view_update = _PV["view_update"]
view_rows = _PV["view_rows"]
arc_moments = _PV["arc_moments"]
arc_mean_shape_jacobian = _PV["arc_mean_shape_jacobian"]
tangent_points = _PV["tangent_points"]
arc_rows = _PV["arc_rows"]
sift_spreads = _PV["sift_spreads"]
view_scan_data = _PV["view_scan_data"]
#: ``out = A B`` by loops for small matrices (core.small_matrices), also the fused prediction's product.
small_matmul = _PV["matmul_into"]
#: ``A B^T + C D^T`` by loops (core.small_matrices), the fused prediction's covariance.
abt_plus_cdt = _PV["abt_plus_cdt_into"]


@njit(cache=True)
def measurement_contour(points, polar, theta, pose_cov, R, centroids, spreads, centroid_covs, gate):  # pragma: no cover
    """The measurement contour of a.7.1 from the detections ``polar`` seen at heading ``theta``:
    their ``W`` of seed eq. (5) (:func:`radarslam.extent.measurement._w_entries`), then
    :func:`radarslam.extent.sifting.contour_inside`, both compiled as they are."""
    m = points.shape[0]
    p00, p01, p02 = pose_cov[0, 0], pose_cov[0, 1], pose_cov[0, 2]
    p11, p12, p22 = pose_cov[1, 1], pose_cov[1, 2], pose_cov[2, 2]
    q22 = p22 + R[1, 1]
    W = np.empty((m, 2, 2))
    for i in range(m):
        ang = theta + polar[i, 1]
        w00, w01, w11 = _w_entries(math.cos(ang), math.sin(ang), polar[i, 0], p00, p01, p02, p11, p12, q22,
                                   R[0, 0], R[0, 1])
        W[i, 0, 0], W[i, 0, 1], W[i, 1, 0], W[i, 1, 1] = w00, w01, w01, w11
    return contour_inside(points, W, centroids, spreads, centroid_covs, gate)


@njit(cache=True)
def arc_moments_many(d, X):  # pragma: no cover - compiled
    """:func:`radarslam.extent.partial_view.arc_moments` of every row: ``d (N, 2)`` sensor minus
    centroid, ``X (N, 2, 2)`` shapes; returns ``g (N, 2)``, ``G (N, 2, 2)`` and ``S (N, 2, 2)``
    (docs/method.md a.12)."""
    N = d.shape[0]
    g = np.empty((N, 2))
    G = np.empty((N, 2, 2))
    S = np.empty((N, 2, 2))
    for n in range(N):
        r = arc_moments(d[n, 0], d[n, 1], X[n, 0, 0], X[n, 0, 1], X[n, 1, 1])
        g[n, 0], g[n, 1] = r[0], r[1]
        G[n, 0, 0], G[n, 0, 1], G[n, 1, 0], G[n, 1, 1] = r[2], r[3], r[4], r[5]
        S[n, 0, 0], S[n, 0, 1], S[n, 1, 0], S[n, 1, 1] = r[6], r[7], r[7], r[8]
    return g, G, S

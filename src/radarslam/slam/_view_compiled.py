"""The partial-view kernels compiled with numba (:mod:`radarslam.slam.view_kernels`, with the arc
kernels of :mod:`radarslam.extent.partial_view` and :mod:`radarslam.extent.view_estimator` and the
batch noise of :mod:`radarslam.slam.ekf` they call, compiled as they are by
:func:`radarslam.core.jit.compile_kernels`; docs/method.md a.12). The fused engine
(:mod:`radarslam.slam.fused.view`) calls these.
"""

from __future__ import annotations

from radarslam.core.jit import compile_kernels
from radarslam.extent import partial_view, partial_view_jac, view_estimator
from radarslam.slam import ekf, view_kernels

_K = compile_kernels(*partial_view.KERNELS, *partial_view_jac.KERNELS, view_estimator.exp_sym2, view_estimator.arc_rows,
                     view_estimator.put_arc_row,
                     ekf.rotate_to_sensor, ekf.batch_noise, *view_kernels.KERNELS)
exp_sym2 = _K["exp_sym2"]
view_rows = _K["view_rows"]
view_xi_rows = _K["view_xi_rows"]
model_error_rows = _K["model_error_rows"]
exp_sym2_rows = _K["exp_sym2_rows"]
shape_error_rows = _K["shape_error_rows"]
polar_rows = _K["polar_rows"]
polar_row = _K["polar_row"]
#: ``Q_v + J P J^T`` of one landmark, in place (view_kernels._shape_error).
shape_error_one = _K["_shape_error"]
sensor_xy_rows = _K["sensor_xy_rows"]
innovation_cov = _K["innovation_cov"]
view_log_distance = _K["view_log_distance"]
log_distance_rows = _K["log_distance_rows"]
view_batch_noise = _K["view_batch_noise"]
corrected_centroid = _K["corrected_centroid"]
view_walk_rows = _K["view_walk_rows"]

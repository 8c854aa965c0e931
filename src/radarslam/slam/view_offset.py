"""The part of an object in view, centred anywhere on it (docs/method.md c.17): the factor
``offset_k`` by which the batch associators add a landmark's spread ``gamma_z X`` to the noise of
its detections' mean once, not divided by their number.

A radar sees a wall, a guard rail or a row of parked cars in part: the part inside its field of
view and range, on the side facing it. The mean of those detections is the centre of the *visible*
part, which slides along the object as the car passes; the batch update of a.7.3 part 3 treats it
as the object's centre up to the spread divided by the number of detections, so a few scans of a
long object seen in part pull the pose along the road. Under ``extent.view_offset = "uniform"``
the centre of the part in view is a point uniform over the object's ellipse, whose covariance is
``X / 4`` (c.17); it is the same whichever detections are seen, so it is added once:

    noise_j = (Rot(-theta) gamma_z X_j Rot(-theta)^T + R_xy) / m + Rot(-theta) X_j / 4 Rot(-theta)^T,

``offset_k = 1 / (4 gamma_z)`` times the spread. Along a 40 m rail the centroid's std becomes 10 m
(it measures the rail's offset across the road, not where along it the car is); across it, a quarter
of the rail's width.
"""

from __future__ import annotations

from radarslam.core.errors import ConfigError

__all__ = ["BATCH_ASSOCIATORS", "view_offset_k"]

#: The associators whose update fuses a landmark's detections into their mean (a.7.3 part 3).
BATCH_ASSOCIATORS = ("batch", "batch-joint")


def view_offset_k(config, partial_view: bool) -> float:
    """``offset_k`` of ``config`` (an ``EstimatorConfig``): 0 under ``extent.view_offset = "none"``;
    one-line :class:`ConfigError` where the term has no place (no extents in the SLAM, an associator
    that does not fuse a landmark's detections, or the partial-view model, a.12, which predicts
    where the part in view is centred instead)."""
    ec = config.extent
    if ec.view_offset == "none":
        return 0.0
    assoc = config.landmarks.associator
    if not (ec.use_in_slam and ec.inflate_noise):
        raise ConfigError("extent.view_offset: 'uniform' needs the extents in the SLAM (extent.use_in_slam and "
                          f"extent.inflate_noise true), got use_in_slam={ec.use_in_slam}, "
                          f"inflate_noise={ec.inflate_noise}")
    if assoc not in BATCH_ASSOCIATORS:
        raise ConfigError(f"extent.view_offset: 'uniform' needs landmarks.associator in {list(BATCH_ASSOCIATORS)} "
                          f"(one mean per landmark and scan, a.7.3), got {assoc!r}")
    if partial_view:
        raise ConfigError("extent.view_offset: 'uniform' is for the full view; the partial-view model "
                          "(extent.view_model, a.12) predicts the part in view itself, got both")
    return 0.25 / ec.spread_factor

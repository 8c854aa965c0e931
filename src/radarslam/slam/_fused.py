"""The fused engine by its former module path: the names of :mod:`radarslam.slam.fused` (a whole
event stream through EKF-SLAM in one compiled call, ``filter.fused``), re-exported.

Patch :mod:`radarslam.slam.fused.plan` (not this module) to wrap the parts :func:`run` calls.
"""

from radarslam.slam.fused import (
    BAD_PREDICTION,
    BAD_SCAN,
    OK,
    FusedParams,
    Noise,
    Stream,
    _parameters,
    _stream_arrays,
    run,
    run_stream,
)
from radarslam.slam.fused import why_not as _plan_why_not

__all__ = ["BAD_PREDICTION", "BAD_SCAN", "OK", "FusedParams", "Noise", "Stream", "run", "run_stream", "why_not",
           "_parameters", "_stream_arrays"]


def why_not(slam, events=None) -> str | None:
    """:func:`radarslam.slam.fused.why_not`, and the options the fused engine does not carry:
    heteroscedastic turn noise (c.11.8) and correlated measurement errors (c.11.9)."""
    f = slam.config.filter
    if f.turn_noise_gain != 0:
        return "filter.turn_noise_gain (turn-dependent odometry noise, docs/method.md c.11.8)"
    if f.measurement_corr_scans != 1:
        return "filter.measurement_corr_scans (correlated measurement errors, docs/method.md c.11.9)"
    return _plan_why_not(slam, events)

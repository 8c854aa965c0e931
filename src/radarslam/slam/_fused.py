"""The fused engine by its former module path: the names of :mod:`radarslam.slam.fused` (a whole
event stream through EKF-SLAM compiled, ``filter.fused``), re-exported.

Patch :mod:`radarslam.slam.fused.plan` (not this module) to wrap the parts :func:`run` calls.
"""

from radarslam.slam.fused import (
    BAD_PREDICTION,
    BAD_SCAN,
    DEFAULT,
    OK,
    Family,
    FusedParams,
    Noise,
    Stream,
    _parameters,
    _stream_arrays,
    engine,
    family,
    run,
    run_stream,
)

__all__ = ["BAD_PREDICTION", "BAD_SCAN", "DEFAULT", "OK", "Family", "FusedParams", "Noise", "Stream", "engine",
           "family", "run", "run_stream", "_parameters", "_stream_arrays"]


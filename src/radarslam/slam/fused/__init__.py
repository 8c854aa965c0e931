"""The fused engine: the one implementation of the filter's steps (docs/method.md a.8, c.2-c.17), a whole
event stream through EKF-SLAM in compiled calls over consecutive parts of it, the filter's state carried from
each to the next, or one event at a time (:mod:`.online`, what :class:`~radarslam.slam.filter.EkfSlam` runs).

The landmark records are held in arrays (ids, creation scans, M/N windows, extent states and their
buffers). The steps, in order: predict (c.2); sift (c.3, a.7.1); associate and update (c.4,
a.7.2-a.7.3); M/N windows and removal (c.5); extent step (a.3-a.5); cluster (c.6); alpha test; Rule 1 /
Rule 2 and augmentation (c.7-c.8); merge (c.9). The same code runs in three forms (:func:`~.engine.form`):
compiled, its steps as Python over the compiled kernels (``filter.fused`` false, a component of the
user's own, :mod:`.own`), or all of it as Python (``filter.backend`` python, the reference the compiled
form is checked against: ``tests/test_engine_forms.py`` and the golden runs).

Modules: :mod:`.storage` (the records as arrays: growth, removal, the record after a scan),
:mod:`.tracking` (steps 1-5), :mod:`.extent` (step 6), :mod:`.mapping` (steps 7-10), :mod:`.gate`
(the Doppler gate), :mod:`.bias` (the prediction with odometry-bias states), :mod:`.view` (the partial view,
docs/method.md a.12), :mod:`.engine` (:func:`run_stream`,
the loop of named steps, compiled once per :class:`~.engine.Family` of configurations: :func:`engine`),
:mod:`.plan` (the Python side: the parameters by name and the family, the stream as
arrays, :func:`run`).
"""

from radarslam.slam.fused.engine import BAD_PREDICTION, BAD_SCAN, DEFAULT, OK, Family, engine, run_stream
from radarslam.slam.fused.plan import FusedParams, Noise, Stream, _parameters, _stream_arrays, family, run

__all__ = ["BAD_PREDICTION", "BAD_SCAN", "DEFAULT", "OK", "Family", "FusedParams", "Noise", "Stream", "engine",
           "family", "run", "run_stream", "_parameters", "_stream_arrays"]

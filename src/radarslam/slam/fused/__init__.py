"""The fused engine: a whole event stream through EKF-SLAM in compiled code (``filter.fused``), a few
compiled calls over consecutive parts of it, the filter's state carried from each to the next.

:class:`~radarslam.slam.filter.EkfSlam` runs docs/method.md a.8 as a dozen Python calls per scan,
each cheap, together ~0.4 ms a scan: the orchestration, not the arithmetic, is the cost of a
car-park trial. For the built-in components (unicycle or Ackermann motion, or Doppler and gyro
odometry, the Doppler gate, range-azimuth radar or laser, the nearest-neighbour, batch, batch-joint
or JCBB associator, the RMA/EFA, visible-arc or MEM-EKF* estimator, the partial-view model with its
estimator and associators, DBSCAN, the standard or first-estimates Jacobians, the odometry-bias
states: every shipped profile, the car parks and both Victoria Park modes) this package runs the
same steps over the whole stream inside numba, with the landmark records held in arrays (ids,
creation scans, M/N windows, extent states and their buffers) instead of Python objects, and records what
:func:`radarslam.slam.driver.run_filter` records after every scan.

It has no maths of its own. Every step calls the compiled kernels the numba backend uses
(:mod:`radarslam.slam._numba` for association and the Joseph update, :mod:`radarslam.extent._compiled`
for the contour test, the RM step and the EFA, :mod:`radarslam.landmarks._compiled` for DBSCAN);
what is written here is the bookkeeping between them, in the orchestrator's order: predict (c.2);
sift (c.3, a.7.1); associate and update (c.4, a.7.2-a.7.3); M/N windows and removal (c.5); extent
step (a.3-a.5); cluster (c.6); alpha test; Rule 1 / Rule 2 and augmentation (c.7-c.8); merge
(c.9). The orchestrator remains the reference and the place for other components:
:func:`why_not` says which configurations this engine covers and why not, and
``tests/test_fused.py`` checks that both give the same associations, landmark ids and states (to
rounding) on whole runs.

Modules: :mod:`.storage` (the records as arrays: growth, removal, the record after a scan),
:mod:`.tracking` (steps 1-5), :mod:`.extent` (step 6), :mod:`.mapping` (steps 7-10), :mod:`.gate`
(the Doppler gate), :mod:`.bias` (the prediction with odometry-bias states), :mod:`.view` (the partial view,
docs/method.md a.12), :mod:`.engine` (:func:`run_stream`,
the loop of named steps, compiled once per :class:`~.engine.Family` of configurations: :func:`engine`),
:mod:`.plan` (the Python side: :func:`why_not`, the parameters by name and the family, the stream as
arrays, :func:`run`).
"""

from radarslam.slam.fused.engine import BAD_PREDICTION, BAD_SCAN, DEFAULT, OK, Family, engine, run_stream
from radarslam.slam.fused.plan import FusedParams, Noise, Stream, _parameters, _stream_arrays, family, run, why_not

__all__ = ["BAD_PREDICTION", "BAD_SCAN", "DEFAULT", "OK", "Family", "FusedParams", "Noise", "Stream", "engine",
           "family", "run", "run_stream", "why_not", "_parameters", "_stream_arrays"]

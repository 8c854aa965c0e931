"""radarslam: radar EKF-SLAM with extended (elliptical) landmarks.

Sub-packages, dependencies pointing one way
(``cli -> experiments -> (simulation | slam | landmarks | extent | metrics) -> models -> core``):

- :mod:`radarslam.core`        angles, linear algebra, validation, event types
- :mod:`radarslam.models`      motion (odometry) and range-azimuth radar models with Jacobians
- :mod:`radarslam.slam`        EKF-SLAM maths, the fused engine and the :class:`~radarslam.slam.filter.EkfSlam` filter
- :mod:`radarslam.landmarks`   sifting, log-distance association, DBSCAN, confirmation, M/N, merging
- :mod:`radarslam.extent`      random-matrix (RMA) and ellipse-fitting (EFA) extents, GWD
- :mod:`radarslam.simulation`  the car park of the APSIPA / seed papers
- :mod:`radarslam.metrics`     pose errors, landmark-management metrics, NEES
- :mod:`radarslam.experiments` single runs and Monte Carlo
"""

from radarslam.core import numba_cache as _numba_cache
from radarslam.core.errors import ConfigError, InputError, RadarSlamError

_numba_cache.refresh()

__version__ = "0.1.0"

__all__ = ["ConfigError", "InputError", "RadarSlamError", "__version__"]

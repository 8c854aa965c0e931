"""The Victoria Park dataset (Guivant & Nebot, ACFR, run "aa3") as one event stream.

Reads the directory documented in ``shared/data/victoria_park/SOURCE.md``:

============================================  ===========================================================
``victoria_park_ascii_LASER.npz`` (preferred)  ``LASER`` (N, 361) uint16 cm, ``TLsr`` (N,) s: raw laser scans
``victoria_park_ascii.zip`` (fallback)         member ``LASER.txt``: N records of ``t (s)`` + 361 ranges (m)
``aa3_dr.mat``                                 ``time`` (ms), ``speed`` (m/s, rear-left wheel), ``steering`` (rad)
``aa3_gpsx.mat``                               ``timeGps`` (ms), ``La_m``, ``Lo_m`` (m)
``lidar_measurements.mat`` (``trees=True``)     ACFR tree detections: ranges, bearings, diameters (7248, 18)
``pptacher_aa3_lsr2_TLsr_only.h5`` (optional)  the full original laser time vector (ms); needs h5py
============================================  ===========================================================

Conventions (all checked against the data; see the tests and the module's notes below)
--------------------------------------------------------------------------------------
- **One time base**: seconds of the ASCII export, ``t = (MAT ms - 20967) / 1000``. The laser times
  in the npz/zip are already on it; the MAT times are converted.
- **Bearing**: beam ``k`` (0-based) points at ``k * 0.5 deg`` in the laser frame (ACFR ``info.txt``:
  ``A_k = (k - 1) / 2`` deg, 1-based), so 90 deg is straight ahead, and the detection bearing is
  ``k * 0.5 deg - 90 deg``, counter-clockwise positive: beam 0 looks RIGHT (-pi/2), beam 360 LEFT
  (+pi/2). Evidence: with this sign, ACFR's tree detections of consecutive scans, placed in the
  world by dead reckoning, land on each other (median 0.07 m over the first 3000 scans, trees
  within 20 m); with the mirrored sign they do not (0.51 m).
- **GPS frame**: ``x = Lo_m`` (east), ``y = La_m`` (north), as ACFR plots it. Dead reckoning with
  positive steering turning LEFT fits this track by a proper rotation (1.5 m RMS over the first
  2 minutes) and not by a reflection (14.5 m).
- **Scan index**: ``Scan.index`` is the 0-based row of the scan in the original ``aa3_lsr2.mat``, which
  is also the row of ``lidar_measurements.mat`` (checked: the tree ranges fit the raw beams of the
  same row to 1 cm in 99.5% of the detections, and no other row offset does).

Detections and the noise model
------------------------------
A beam is a detection when ``min_range <= range < max_range``. Values of 80 m and more are the
LMS's "no return" and status codes (8183, 8187, 8189, 8191 cm; 83% of all beams).

- ``max_range = 30 m``: beyond it the beam spacing (0.26 m at 30 m) exceeds the median trunk
  diameter (0.42 m per ACFR's detector gives 1-2 beams), so a trunk's extent is not observable, and
  returns thin out sharply (the data hold 100k returns in 20-30 m, 32k in 30-40 m, 10k beyond 40 m).
  71% of ACFR's tree detections lie within 30 m.
- ``min_range = 1 m``: beams 0-12 (the rightmost 6 deg) return 0.82-0.95 m in every scan: that is
  the vehicle's own body (the laser sits at the left-front corner). Only 27 returns are shorter.

See :data:`NOISE` for the suggested measurement noise.

Stream
------
``events`` merges both streams in time order, odometry first on ties (``t_odo <= t_scan``). Each DR
sample ``k`` whose time lies in ``(t_first_scan, t_last_scan]`` becomes ``Odometry(t_k, t_k - t_{k-1},
[v_e_k, alpha_k])``: the reading at the end of the 25 ms interval, applied over it. The very first
DR sample (no predecessor) is skipped. A window (``first_scan``, ``n_scans``) gives exactly the
corresponding slice of the full stream.

Modules
-------
:mod:`.records` (file names, time base, beams, the published protocol; the records a load
returns), :mod:`.files` (the file readers), :mod:`.stream` (:func:`load_victoria_park`: options,
time alignment, window, detections, events). Every name is importable from here.
"""

from radarslam.io.datasets.victoria_park.files import ODOMETRY_GAP_S
from radarslam.io.datasets.victoria_park.records import (
    BEAM_STEP,
    FILE_DR,
    FILE_GPS,
    FILE_NPZ,
    FILE_TLSR,
    FILE_TREES,
    FILE_ZIP,
    INPUT_PROFILES,
    INPUTS,
    MAT_EPOCH_MS,
    MAX_CODE_CM,
    N_BEAMS,
    NO_RETURN_M,
    NOISE,
    PUBLISHED_START,
    PUBLISHED_TOLERANCE_S,
    TIME_MATCH_S,
    VEHICLE,
    ZIP_MEMBER,
    DeadReckoning,
    GpsFixes,
    NoiseModel,
    TreeDetections,
    VictoriaParkData,
)
from radarslam.io.datasets.victoria_park.stream import load_victoria_park

__all__ = ["INPUT_PROFILES", "NOISE", "VEHICLE", "DeadReckoning", "GpsFixes", "NoiseModel", "TreeDetections",
           "VictoriaParkData", "load_victoria_park"]

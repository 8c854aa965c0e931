"""The time-ordered event stream every estimator consumes.

The simulator and every dataset loader produce the same two event types, so the filter never
knows where its data came from:

- :class:`Odometry`: a control reading that moves the platform over ``dt`` seconds;
- :class:`Scan`: one radar (or laser) scan of range-azimuth detections.

The ground truth is never inside the stream; it travels separately for evaluation.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from radarslam.core.errors import InputError
from radarslam.core.mounting import Mounting
from radarslam.core.validation import as_array


@dataclass(frozen=True, slots=True)
class Odometry:
    """An odometer reading applied over ``dt`` seconds, ending at time ``t``.

    Attributes
    ----------
    t : float
        Time at the end of the interval (s).
    dt : float
        Length of the interval (s), > 0.
    control : ndarray, shape (2,)
        Model-specific control; for the car park's unicycle model ``[v (m/s), psi (rad/s)]``.
    gyro_rad_s : float or None
        A gyro's mean yaw rate over the interval (rad/s), or None without a gyro (the simulator
        draws one with ``radar.doppler`` on; docs/method.md c.10.5).
    """

    t: float
    dt: float
    control: np.ndarray
    gyro_rad_s: float | None = None

    @classmethod
    def checked(cls, t: float, dt: float, control: object) -> "Odometry":
        """Build with validation (finite values, ``dt > 0``, ``control`` of shape (2,))."""
        if not (np.isfinite(t) and np.isfinite(dt) and dt > 0):
            raise InputError(f"odometry: expected finite t and dt > 0, got t={t!r}, dt={dt!r}")
        return cls(float(t), float(dt), as_array("odometry.control", control, (2,)))


def Sensor(x: float, y: float, yaw: float, max_range_m: float | None = None, fov_rad: float | None = None,
           sensor_id: int = 0) -> Mounting:
    """The radar that made a scan, as the one mounting type :class:`~radarslam.core.mounting.Mounting`
    (``Scan.sensor``, docs/method.md c.13). ``Sensor`` was a type of its own with the same fields; this
    is its constructor, kept for its argument order (``x``, ``y`` m, ``yaw`` rad, then the range and
    full opening angle of the M/N view test, None: ``filter.max_range_m``, ``filter.field_of_view_deg``,
    and the id the recording gave it)."""
    return Mounting(x, y, yaw, sensor_id=sensor_id, max_range_m=max_range_m, fov_rad=fov_rad)


@dataclass(frozen=True, slots=True)
class Scan:
    """One scan of range-azimuth detections.

    Attributes
    ----------
    t : float
        Scan time (s).
    index : int
        Scan number ``k`` (1-based in the car park).
    polar : ndarray, shape (m, 2)
        Detections ``[range (m), azimuth (rad)]``, azimuth relative to the heading; ``m`` may be 0.
    channels : dict of str to ndarray of shape (m,), optional
        What a recording carries per detection besides range and azimuth, passed through and not
        used by the filter yet (docs/recordings.md "What reaches the filter"): ``doppler_mps``
        (radial velocity in the sensor frame, positive receding), ``rcs`` (rcs or intensity, as
        recorded), ``sensor_id`` and ``z_m`` (height in the sensor frame, 3-D radars). ``None``
        for the simulator.
    ego : EgoVelocity or None
        The platform's velocity measured outside the filter (:class:`radarslam.models.doppler.EgoVelocity`
        with ``v`` (2,) forward and lateral m/s in the levelled platform frame and its ``cov``): a 3-D
        recording's Doppler fit (docs/method.md c.10.6). ``filter.odometry`` "doppler" / "both" then
        use it instead of fitting the scan's own azimuths (c.10.5). ``None``: the filter fits.
    sensor : Mounting or None
        The radar that made the scan (:class:`~radarslam.core.mounting.Mounting`: its mounting and
        view), its ``polar`` (and Doppler) then in THAT radar's frame: the filter measures from the
        sensor's pose (docs/method.md c.13). ``None``: the detections are about the platform origin
        along the heading (the simulator, a radar at the axle).
    """

    t: float
    index: int
    polar: np.ndarray
    channels: dict | None = None
    ego: object | None = None
    sensor: Mounting | None = None

    @classmethod
    def checked(cls, t: float, index: int, polar: object) -> "Scan":
        """Build with validation: finite ``(m, 2)`` detections with non-negative ranges."""
        if not np.isfinite(t):
            raise InputError(f"scan.t: expected a finite time, got {t!r}")
        arr = np.asarray(polar, dtype=np.float64)
        if arr.size == 0:
            return cls(float(t), int(index), np.empty((0, 2)))
        arr = as_array("scan.polar", arr, (None, 2))
        if np.any(arr[:, 0] < 0):
            raise InputError(f"scan.polar: expected ranges >= 0, got min {arr[:, 0].min()}")
        return cls(float(t), int(index), arr)


Event = Odometry | Scan

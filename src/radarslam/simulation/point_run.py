"""A synthetic run of point landmarks with systematic odometry errors (docs/method.md c.11.4).

The platform moves by a motion model (the unicycle, the Ackermann car or any model with an
``input_bias``) under its true input ``u``; the odometer reports the input that the model's bias
correction maps back to the truth, plus white noise: with the true bias states
``b = [eps, delta]`` and the correction ``c(., b)`` of :class:`~radarslam.models.input_bias.InputBias`,

    u_meas = c^{-1}(u, b) + eta,   eta ~ N(0, diag(input_std^2)),

i.e. a speed reading ``(1 + eps)`` times too small and a turning input ``delta`` too small. With a
thrust-angle state (``spec.thrust``, the last entry ``beta`` of ``b``, c.11.12) the platform's
position increment is turned by ``beta`` from what the model's step gives (a car whose rear axle
moves at ``beta`` from its heading); the odometer does not see it. This is
exactly the filter's model of c.11, so a filter with the bias states is consistent on it and one
without them is not. Every ``scan_every`` odometry steps the sensor at the pose measures the range and
bearing of each landmark within ``[min_range, max_range]`` and the field of view, with noise ``N(0, diag(range_std^2,
bearing_std^2))``: one detection per landmark and scan, as ACFR's tree detections of Victoria Park.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from radarslam.core.angles import wrap_pi
from radarslam.core.errors import InputError
from radarslam.core.types import Odometry, Scan
from radarslam.slam.bias import turned_step

__all__ = ["PointRun", "simulate_point_run", "uncorrect"]


@dataclass(frozen=True)
class PointRun:
    """The events (odometry, then a scan every ``scan_every`` steps) and the truth at the scans."""

    events: list
    scan_poses: np.ndarray   # (S, 3) true pose at each scan
    landmarks: np.ndarray    # (L, 2)
    bias: np.ndarray         # (dim,) the true bias states, e.g. [eps, delta]


def uncorrect(spec, u: np.ndarray, b: np.ndarray) -> np.ndarray:
    """``c^{-1}(u, b)``: the reading whose bias correction (``spec.correct``) is ``u``."""
    return spec.uncorrect(u, b)


def simulate_point_run(model, controls: np.ndarray, dt: float, landmarks: np.ndarray, bias, rng: np.random.Generator,
                       *, initial_pose=(0.0, 0.0, 0.0), input_std=(0.05, 0.01), range_std: float = 0.1,
                       bearing_std: float = math.radians(1.0), min_range: float = 1.0, max_range: float = 30.0,
                       field_of_view: float = math.pi, scan_every: int = 4, spec=None) -> PointRun:
    """Drive ``model`` with ``controls (K, m)`` (true inputs, one per step of ``dt`` s) among
    ``landmarks (L, 2)`` and return the odometry and scans of the module docstring.

    Draws from ``rng`` in a fixed order: per step the odometer noise, then at a scan its detections'
    noise. ``spec``: the bias correction the odometer errs by (default the model's ``input_bias``;
    ``model.input_bias.with_turn("scale")`` for a turn-scale error, c.11.8). Raises :class:`InputError`
    for a model without ``input_bias`` or mismatched shapes.
    """
    spec = spec if spec is not None else getattr(model, "input_bias", None)
    if spec is None:
        raise InputError(f"model: expected a motion model with an input_bias, got {model!r}")
    controls = np.asarray(controls, dtype=float)
    std = np.asarray(input_std, dtype=float)
    if controls.ndim != 2 or std.shape != (controls.shape[1],):
        raise InputError(f"controls, input_std: expected shapes (K, m) and (m,), got {controls.shape} and {std.shape}")
    b = np.asarray(bias, dtype=float)
    pose = np.array(initial_pose, dtype=float)
    events, scan_poses = [], []
    for k, u in enumerate(controls):
        if k % scan_every == 0:
            events.append(_scan(pose, landmarks, rng, k // scan_every, k * dt, range_std, bearing_std,
                                (min_range, max_range), field_of_view))
            scan_poses.append(pose.copy())
        reading = uncorrect(spec, u, b) + rng.standard_normal(std.shape[0]) * std
        events.append(Odometry(t=(k + 1) * dt, dt=dt, control=reading))
        nxt = model.step(pose, u, dt)
        if spec.thrust:                                     # c.11.12: the increment at beta from the step's
            nxt = turned_step(pose, nxt, b[-1])
        pose = nxt
    return PointRun(events, np.array(scan_poses), np.asarray(landmarks, dtype=float), b)


def _scan(pose, landmarks, rng, k, t, range_std, bearing_std, ranges, field_of_view) -> Scan:
    d = landmarks - pose[:2]
    r = np.hypot(d[:, 0], d[:, 1])
    phi = wrap_pi(np.arctan2(d[:, 1], d[:, 0]) - pose[2])
    seen = (r >= ranges[0]) & (r <= ranges[1]) & (np.abs(phi) <= 0.5 * field_of_view)
    noise = rng.standard_normal((int(seen.sum()), 2)) * [range_std, bearing_std]
    polar = np.column_stack([r[seen], phi[seen]]) + noise
    return Scan(t=t, index=k, polar=polar)

"""The Doppler gate's classification (c.10.4) and Doppler odometry's fits (c.10.5) of a whole stream
in one compiled call (:func:`~radarslam.models._doppler_compiled.classify_stream`, ``fit_stream``),
for the fused engine's stream (:func:`radarslam.slam.fused.plan._stream_arrays`): both depend on
the scans alone, and each draws from its own generator in scan order as the per-scan calls
(:meth:`DopplerGate.classify`, :meth:`DopplerOdometry.fit`) do, so the results are theirs
(tests/test_fused.py). A stream whose scans are not all plain (a finite float ``(m, 2)`` polar
array with ranges >= 0, a ``doppler_mps`` channel of ``m`` finite values, no ``Scan.ego``) gets
None: the per-scan calls then run, and raise the filter's errors in order.
"""

from __future__ import annotations

import numpy as np

from radarslam.models import _doppler_compiled as _C
from radarslam.models.doppler import EgoVelocity, chi2_quantile
from radarslam.slam.doppler_gate import MIN_INLIER_FRACTION, _platform_xy


def _plain(events):
    """``(polar (M, 2), off (S + 1,), doppler (M,))`` of the stream's scans, or None (module docstring)."""
    from radarslam.core.types import Scan

    polars, dops = [], []
    for ev in events:
        if not isinstance(ev, Scan):
            continue
        p, ch = ev.polar, ev.channels or {}
        if not (type(p) is np.ndarray and p.dtype == np.float64 and p.ndim == 2 and p.shape[1] == 2) \
                or ev.ego is not None or "doppler_mps" not in ch:
            return None
        d = np.asarray(ch["doppler_mps"], dtype=float)
        if d.shape != (p.shape[0],):
            return None
        polars.append(p)
        dops.append(d)
    if not polars:
        return None
    polar, dop = np.concatenate(polars), np.concatenate(dops)
    if not (np.isfinite(polar).all() and (polar[:, 0] >= 0).all() and np.isfinite(dop).all()):
        return None
    off = np.zeros(len(polars) + 1, dtype=np.int64)
    off[1:] = np.cumsum([p.shape[0] for p in polars])
    return np.ascontiguousarray(polar), off, np.ascontiguousarray(dop)


def _egos(off, v, cov, inl, sigma, stat, rest, valid):
    """One :class:`EgoVelocity` per scan of the stream outputs."""
    return [EgoVelocity(v[s], cov[s], inl[off[s]:off[s + 1]], float(sigma[s]), float(stat[s]), bool(rest[s]),
                        bool(valid[s])) for s in range(off.shape[0] - 1)]


def gate_stream(events, gate):
    """:meth:`DopplerGate.classify` of each scan, in order, or None (module docstring)."""
    plain = _plain(events)
    if plain is None:
        return None
    polar, off, dop = plain
    f = gate.f
    q_zero, q_gate, radius, q_one, q_two = gate.quantiles()
    v, cov, inl, sigma, stat, rest, valid, bad, objects, tested = _C.classify_stream(
        polar, off, dop, gate.mounting.as_array(), gate.rng, int(f.doppler_iterations), float(f.doppler_threshold_mps),
        float(f.doppler_std_floor_mps), MIN_INLIER_FRACTION, np.array([q_zero, q_gate, q_one, q_two]), radius)
    xy = _platform_xy(polar[objects])                       # the moving objects' detections, scan by scan
    xy_off = np.concatenate([[0], np.cumsum(objects)])[off]
    rows = np.arange(polar.shape[0]) - np.repeat(off[:-1], np.diff(off))
    out = []
    for s, ego in enumerate(_egos(off, v, cov, inl, sigma, stat, rest, valid)):
        a, b = off[s], off[s + 1]
        seen = xy[xy_off[s]:xy_off[s + 1]] if tested[s] else None
        out.append((rows[a:b][~bad[a:b]], rows[a:b][bad[a:b]], ego, seen))
    return out


def odometry_stream(events, src):
    """The :class:`EgoVelocity` that :meth:`DopplerOdometry.fit` fits to each scan, in order, or None."""
    plain = _plain(events)
    if plain is None:
        return None
    polar, off, dop = plain
    f = src.f
    out = _C.fit_stream(polar, off, dop, src.mount.as_array(), src.rng, int(f.doppler_iterations),
                        float(f.doppler_threshold_mps), float(f.doppler_std_floor_mps), MIN_INLIER_FRACTION,
                        chi2_quantile(f.zero_velocity_probability, 2))
    return _egos(off, *out)

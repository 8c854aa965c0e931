"""The visible arc's kernels (docs/method.md a.10): a trunk's diameter from the angular width of its
returns, per landmark and scan, and the gated mean over scans; compiled by :mod:`._compiled`, the
class of :mod:`.visible_arc` calls them."""

from __future__ import annotations

import math

import numpy as np

from radarslam.core.errors import InputError
from radarslam.extent.rows import detections

#: A gap between consecutive hits wider than this many beam steps splits the landmark's returns.
MAX_GAP_STEPS = 1.5
#: Scans whose diameter is farther than this many beam widths (plus ARC_GATE_M) from the trunk's
#: median are left out of its mean: more than the beam quantisation can explain.
ARC_GATE_BEAMS = 1.5
ARC_GATE_M = 0.05


def arc_diameter(polar: np.ndarray, beam_step: float) -> float:
    """Diameter (m) of a circle from one scan's hits ``polar (m, 2)`` of ``[range, bearing]`` on it.

    ``w = (phi_max - phi_min) + delta``, ``s = sin(w / 2)``, ``d = 2 r_min s / (1 - s)`` (module
    docstring); NaN when the hits are not consecutive beams or there are none.

    Raises
    ------
    InputError
        For a ``polar`` that is not ``(m, 2)`` or a ``beam_step`` outside ``(0, pi / 4]``.
    """
    polar = np.asarray(polar, dtype=float)
    if polar.ndim != 2 or polar.shape[1] != 2:
        raise InputError(f"polar: expected shape (m, 2), got {polar.shape}")
    if not 0.0 < beam_step <= math.pi / 4:
        raise InputError(f"beam_step: expected radians in (0, pi/4], got {beam_step!r}")
    return arc_width_diameter(polar, beam_step)


def arc_width_diameter(polar: np.ndarray, beam_step: float) -> float:
    """:func:`arc_diameter` without the checks of its arguments. A kernel: numba compiles it as it
    is (the fused engine's extent step)."""
    if polar.shape[0] == 0:
        return math.nan
    phi = np.sort(polar[:, 1])
    if phi.size > 1 and np.max(np.diff(phi)) > MAX_GAP_STEPS * beam_step:
        return math.nan
    s = math.sin(0.5 * (phi[-1] - phi[0] + beam_step))
    return 2.0 * float(polar[:, 0].min()) * s / (1.0 - s)


def arc_widths_rows(polar, N, old, aoff, arow, beam_step, d, beam):
    """The visible-arc part of the extent step (a.9) for every landmark ``j < N`` (its detections
    as :mod:`radarslam.extent.rows` has them): this scan's diameter ``d[j]``
    (:func:`arc_width_diameter`; NaN without detections or when they are not consecutive beams)
    and beam width ``beam[j]`` at the nearest one's range. A kernel: the fused engine and
    :class:`VisibleArcEstimator` alike."""
    for j in range(N):
        o = old[j]
        d[j] = math.nan
        beam[j] = 0.0
        if aoff[o + 1] == aoff[o]:
            continue
        mine = detections(polar, aoff, arow, o)
        d[j] = arc_width_diameter(mine, beam_step)
        r_min = math.inf
        for a in range(mine.shape[0]):
            r_min = min(r_min, mine[a, 0])
        beam[j] = r_min * beam_step


def gated_diameter(d: np.ndarray, b: np.ndarray) -> float:
    """The trunk diameter from its per-scan diameters ``d (n,)`` and beam widths ``b (n,)`` (m), n >= 1:
    the mean of those within ``ARC_GATE_BEAMS b + ARC_GATE_M`` of their median, else the median.
    A kernel: numba compiles it as it is."""
    med = np.median(d)
    keep = np.abs(d - med) <= ARC_GATE_BEAMS * b + ARC_GATE_M
    if keep.any():
        return float(d[keep].mean())
    return float(med)

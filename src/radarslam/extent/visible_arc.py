"""The visible-arc extent of a round object seen by a scanning laser (docs/method.md a.9).

A laser does not see a trunk as a filled disc, which is what the random-matrix model's
``gamma_z X`` spread assumes (seed eq. 4): its beams, equally spaced in bearing by ``delta``, hit
the near half of the circle, and the number of beams that hit is set by the circle's angular width.
A circle of radius ``rho`` whose nearest point is at range ``r`` spans the angle
``w = 2 asin(rho / (r + rho))`` seen from the sensor. With the beam grid at a random phase, ``n``
consecutive hits mean ``w`` lies in ``[(n - 1) delta, (n + 1) delta)`` and ``E[n delta] = w``, so one
scan's hits give the unbiased width ``w_hat = (phi_max - phi_min) + delta`` and, with ``s = sin(w_hat / 2)``,
the radius ``rho_hat = r_min s / (1 - s)``. A scan whose hits on the landmark are not consecutive
beams (a gap wider than 1.5 ``delta``: another object, an occlusion) is left out. Each scan's
diameter is kept; the trunk's diameter is their median, robust to the scans where a neighbour or
the vehicle's motion distorted the width.

:class:`VisibleArcEstimator` (registered ``"visible-arc"``) is :class:`~.estimator.RmaEfaEstimator`
(whose RMA extent still serves SLAM's sifting and noise, a.7) that reports the circle
``(d / 2)^2 I`` of this mean as the landmark's extent, and the RMA matrix as its baseline.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from radarslam.core.errors import InputError
from radarslam.core.registry import EXTENT_ESTIMATORS
from radarslam.extent.estimator import RmaEfaEstimator, RmaEfaState
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


@dataclass
class VisibleArcState(RmaEfaState):
    """:class:`~.estimator.RmaEfaState` plus the per-scan visible-arc diameters and beam widths (m)."""

    arc: list[float] = field(default_factory=list)
    beam: list[float] = field(default_factory=list)
    cached: tuple[int, float] = (-1, math.nan)   # (len(arc), diameter) of the last computation


class VisibleArcEstimator(RmaEfaEstimator):
    """Trunk circles from the visible arc (docs/method.md a.9); RMA/EFA underneath for SLAM.

    Parameters
    ----------
    extent_config : ExtentConfig
        The ``extent`` section (``beam_step_deg``, ``arc_min_scans`` and the RMA keys).
    R_extent : ndarray (2, 2)
        Detection noise of the RMA step.
    """

    name = "visible-arc"

    def __init__(self, extent_config, R_extent: np.ndarray, backend: str = "python"):
        super().__init__(extent_config, R_extent, backend)
        self.beam_step = math.radians(extent_config.beam_step_deg)
        self.min_scans = int(extent_config.arc_min_scans)

    def new(self) -> VisibleArcState:
        return VisibleArcState()

    def _after(self, E, states: list[VisibleArcState], s) -> None:
        """Each landmark's width of this scan (:func:`arc_widths_rows`, the function the fused
        engine calls), kept when finite."""
        n = len(states)
        d, beam = np.empty(n), np.empty(n)
        self._kernels.arc_widths_rows(s.polar, n, s.old, s.aoff, s.arow, self.beam_step, d, beam)
        for j, st in enumerate(states):
            if math.isfinite(d[j]):
                st.arc.append(float(d[j]))
                st.beam.append(float(beam[j]))

    def diameter(self, st: VisibleArcState) -> float:
        """The trunk diameter (m): the gated mean of the per-scan widths (module docstring); NaN
        before ``arc_min_scans``."""
        n = len(st.arc)
        if n < self.min_scans:
            return math.nan
        if st.cached[0] != n:        # only new widths change it: once per scan seen, not per call
            st.cached = (n, gated_diameter(np.asarray(st.arc), np.asarray(st.beam)))
        return st.cached[1]

    def matrix(self, st: VisibleArcState) -> np.ndarray | None:
        d = self.diameter(st)
        return None if not math.isfinite(d) else (0.5 * d) ** 2 * np.eye(2)

    def baseline(self, st: VisibleArcState) -> np.ndarray | None:
        return st.X

    baseline_name = "rma"

    def round_diameter(self, X: np.ndarray) -> np.ndarray:
        """Diameters (m) of this estimator's circles ``(d / 2)^2 I``: ``2 sqrt(lambda_max)``."""
        return 2.0 * np.sqrt(np.maximum(np.linalg.eigvalsh(np.asarray(X, dtype=float))[..., -1], 0.0))

    def baseline_round_diameter(self, X: np.ndarray) -> np.ndarray:
        """The RMA baseline through the RMA's own reading."""
        return super().round_diameter(X)

    def merge(self, survivor: VisibleArcState, gone: VisibleArcState) -> VisibleArcState:
        """As :meth:`RmaEfaEstimator.merge`, and the survivor pools the other's widths (one trunk)."""
        arcs, beams = survivor.arc + gone.arc, survivor.beam + gone.beam
        kept = super().merge(survivor, gone)
        kept.arc, kept.beam = arcs, beams
        return kept


EXTENT_ESTIMATORS.register("visible-arc", VisibleArcEstimator.from_config)

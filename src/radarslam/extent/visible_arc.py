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

from radarslam.extent.estimator import RmaEfaEstimator, RmaEfaState

from radarslam.extent.arc_kernels import (  # noqa: F401  (this module's kernels until they moved)
    ARC_GATE_BEAMS, ARC_GATE_M, MAX_GAP_STEPS, arc_diameter, arc_width_diameter, arc_widths_rows, gated_diameter)

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



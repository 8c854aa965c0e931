""":class:`~radarslam.slam.filter.EkfSlam` event by event through the fused engine: the filter's state is the
engine's record (:class:`~radarslam.slam.fused.events.Carry`), run by the same function a whole stream
runs through (:class:`~radarslam.slam.fused.online.Online`), and ``EkfSlam.state`` reads it after every event
(:func:`read_back`). The steps are written once, in ``slam/fused/``."""

from __future__ import annotations

import numpy as np

from radarslam.landmarks.records import Records

__all__ = ["EngineExtents", "check_components", "engine_for", "read_back", "write_through"]


def check_components(slam) -> None:
    """Refuse in one line the components the engine has no step for, when ``slam`` is built: the
    partial-view estimator with the full view or the partial view with another estimator, and an
    associator of the user's own under the partial view (the view's association is the engine's,
    slam/fused/view.py).

    Raises
    ------
    InputError
        Naming the component and what the engine takes instead.
    """
    from radarslam.core.errors import InputError
    from radarslam.extent.view_estimator import PartialViewEstimator
    from radarslam.slam.fused.own import own_associator

    view = getattr(slam, "view", None) is not None
    if view != (type(slam.extent) is PartialViewEstimator):
        raise InputError(f"extent_estimator: expected the partial-view estimator exactly with extent.view_model "
                         f"partial, got {type(slam.extent).__name__} with the {'partial' if view else 'full'} view")
    if view and own_associator(slam):
        raise InputError(f"associator: expected a built-in associator under the partial view (its association is "
                         f"the engine's, docs/method.md a.12), got {type(slam.associator).__name__}")


def engine_for(slam, how: str = "auto"):
    """The fused engine one event at a time for ``slam`` (an EkfSlam that has processed nothing) in the
    form ``how`` (``EkfSlam``'s ``engine``): ``"auto"`` the compiled engine, its steps form under
    ``filter.fused`` false; a component of the user's own and ``filter.backend`` python choose their
    form as a whole stream's would (slam/fused/own.py ``run_form``)."""
    from radarslam.slam.fused.online import Online

    if how == "auto":
        how = "compiled" if slam.config.filter.fused else "steps"
    return Online(slam, how)


class EngineExtents:
    """The extent estimator's per-landmark states (its own type, as the estimator's protocol has them) of the
    engine's landmark records: built from a copy of the rows when first read (``estimator._scatter``, the
    estimator's own reading of array-held states) and, for the visible-arc estimator, the widths of its
    arcs from the engine's ``arcs`` (a.9); ``initialized_at`` from the scans at which each landmark's extent
    was seen initialised. Valid until the next event; setting one is refused (it would not reach the
    engine)."""

    def __init__(self, estimator, lm, n: int, initialized_at: dict, own=None, arcs=None):
        self._est, self._lm, self._n, self._at, self._arcs = estimator, lm, n, initialized_at, arcs
        #: An estimator of the user's own: its live states (slam/fused/own.py UserExtents), not rebuilt.
        self._states = None if own is None else own.of(lm, n)

    def _built(self) -> list:
        if self._states is None:
            n = self._n
            rows = type(self._lm)(*(a[:n].copy() for a in self._lm))
            states = [self._est.new() for _ in range(n)]
            if n:
                self._est._scatter(rows, states, np.zeros(n, dtype=bool), 0)
            for st, lid in zip(states, rows.ids.tolist()):
                st.initialized_at = self._at.get(lid)
            from radarslam.extent.visible_arc import VisibleArcEstimator

            if self._arcs is not None and isinstance(self._est, VisibleArcEstimator):   # its arcs' widths (a.9)
                from radarslam.slam.fused.storage import arc_values

                for j, st in enumerate(states):
                    d, b = arc_values.py_func(self._arcs, self._lm, j)
                    st.arc, st.beam = d.tolist(), b.tolist()
            self._states = states
        return self._states

    def __len__(self) -> int:
        return self._n

    def __getitem__(self, j):
        return self._built()[j]

    def __setitem__(self, j, value) -> None:
        from radarslam.core.errors import InputError

        raise InputError(f"slam.state.extents[{j}]: expected no extent set by hand after the first event (the "
                         f"extents are the engine's rows; set them before it), got a {type(value).__name__}")

    def __iter__(self):
        return iter(self._built())


def write_through(slam, online) -> None:
    """A mean or covariance the caller set on ``slam.state`` since the last event (``SlamState.set``, new
    arrays) into the engine's record, before the next event; changed in place, they are the record's own.

    Raises
    ------
    InputError
        For a state of another size (landmarks added or removed by hand after the first event: the
        engine's landmark records would no longer match).
    """
    from radarslam.core.errors import InputError

    c, st = online.carry, slam.state
    if st.x is c.x and st.P is c.P:
        return
    n = c.x.shape[0]
    if st.x.shape != (n,) or st.P.shape != (n, n):
        raise InputError(f"slam.state: expected a mean of {n} and a covariance of {n} x {n} (the engine's "
                         f"landmarks), got {st.x.shape} and {st.P.shape}; add landmarks before the first event")
    online.carry = c._replace(x=np.ascontiguousarray(st.x, dtype=float), P=np.ascontiguousarray(st.P, dtype=float))


def read_back(slam, online, k: int | None) -> None:
    """``slam.state`` as the engine's record after an event (``k``: the scan's index, None for a reading):
    the mean and covariance (the record's own arrays), the landmarks' records, the tentatives, the next id
    and the extents (:class:`EngineExtents`); ``slam``'s scan count and last scan time."""
    c = online.carry
    st, lm, n = slam.state, c.lm, int(c.N)
    st.x, st.P = c.x, c.P
    st.records = Records(lm.ids, lm.created, lm.mbits, lm.rbits, lm.first)
    st.tentatives, st.next_id = c.tent, int(c.next_id)
    at = slam._initialized_at
    if k is not None and n:
        for lid in lm.ids[:n][lm.einit[:n]].tolist():
            at.setdefault(lid, k)
    st.extents = EngineExtents(slam.extent, lm, n, at, online.user_extents, c.arcs)
    slam._scans, slam._last_scan_t = int(c.scans), online.last_t

"""EkfSlam event by event through the fused engine (slam/per_event.py): the state read back after every
event, a state set by hand written through, in the engine's compiled and steps forms.

Oracle: the same filter in the engine's steps form (``engine="steps"``: its steps run by the interpreter,
tests/test_engine_forms.py), and the whole stream in one run: every report the same, the state and the
extents to 1e-9, the map after every scan the same ids; a landmark moved by hand between two scans moves
both alike. Negative controls: the moved landmark changes the run (a write-through that did nothing would
leave it as the unmoved run), and a state of another size is refused in one line.
"""

from __future__ import annotations

import numpy as np
import pytest

from conftest import require

require("numba")

from radarslam.config import profile_config  # noqa: E402
from radarslam.core.errors import InputError  # noqa: E402
from radarslam.core.types import Scan  # noqa: E402
from radarslam.simulation.scenario import generate_scenario  # noqa: E402
from radarslam.slam.filter import EkfSlam  # noqa: E402


@pytest.fixture(scope="module")
def events():
    return generate_scenario(profile_config(), np.random.default_rng(7)).events


def _both(cfg, events, report=("removed", "confirmed", "merged", "n_candidates")):
    """``cfg``'s filter through the compiled engine and through its steps form event by event, each
    report's ``report`` fields equal: ``(compiled, steps form, merges)``."""
    eng, orch, merged = EkfSlam(cfg), EkfSlam(cfg, engine="steps"), 0
    for ev in events:
        ra, rb = eng.process(ev), orch.process(ev)
        assert (ra is None) == (rb is None)
        if ra is not None:
            assert [getattr(ra, f) for f in report] == [getattr(rb, f) for f in report]
            np.testing.assert_array_equal(eng.snapshot().ids, orch.snapshot().ids)
            merged += len(ra.merged)
    assert eng._online is not None and orch._online is not None
    return eng, orch, merged


def test_the_engine_runs_the_events_and_the_state_is_read_back(events):
    eng, orch, _ = _both(profile_config(), events)
    np.testing.assert_allclose(eng.x, orch.x, rtol=0, atol=1e-9)
    np.testing.assert_allclose(eng.P, orch.P, rtol=0, atol=1e-9)
    assert [lm.id for lm in eng.landmarks] == [lm.id for lm in orch.landmarks]
    for a, b in zip(eng.state.extents, orch.state.extents):
        assert a.initialized_at == b.initialized_at and a.n_buffered == b.n_buffered
        if b.X is not None:
            np.testing.assert_allclose(a.X, b.X, rtol=0, atol=1e-9)
    assert eng.state.next_id == orch.state.next_id and eng.state.n_landmarks >= 5


def _moved(engine: str, events, dx: float):
    """The car park with the first landmark moved by ``dx`` along x after scan 40."""
    slam, n = EkfSlam(profile_config(), engine=engine), 0
    for ev in events:
        slam.process(ev)
        n += isinstance(ev, Scan)
        if n == 40 and isinstance(ev, Scan) and dx:
            x = slam.state.x.copy()
            x[slam.state.index(0)] += dx
            slam.state.set(x, slam.state.P.copy())
    return slam.x


def test_a_state_set_by_hand_is_written_through(events):
    moved_engine, moved_orch = _moved("auto", events, 0.5), _moved("steps", events, 0.5)
    np.testing.assert_allclose(moved_engine, moved_orch, rtol=0, atol=1e-9)
    unmoved = _moved("auto", events, 0.0)
    assert unmoved.shape != moved_engine.shape or np.abs(unmoved - moved_engine).max() > 1e-3


def test_a_state_of_another_size_an_extent_set_by_hand_and_a_bad_engine_are_refused(events):
    slam = EkfSlam(profile_config())
    k = 0
    while slam.state.n_landmarks == 0:
        slam.process(events[k])
        k += 1
    x, P = slam.state.x, slam.state.P
    with pytest.raises(InputError, match=r"^slam.state.extents\[0\]: expected no extent set by hand"):
        slam.landmarks[0].extent = slam.extent.new()
    slam.state.set(np.concatenate([x, [1.0, 2.0]]), np.pad(P, ((0, 2), (0, 2))) + np.diag([0.0] * x.size + [1.0, 1.0]))
    with pytest.raises(InputError, match=r"^slam.state: expected a mean of \d+"):
        slam.process(events[k])
    with pytest.raises(InputError, match="engine: expected one of auto, compiled, steps, python, got 'fast'"):
        EkfSlam(profile_config(), engine="fast")


def test_components_of_the_users_own_run_event_by_event_in_the_engines_steps_form(events):
    """A motion model, an associator and an extent estimator of the user's own together (as in
    tests/test_engine_forms.py), event by event: the engine runs them in its steps form (slam/fused/own.py).
    Oracle: the whole stream in one run of the same filter gives the same record and maps, and
    ``state.extents`` are the estimator's own live states, whose matrices are the map's extents."""
    from radarslam.config.variants import Variant, apply_variant
    from radarslam.core.registry import ASSOCIATORS, EXTENT_ESTIMATORS, MOTION_MODELS
    from radarslam.models.motion import UnicycleModel
    from radarslam.slam.association import JointBatchAssociator
    from radarslam.slam.driver import run_filter

    from test_engine_forms import _Scatter, _same_record

    class Own(UnicycleModel):
        name = "own-pe"

    calls = {"sift": 0, "step": 0, "merge": 0}
    MOTION_MODELS.register("own-pe", lambda f: Own())
    ASSOCIATORS.register("narrow-pe", lambda c: JointBatchAssociator(
        c.landmarks.beta / 4.0, c.landmarks.n_nearest_assoc, c.landmarks.n_nearest_new))
    EXTENT_ESTIMATORS.register("scatter-pe", lambda c: _Scatter(calls))
    try:
        cfg = apply_variant(profile_config(), Variant("own", "own", {
            "filter": {"motion_model": "own-pe"}, "landmarks": {"associator": "narrow-pe", "merge_distance_m": 6.0},
            "extent": {"estimator": "scatter-pe"}}))
        eng = EkfSlam(cfg)
        rec = run_filter(cfg, events, slam=eng)
        whole = run_filter(cfg, events)
        assert whole.engine == "fused-steps" and eng._online is not None and calls["merge"] >= 2
        _same_record(rec, whole)
        for a, b in zip(rec.maps, whole.maps):
            np.testing.assert_array_equal(a.ids, b.ids)
            np.testing.assert_allclose(a.rma, b.rma, rtol=0, atol=1e-9)
        ext, n = eng.state.extents, eng.state.n_landmarks
        assert len(ext) == n >= 3 and all(type(s).__name__ == "_ScatterState" for s in ext)
        mats = [eng.extent.matrix(a) for a in ext]
        assert sum(m is not None for m in mats) >= 3
        for j, m in enumerate(mats):
            np.testing.assert_allclose(rec.maps[-1].rma[j], np.full((2, 2), np.nan) if m is None else m, rtol=0,
                                       atol=1e-12)
    finally:
        MOTION_MODELS.unregister("own-pe")
        ASSOCIATORS.unregister("narrow-pe")
        EXTENT_ESTIMATORS.unregister("scatter-pe")


def test_the_visible_arc_estimator_runs_event_by_event_with_its_widths_read_back(events):
    """The visible-arc estimator (a.9) event by event through the engine: each landmark's state carries the
    widths of its arcs as the compiled engine's does (read from the engine's arcs), and its diameter is the
    same; a landmark with no width has none in both."""
    from radarslam.config.variants import Variant, apply_variant

    cfg = apply_variant(profile_config(), Variant("arc", "arc", {"extent": {"estimator": "visible-arc"}}))
    eng, orch, _ = _both(cfg, events)
    np.testing.assert_allclose(eng.x, orch.x, rtol=0, atol=1e-9)
    widths = 0
    for a, b in zip(eng.state.extents, orch.state.extents):
        np.testing.assert_allclose(a.arc, b.arc, rtol=0, atol=1e-12)
        np.testing.assert_allclose(a.beam, b.beam, rtol=0, atol=1e-12)
        widths += len(b.arc)
        da, db = eng.extent.diameter(a), orch.extent.diameter(b)
        assert (np.isnan(da) and np.isnan(db)) or abs(da - db) < 1e-12
    assert widths >= 20                   # measured: 32 widths over the final landmarks

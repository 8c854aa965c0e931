"""A stream through the fused engine in parts (slam/fused/chunks.py): the engine takes the filter's state
in and gives it back, so parts of any size give the one-call run's record bit for bit, the caller
hears of each part's scans, and a bad event is named where it is in the whole stream."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from conftest import require

require("numba")

from radarslam.config import profile_config  # noqa: E402
from radarslam.config.variants import Variant, apply_variant  # noqa: E402
from radarslam.core.errors import InputError  # noqa: E402
from radarslam.core.types import Odometry  # noqa: E402
from radarslam.simulation.scenario import generate_scenario  # noqa: E402
from radarslam.slam.filter import EkfSlam  # noqa: E402
from radarslam.slam.fused import chunks, plan  # noqa: E402
from radarslam.slam.fused.engine import ODOMETRY, SCAN  # noqa: E402
from radarslam.slam.fused.stream import _stream_arrays  # noqa: E402


@pytest.fixture(scope="module")
def events():
    return generate_scenario(profile_config(), np.random.default_rng(7)).events


def _run(cfg, events, pacer, **kw):
    """plan.run with every stream cut by ``pacer``."""
    real = plan.Pacer
    plan.Pacer = lambda: pacer
    try:
        return plan.run(EkfSlam(cfg), events, **kw)
    finally:
        plan.Pacer = real


def _equal(a, b):
    assert a.keys() == b.keys()
    for k in a:
        np.testing.assert_array_equal(a[k], b[k], err_msg=k)


@pytest.mark.parametrize("all_maps", [True, False])
def test_parts_of_any_size_give_the_one_call_record_bit_for_bit(events, all_maps):
    """Parts of 1, then 5 scans (a part ends just after a scan, odometry between scans goes with the next):
    every array of the record, the maps after every scan (or the last one) and the association rows equal
    to one call's; the caller is told of every scan once, part by part."""
    cfg = profile_config()
    one, one_rows = _run(cfg, events, chunks.Pacer(first=10**9), all_maps=all_maps)
    told = []
    pacer = chunks.Pacer(first=1, target_s=1e-12, least=5)
    many, many_rows = _run(cfg, events, pacer, all_maps=all_maps, on_scans=told.append)
    n_scans = one["poses"].shape[0]
    assert told[0] == 1 and set(told[1:-1]) == {5} and sum(told) == n_scans and len(told) > 20
    _equal(one, many)
    np.testing.assert_array_equal(one_rows, many_rows)


def test_parts_carry_the_bias_states_and_the_partial_view(events):
    """The families that carry more state (the odometry-bias states, the partial view's shapes and view
    angles): parts of 3 scans give the one call's poses, covariances and maps bit for bit."""
    for name, change in (("bias", {"filter": {"odometry_bias": "states"}}),
                         ("view", {"extent": {"use_in_slam": True, "spread_model": "visible-faces"}})):
        cfg = apply_variant(profile_config(), Variant(name, name, change))
        one, _ = _run(cfg, events, chunks.Pacer(first=10**9))
        many, _ = _run(cfg, events, chunks.Pacer(first=3, target_s=1e-12, least=3))
        _equal(one, many)


def test_a_part_is_the_streams_events_in_the_same_layout(events):
    """``part`` cuts out events [e0, e1): its scans' detections, counts and offsets are the whole
    stream's, its first scan's index is the scans before e0, and its arrays keep their layout."""
    stream = _stream_arrays(events, slam=EkfSlam(profile_config()))
    e0 = int(np.flatnonzero(stream.kinds == SCAN)[10]) + 1
    e1 = e0 + 40
    sub, s0 = chunks.part(stream, e0, e1)
    assert s0 == 11
    n = int((stream.kinds[e0:e1] == SCAN).sum())
    assert sub.scan_off.shape == (n + 1,) and sub.scan_off[0] == 0
    for j in range(n):
        np.testing.assert_array_equal(sub.polar[sub.scan_off[j]:sub.scan_off[j + 1]],
                                      stream.polar[stream.scan_off[s0 + j]:stream.scan_off[s0 + j + 1]])
    assert sub.odo.shape[0] == int((stream.kinds[e0:e1] == ODOMETRY).sum())
    np.testing.assert_array_equal(sub.odo[0], stream.odo[int((stream.kinds[:e0] == ODOMETRY).sum())])
    for f in sub._fields:
        assert getattr(sub, f).flags.c_contiguous, f


def test_a_bad_event_in_a_later_part_is_named_where_it_is(events):
    """An odometry reading that makes the state non-finite, in the third part: the one-line error names
    that reading (its time and control), as one call would."""
    bad = list(events)
    i = [j for j, e in enumerate(bad) if isinstance(e, Odometry)][60]
    e = bad[i]
    bad[i] = dataclasses.replace(e, control=np.array([1e308, 1e308]))
    cfg = profile_config()
    with pytest.raises(InputError) as one:
        _run(cfg, bad, chunks.Pacer(first=10**9))
    with pytest.raises(InputError) as many:
        _run(cfg, bad, chunks.Pacer(first=4, target_s=1e-12, least=4))
    assert str(one.value) == str(many.value)
    assert f"t={e.t!r}" in str(many.value)

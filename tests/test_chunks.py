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


@pytest.mark.parametrize("how", ["compiled", "steps"])
def test_the_engine_event_by_event_gives_the_one_call_record(events, how):
    """slam/fused/online.py ``Online``: the car-park trial fed one event at a time through the same engine
    (compiled, and its steps form) gives the one-call run's pose, covariance, landmarks, NIS, map after
    every scan and associations bit for bit; an odometry reading gives no record."""
    from radarslam.core.types import Scan
    from radarslam.slam.fused.online import Online

    cfg = profile_config()
    one, one_rows = _run(cfg, events, chunks.Pacer(first=10**9))
    online = Online(EkfSlam(cfg), how=how)
    got = [(online.process(ev), isinstance(ev, Scan)) for ev in events]
    assert all((r is None) != is_scan for r, is_scan in got)
    scans = [r for r, _ in got if r is not None]
    np.testing.assert_array_equal(np.concatenate([rec.poses for rec, _, _ in scans]), one["poses"])
    np.testing.assert_array_equal(np.concatenate([rec.pose_covs for rec, _, _ in scans]), one["pose_covs"])
    np.testing.assert_array_equal(np.concatenate([rec.n_lm for rec, _, _ in scans]), one["n_landmarks"])
    np.testing.assert_array_equal(np.concatenate([rec.nis for rec, _, _ in scans]), one["nis"])
    off = one["map_offsets"]
    for s, (_, maps, _) in enumerate(scans):
        np.testing.assert_array_equal(maps.ids, one["ids"][off[s]:off[s + 1]])
        np.testing.assert_array_equal(maps.rma, one["rma"][off[s]:off[s + 1]])
    rows = np.concatenate([np.column_stack([np.full(a.shape[0], s), a[:, 1:]]) for s, (_, _, a) in enumerate(scans)])
    np.testing.assert_array_equal(rows, one_rows)


def test_the_engine_event_by_event_refuses_a_bad_scan_and_goes_on(events):
    """A scan with a negative range is refused in one line before anything changes (the filter's state is
    the one before the bad scan); so is a scan earlier than the last one run, as EkfSlam.update refuses it."""
    from radarslam.core.types import Scan
    from radarslam.slam.fused.online import Online

    cfg = profile_config()
    a, b = Online(EkfSlam(cfg)), Online(EkfSlam(cfg))
    k = [j for j, e in enumerate(events) if isinstance(e, Scan)][5]
    for ev in events[:k]:
        a.process(ev), b.process(ev)
    bad = dataclasses.replace(events[k], polar=np.array([[-1.0, 0.0]]))
    with pytest.raises(InputError, match="range"):
        a.process(bad)
    np.testing.assert_array_equal(a.carry.x, b.carry.x)
    np.testing.assert_array_equal(a.carry.P, b.carry.P)
    a.process(events[k]), b.process(events[k])
    back = dataclasses.replace(events[k], t=float(events[k].t) - 0.5)
    with pytest.raises(InputError, match="scan.t: expected scan times that do not go backwards"):
        a.process(back)


def test_the_engine_event_by_event_feeds_the_doppler_odometry_and_gate_in_order():
    """Under Doppler and gyro odometry with the Doppler gate (c.10.4, c.10.5) the filter's own components
    read the events as they come (an odometry reading is held until the scan, the gate's generator goes
    on): fed one event at a time, the car park simulated with Doppler gives the one-call record bit for bit.
    Negative control: components copied afresh for every event (``live`` False) do not."""
    from dataclasses import replace

    from radarslam.config import Config
    from radarslam.config.variants import Variant
    from radarslam.montecarlo.trials import variant_config
    from radarslam.slam.fused import online as online_mod
    from radarslam.slam.fused.online import Online

    cfg = Config()
    cfg = replace(cfg, radar=replace(cfg.radar, doppler=True))
    sc = generate_scenario(cfg, np.random.default_rng(7))
    cfg = variant_config(cfg, Variant("both", "both", {"filter": {"odometry": "both", "doppler_gate": True}}))
    one, _ = _run(cfg, sc.events, chunks.Pacer(first=10**9))

    def poses(live: bool):
        real = online_mod._stream_arrays
        online_mod._stream_arrays = lambda ev, fast=True, slam=None, live=False, **kw: real(ev, fast, slam, live and keep,
                                                                                        **kw)
        keep = live
        try:
            on = Online(EkfSlam(cfg))
            return np.concatenate([r[0].poses for r in (on.process(ev) for ev in sc.events) if r is not None])
        finally:
            online_mod._stream_arrays = real

    np.testing.assert_array_equal(poses(True), one["poses"])
    copied = poses(False)
    assert copied.shape != one["poses"].shape or np.abs(copied - one["poses"]).max() > 1e-6

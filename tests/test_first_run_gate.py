"""The first-run policy and a recording's Doppler gate: a run event by event is
"ready" only when the gate's compiled classification is too (it compiled 28 s without a word on a
machine that had run the car park and Victoria Park before), and a step before the filter that takes
a while says so (``compiling.heartbeat.stage``)."""

from __future__ import annotations

import dataclasses

from radarslam.compiling import heartbeat, policy
from radarslam.compiling.policy import Workload
from radarslam.config import profile_config
from radarslam.models._doppler_compiled import classify_scan


def _plan(monkeypatch, gate_compiled: bool, doppler_gate: bool):
    monkeypatch.setattr(policy, "_steps_ready", lambda: True)   # the steps form's kernels: cached
    monkeypatch.setattr(policy, "_fused_ready", lambda *f: False)
    real = policy.ready
    monkeypatch.setattr(policy, "ready", lambda d: gate_compiled if d is classify_scan else real(d))
    cfg = profile_config("automotive")
    cfg = dataclasses.replace(cfg, filter=dataclasses.replace(cfg.filter, doppler_gate=doppler_gate))
    return policy.plan(cfg, Workload("stream", n_scans=1263, n_detections=126_749, fused=False))


def test_the_gate_not_compiled_is_not_a_ready_run(monkeypatch):
    p = _plan(monkeypatch, gate_compiled=False, doppler_gate=True)
    assert not (p.engine == "steps" and not p.compiles)          # before: the steps form, compiling silently
    assert p.announce.startswith("first run on this machine")
    assert p.engine == "python" or p.compiles


def test_a_compiled_gate_or_no_gate_is_ready(monkeypatch):
    for compiled, gate in ((True, True), (False, False)):               # the negative controls
        p = _plan(monkeypatch, gate_compiled=compiled, doppler_gate=gate)
        assert p.engine == "steps" and not p.compiles


def test_a_long_stage_beats_and_says_when_it_ends(monkeypatch, capsys):
    import time

    monkeypatch.setattr(heartbeat, "HEARTBEAT_S", 0.05)
    with heartbeat.stage("fitting something"):
        time.sleep(0.18)
    err = capsys.readouterr().err.splitlines()
    assert sum(line.startswith("run: still fitting something (") for line in err) >= 2
    assert err[-1].startswith("run: fitting something: done in ")
    with heartbeat.stage("fitting something", enabled=False):           # a library call: silent
        time.sleep(0.12)
    with heartbeat.stage("fitting something"):                          # short: silent too
        pass
    assert capsys.readouterr().err == ""

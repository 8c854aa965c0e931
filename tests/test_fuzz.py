"""Fuzzing (Hypothesis, derandomised by conftest): configuration values through the command line and
event streams through the filter. Every case ends either in success with finite outputs or in exit 1
(an InputError) with one line and no traceback."""

from __future__ import annotations

import json
import math

import numpy as np
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from radarslam.cli.main import main
from radarslam.config import profile_config
from radarslam.core.errors import InputError
from radarslam.core.types import Odometry, Scan
from radarslam.slam import EkfSlam

#: Keys fuzzed, with the TOML section; the trajectory stays short so that every case runs fast.
KEYS = [("radar", "range_std_m"), ("radar", "azimuth_std_deg"), ("radar", "detection_probability"),
        ("radar", "points_per_m2"), ("radar", "clutter_rate_per_m2"), ("radar", "max_range_m"),
        ("filter", "range_std_m"), ("filter", "azimuth_std_deg"), ("filter", "speed_std_mps"),
        ("filter", "initial_pose_std"), ("landmarks", "alpha"), ("landmarks", "beta"),
        ("landmarks", "cluster_eps_m"), ("landmarks", "cluster_min_samples"), ("landmarks", "merge_axis_tol_m"),
        ("landmarks", "associator"), ("landmarks", "init"), ("extent", "gamma_z"), ("extent", "gate_probability"),
        ("extent", "use_in_slam"), ("extent", "sifting_mode"), ("extent", "pre_init_spread"),
        ("trajectory", "speed_mps"), ("trajectory", "dt_s"), ("world", "vehicles"), ("world", "departing_vehicle")]

values = st.one_of(
    st.floats(allow_nan=True, allow_infinity=True, width=64),
    st.floats(min_value=-5, max_value=5),
    st.integers(min_value=-3, max_value=10**7),
    st.booleans(),
    st.sampled_from(["batch", "cluster", "literal", "prior", "scatter", "nearest", "", "x" * 3]),
    st.lists(st.floats(min_value=-50, max_value=50), min_size=0, max_size=5),
    st.lists(st.lists(st.floats(min_value=-20, max_value=20), min_size=3, max_size=5), min_size=0, max_size=3),
)


def _toml(v) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, float):
        return "nan" if math.isnan(v) else ("inf" if v > 0 else "-inf") if math.isinf(v) else repr(v)
    if isinstance(v, str):
        return json.dumps(v)
    if isinstance(v, list):
        return "[" + ", ".join(_toml(x) for x in v) + "]"
    return str(v)


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(st.lists(st.tuples(st.sampled_from(KEYS), values), min_size=1, max_size=4))
def test_config_values_end_in_success_or_one_line(tmp_path_factory, overrides):
    d = tmp_path_factory.mktemp("fuzz")
    sections: dict[str, dict] = {"trajectory": {"n_steps": 12, "turn_end": 12}}
    for (sec, key), v in overrides:
        sections.setdefault(sec, {})[key] = v
    text = "\n".join(f"[{sec}]\n" + "\n".join(f"{k} = {_toml(v)}" for k, v in kv.items()) for sec, kv in sections.items())
    (d / "c.toml").write_text(text + "\n")
    import contextlib
    import io

    err = io.StringIO()
    with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
        rc = main(["run", "--config", str(d / "c.toml"), "--out", str(d / "o"), "--no-plot"])
    msg = err.getvalue()
    assert "Traceback" not in msg
    if rc == 0:
        m = json.loads((d / "o" / "metrics.json").read_text())["scalars"]
        assert m["position_avg_rmse_m"] is not None and math.isfinite(m["position_avg_rmse_m"])
        poses = np.loadtxt(d / "o" / "trajectory.csv", delimiter=",", skiprows=1)
        assert np.all(np.isfinite(poses))
    else:
        assert rc == 1 and msg.count("\n") == 1 and msg.startswith("radarslam run: error: "), msg


numbers = st.one_of(st.floats(allow_nan=True, allow_infinity=True, width=64), st.floats(-100, 100),
                    st.integers(-5, 5), st.text(max_size=2))
odometry = st.builds(lambda t, dt, c: Odometry(t, dt, c), st.floats(0, 100), numbers,
                     st.lists(numbers, min_size=0, max_size=3))
scan = st.builds(lambda t, k, p: Scan(t, k, p), numbers, st.integers(1, 200),
                 st.one_of(st.lists(st.lists(numbers, min_size=2, max_size=2), max_size=8),
                           st.lists(st.tuples(st.floats(0, 25), st.floats(-3.2, 3.2)), max_size=30)))


@settings(max_examples=150, deadline=None)
@given(st.lists(st.one_of(odometry, scan), min_size=1, max_size=25), st.sampled_from(["nearest-neighbour", "batch"]),
       st.sampled_from(["python", "numba"]))
def test_event_streams_end_in_a_finite_state_or_an_input_error(events, associator, backend):
    from dataclasses import replace

    cfg = profile_config("apsipa")
    cfg = replace(cfg, filter=replace(cfg.filter, backend=backend),
                  landmarks=replace(cfg.landmarks, associator=associator),
                  extent=replace(cfg.extent, use_in_slam=True, pre_init_spread="prior"))
    slam = EkfSlam(cfg)
    for ev in events:
        x0 = slam.x.copy()
        try:
            slam.process(ev)
        except InputError as exc:
            assert "\n" not in str(exc)
            if isinstance(ev, Odometry):
                assert np.array_equal(slam.x, x0)      # a refused reading changes nothing
            if "non-finite" in str(exc):
                return                                  # the filter says it is not to be used further
            continue
        assert np.all(np.isfinite(slam.x)) and np.all(np.isfinite(slam.P))
        assert np.allclose(slam.P, slam.P.T)

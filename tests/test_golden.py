"""Golden regression: the recorded runs of ``tests/golden.py`` (car park 120 scans, four
configurations; Victoria Park 500 scans; both backends) are reproduced exactly.

Python backend: every value equal to the last bit. numba: equal to 1e-12 (its covariance sums run
in another order), and the very same associations as the recording and as the Python backend.
"""

from __future__ import annotations

import numpy as np
import pytest

from conftest import require
from golden import BACKENDS, CARPARK_RUNS, GOLDEN, VP_SCANS, carpark_run, victoria_park_run


@pytest.fixture(scope="module")
def golden():
    with np.load(GOLDEN) as z:
        return {k: z[k] for k in z.files}


def _check(golden: dict, key: str, values: dict, backend: str) -> None:
    stored = {k.split("/")[-1]: v for k, v in golden.items() if k.startswith(key + "/")}
    assert stored, f"no golden values for {key}"
    assert set(stored) == set(values)
    for name, want in stored.items():
        got = values[name]
        assert got.shape == want.shape, (key, name, got.shape, want.shape)
        if want.dtype.kind in "iu" or backend == "python":
            assert np.array_equal(got, want, equal_nan=True), (key, name)
        else:
            np.testing.assert_allclose(got, want, rtol=1e-12, atol=1e-12, err_msg=f"{key}/{name}")


@pytest.mark.parametrize("backend", BACKENDS)
@pytest.mark.parametrize("name,profile,seed,extent", CARPARK_RUNS, ids=[r[0] for r in CARPARK_RUNS])
def test_carpark_run_matches_golden(golden, backend, name, profile, seed, extent):
    if backend == "numba":
        require("numba")
    _check(golden, f"{backend}/{name}", carpark_run(profile, seed, extent, backend), backend)


@pytest.mark.parametrize("backend", BACKENDS)
def test_victoria_park_500_matches_golden(golden, backend, victoria_park_dir):
    if backend == "numba":
        require("numba")
    _check(golden, f"{backend}/victoria-park-{VP_SCANS}", victoria_park_run(backend, victoria_park_dir), backend)


def test_backends_made_the_same_associations(golden):
    """The two backends of the recording associate every detection to the same landmark."""
    runs = [r[0] for r in CARPARK_RUNS] + [f"victoria-park-{VP_SCANS}"]
    for name in runs:
        a, b = f"python/{name}/associations", f"numba/{name}/associations"
        if a in golden:
            assert np.array_equal(golden[a], golden[b]), name

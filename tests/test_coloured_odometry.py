"""The equivalent white noise of correlated odometry errors (docs/method.md c.11.6,
``filter.odometry_tau_s``): each sample's U is U 2 tau / dt; tau = 0 is the model's U bit for bit;
the per-sample variance gives the Gauss-Markov process's long-run growth of the integrated error."""

from __future__ import annotations

import numpy as np
import pytest

from radarslam.config import from_dict, profile_config, to_dict
from radarslam.core.errors import ConfigError
from radarslam.slam.filter import EkfSlam


def _config(profile: str, **filter_keys):
    d = to_dict(profile_config(profile))
    d["filter"].update(filter_keys)
    return from_dict(d)


@pytest.mark.parametrize("profile", ["victoria-park-trees", "apsipa"])
def test_u_is_scaled_by_two_tau_over_dt(profile):
    plain = EkfSlam(_config(profile)).U
    assert np.array_equal(EkfSlam(_config(profile, odometry_tau_s=0.0, odometry_sample_s=0.025)).U, plain)
    U = EkfSlam(_config(profile, odometry_tau_s=3.0, odometry_sample_s=0.025)).U
    np.testing.assert_allclose(U, plain * 240.0, rtol=1e-15)


def test_tau_without_a_sample_interval_is_refused():
    with pytest.raises(ConfigError, match="filter.odometry_sample_s"):
        EkfSlam(_config("victoria-park-trees", odometry_tau_s=3.0))


def test_equivalent_white_noise_matches_the_gauss_markov_growth():
    """Integrate a Gauss-Markov input error (std s, time constant tau) and its equivalent white
    noise per sample (variance s^2 2 tau / dt) over T = 50 tau: the variances of the integrals
    agree to the Monte Carlo error (2000 paths), and plain white noise of variance s^2 per sample
    (the negative control) gives 2 tau / dt = 80 times less."""
    rng = np.random.default_rng(7)
    s, tau, dt, n, paths = 0.5, 1.0, 0.025, 2000, 2000
    phi = np.exp(-dt / tau)
    b = rng.normal(0.0, s, paths)
    gm = np.zeros(paths)
    for _ in range(n):
        gm += b * dt
        b = phi * b + rng.normal(0.0, s * np.sqrt(1 - phi ** 2), paths)
    T = n * dt
    exact = 2 * s ** 2 * tau ** 2 * (T / tau - 1 + np.exp(-T / tau))
    assert gm.var() == pytest.approx(exact, rel=0.1)
    white_equiv = (s ** 2 * 2 * tau / dt) * dt ** 2 * n
    assert white_equiv == pytest.approx(exact, rel=0.03)          # T >> tau: 2 s^2 tau T
    assert (s ** 2) * dt ** 2 * n < exact / 50                     # white per sample: far too small

"""How well the rig's ego-motion agrees with the car's own odometry, and whether its covariance says
so (docs/method.md c.12.6-c.12.8): the speed and yaw-rate error RMS of the sweeps marked ok, the share
of them inside their own 95% ellipse of ``(v_x, omega)``, and the largest yaw-rate error among them.

The odometry is the reference, with errors of its own that the comparison accounts for:

- **Its clock.** The radars' stamps and the odometry's differ by an offset ``tau`` (c.12.8; on
  RadarScenes 105 about -0.11 s). ``tau`` minimises the squared difference of the fit's ``v_x(t)`` and
  the wheel speed at ``t + tau`` over the ok sweeps of one half of the drive and is applied to the
  other half (two folds by time), so no sweep is compared at an offset fitted to it. The wheels'
  scale against the Doppler (c.12.8's second state) is neither fitted nor carried: on RadarScenes 105
  it changes sign between the drive's halves (+0.12%, -0.14%) and, applied out of fold, raises the
  speed error RMS from 0.043 to 0.057 m/s; profiled out of each fold's fit instead, it moves the
  nuScenes offsets away from an independent review's cross-correlation (scene-0061: +53 ms against
  its 0; without it +1 ms, and +44/+26, +44/+32, +42/+5 ms on 0103, 0655, 0916 against 40, 30, 45).
- **Its noise.** The odometry's own white noise, measured on the odometry alone: the std of each
  sample's residual about a local quadratic over +-:data:`REFERENCE_HALF_S` (RadarScenes 105: 0.002
  m/s, 0.05 deg/s), added to the comparison's covariance.
- **The covariance compared.** The fit's own (``cov``, c.12.3 steps 5-5b), its clock term
  ``sigma_tau^2 theta_dot theta_dot^T`` replaced by the alignment's own error (the two folds are two
  estimates of one offset: ``|tau_1 - tau_2| / sqrt 2``): what is left of the clock once aligned.

**The band of the containment share.** ``n`` ok sweeps are not ``n`` independent trials: neighbouring
windows share detections (c.12.7: each is in about five) and the systematic terms (mounting, clock,
sideslip) move neighbours alike. The share's band is the binomial one at the effective number of
sweeps ``n / tau_int``, ``tau_int`` the integrated autocorrelation time of the inside/outside sequence
(Sokal's window: the smallest ``M >= 5 tau_int(M)``); :func:`ego_accuracy` also gives the binomial
band at ``n`` (independent sweeps) for comparison.
"""

from __future__ import annotations

import math

import numpy as np
from scipy import stats
from scipy.optimize import minimize_scalar

from radarslam.models.rig_velocity import OK, RigVelocitySeries

__all__ = ["CHI2_2_95", "REFERENCE_HALF_S", "clock_folds", "ego_accuracy", "effective_sample_size",
           "reference_noise", "share_band"]

#: ``chi2.ppf(0.95, 2)``: the 95% ellipse of a 2-D Gaussian error.
CHI2_2_95 = 5.991464547107979
#: Half-width (s) of the local quadratic about which the odometry's own noise is measured.
REFERENCE_HALF_S = 0.2
#: The clock offsets searched (s): +-0.5 s, five times the largest measured on the shared recordings.
CLOCK_BOUND_S = 0.5


def reference_noise(odometry: np.ndarray, half_s: float = REFERENCE_HALF_S) -> tuple[float, float]:
    """``(speed std m/s, yaw-rate std rad/s)`` of the odometry's own white noise: the std of each
    sample's residual about the least-squares quadratic through the samples within ``+-half_s`` of it
    (at least 8 of them); ``(0, 0)`` with too few samples."""
    t, v, w = (np.asarray(odometry, dtype=float)[:, j] for j in range(3))
    lo = np.searchsorted(t, t - half_s, side="left")
    hi = np.searchsorted(t, t + half_s, side="right")
    rv, rw = [], []
    for i in np.flatnonzero(hi - lo >= 8):
        sl = slice(lo[i], hi[i])
        X = np.vander(t[sl] - t[i], 3)
        coef = np.linalg.lstsq(X, np.column_stack([v[sl], w[sl]]), rcond=None)[0]
        rv.append(v[i] - coef[-1, 0])
        rw.append(w[i] - coef[-1, 1])
    return (float(np.std(rv)), float(np.std(rw))) if rv else (0.0, 0.0)


def _clock_offset(t: np.ndarray, vx: np.ndarray, odometry: np.ndarray) -> float:
    """The offset ``tau`` minimising ``sum (vx - v_o(t + tau))^2`` within +-:data:`CLOCK_BOUND_S` (a grid
    of 10 ms, then a bounded search about its best point)."""
    ot, ov = odometry[:, 0], odometry[:, 1]
    rss = lambda tau: float(np.sum((vx - np.interp(t + tau, ot, ov)) ** 2))
    grid = np.linspace(-CLOCK_BOUND_S, CLOCK_BOUND_S, 101)
    best = grid[int(np.argmin([rss(x) for x in grid]))]
    step = grid[1] - grid[0]
    res = minimize_scalar(rss, bounds=(best - step, best + step), method="bounded", options={"xatol": 1e-5})
    return float(res.x)


def clock_folds(t: np.ndarray, vx: np.ndarray, odometry: np.ndarray) -> tuple[np.ndarray, tuple[float, float]]:
    """Each sweep's clock offset (module docstring) fitted on the other half of the drive: ``(tau (K,),
    (tau of the first half's sweeps, of the second half's))``; ``t``, ``vx`` the ok sweeps' times and
    forward speeds, in time order."""
    first = t < np.median(t)
    tau_a = _clock_offset(t[~first], vx[~first], odometry)      # for the first half, from the second
    tau_b = _clock_offset(t[first], vx[first], odometry)
    return np.where(first, tau_a, tau_b), (tau_a, tau_b)


def effective_sample_size(x: np.ndarray) -> tuple[float, float]:
    """``(n_eff, tau_int)`` of the sequence ``x``: ``tau_int = 1 + 2 sum_{k=1}^{M} rho_k`` with Sokal's
    window (the smallest ``M >= 5 tau_int(M)``), ``n_eff = n / tau_int``; ``(n, 1)`` for a constant
    sequence."""
    x = np.asarray(x, dtype=float)
    n = x.size
    d = x - x.mean()
    var = float(np.dot(d, d)) / n if n else 0.0
    if n < 3 or var <= 0:
        return float(n), 1.0
    f = np.fft.rfft(d, 2 * n)
    acf = np.fft.irfft(f * np.conj(f))[:n] / (var * n)
    tau = 1.0
    for M in range(1, n):
        tau += 2.0 * acf[M]
        if M >= 5.0 * tau:
            break
    tau = max(tau, 1.0)
    return n / tau, tau


def share_band(n: float, p: float = 0.95, probability: float = 0.95) -> tuple[float, float]:
    """The two-sided ``probability`` band of the share of ``n`` (rounded down, at least 1) independent
    trials of probability ``p`` that succeed: Binomial(n, p) / n quantiles."""
    m = max(int(math.floor(n)), 1)
    lo, hi = stats.binom.ppf([(1 - probability) / 2, (1 + probability) / 2], m, p) / m
    return float(lo), float(hi)


def _figures(e: np.ndarray, C: np.ndarray) -> dict:
    m2 = np.einsum("ki,ki->k", e, np.linalg.solve(C, e[..., None])[..., 0])
    inside = m2 <= CHI2_2_95
    n_eff, tau_int = effective_sample_size(inside)
    return {"speed_rms_mps": float(np.sqrt(np.mean(e[:, 0] ** 2))),
            "speed_mean_mps": float(np.mean(e[:, 0])),
            "yaw_rate_rms_deg_s": math.degrees(float(np.sqrt(np.mean(e[:, 1] ** 2)))),
            "yaw_rate_mean_deg_s": math.degrees(float(np.mean(e[:, 1]))),
            "within_95_ellipse": float(np.mean(inside)),
            "vx_within_1.96_sd": float(np.mean(np.abs(e[:, 0]) <= 1.959964 * np.sqrt(C[:, 0, 0]))),
            "yaw_rate_within_1.96_sd": float(np.mean(np.abs(e[:, 1]) <= 1.959964 * np.sqrt(C[:, 1, 1]))),
            "median_sd_vx_mps": float(np.median(np.sqrt(C[:, 0, 0]))),
            "median_sd_yaw_rate_deg_s": math.degrees(float(np.median(np.sqrt(C[:, 1, 1])))),
            "max_abs_yaw_rate_error_deg_s": math.degrees(float(np.max(np.abs(e[:, 1])))),
            "beyond_20_deg_s": int(np.sum(np.abs(e[:, 1]) > math.radians(20.0))),
            "n_eff": n_eff, "tau_int": tau_int,
            "band_n_eff": share_band(n_eff), "band_n": share_band(e.shape[0])}


def ego_accuracy(series: RigVelocitySeries, odometry: np.ndarray, *, clock_std_s: float = 0.05,
                 cov_scale: float = 1.0) -> dict:
    """The rig's ego-motion ``series`` against ``odometry`` ``(T, 3)`` ``[t, speed, yaw rate]`` (module
    docstring), over the sweeps marked ok within the odometry's span (and +-:data:`CLOCK_BOUND_S`
    inside it): ``aligned`` (the reference at the out-of-fold clock offset, the covariance with the
    clock term of ``clock_std_s``, the fit's stated ``sigma_tau``, replaced by the alignment's error,
    plus the reference's noise) and ``as_stamped`` (the reference at each sweep's stamp, the fit's
    covariance as it is, plus the reference's noise), each with the speed and yaw-rate error RMS and
    mean (m/s, deg/s), the share inside the 95% ellipse of ``(v_x, omega)`` and of each inside 1.96
    sd, the largest yaw-rate error and the number beyond 20 deg/s, and the share's bands.
    ``cov_scale`` multiplies the fit's covariance (a negative control: a covariance stated wrong)."""
    odo = np.asarray(odometry, dtype=float)
    th = np.asarray(series.theta, dtype=float)
    t_all = np.asarray(series.t, dtype=float)
    ok = ((series.status == OK) & np.all(np.isfinite(th), axis=1)
          & (t_all >= odo[0, 0] + CLOCK_BOUND_S) & (t_all <= odo[-1, 0] - CLOCK_BOUND_S))
    t = t_all[ok]
    C3 = cov_scale * np.asarray(series.cov, dtype=float)[ok]
    rv, rw = reference_noise(odo)
    R = np.diag([rv * rv, rw * rw])
    pick = lambda M: M[:, [0, 2]][:, :, [0, 2]]
    err = lambda tau: np.column_stack([th[ok, 0] - np.interp(t + tau, odo[:, 0], odo[:, 1]),
                                       th[ok, 2] - np.interp(t + tau, odo[:, 0], odo[:, 2])])
    out = {"sweeps": int(t_all.size), "ok_sweeps": int(ok.sum()),
           "reference_noise": {"speed_mps": rv, "yaw_rate_deg_s": math.degrees(rw)}}
    out["as_stamped"] = _figures(err(0.0), pick(C3) + R)
    tau, folds = clock_folds(t, th[ok, 0], odo)
    tau_std = abs(folds[0] - folds[1]) / math.sqrt(2.0)
    C_al = C3.copy()
    if series.theta_dot is not None:
        td = np.asarray(series.theta_dot, dtype=float)[ok]
        C_al += (cov_scale * (tau_std ** 2 - clock_std_s ** 2)) * td[:, :, None] * td[:, None, :]
    out["aligned"] = {"clock_offset_s": list(folds), "clock_offset_std_s": tau_std,
                      **_figures(err(tau), pick(C_al) + R)}
    return out

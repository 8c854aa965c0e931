"""The robust fit of many windows of a rig's Doppler at once (docs/method.md c.12.3-c.12.4): after
the consensus of :mod:`radarslam.models._rig_consensus` (RANSAC and least squares on it), the robust
scale (1.4826 MAD of the consensus), Tukey's biweight by IRLS at that scale, the M-estimator's
sandwich covariance and each window's status (:func:`fit_chunk`), over every window of a recording
in chunks of at most :data:`CHUNK_ROWS` window-detection pairs (memory; :func:`fit_windows`).
:func:`radarslam.models.rig_velocity.fit_rig_velocity` and ``fit_rig_windows`` call it.
"""

from __future__ import annotations

import numpy as np

from radarslam.models._rig_consensus import (
    Pairs,
    consensus_fit,
    corr_det,
    inv_batch,
    ransac,
)

#: Tukey's biweight constant in units of the scale: 95% efficiency at the normal law (c.12.3).
TUKEY_C = 4.685
#: 1 / Phi^-1(3/4): the MAD of a normal law times this is its standard deviation.
MAD_TO_STD = 1.4826
#: Below this determinant of the information matrix normalised to unit diagonal, a direction of
#: theta is not observed (one radar alone: ~1e-16; two radars 1.4 m apart: ~1e-2).
RANK_TOL = 1e-9

#: Status codes of a window's fit; the last two are set by the consistency gates (c.12.7), not the fit.
OK, TOO_FEW, NO_CONSENSUS, UNOBSERVABLE, FLAGGED_GYRO, FLAGGED_JUMP = 0, 1, 2, 3, 4, 5
STATUS = {OK: "ok", TOO_FEW: "too few detections", NO_CONSENSUS: "no consensus", UNOBSERVABLE: "rank deficient",
          FLAGGED_GYRO: "flagged: disagrees with the gyro", FLAGGED_JUMP: "flagged: disagrees with the previous sweeps"}
#: The same as words for ``ego_velocity.csv``'s ``status`` column.
STATUS_WORDS = {OK: "ok", TOO_FEW: "too-few", NO_CONSENSUS: "no-consensus", UNOBSERVABLE: "rank-deficient",
                FLAGGED_GYRO: "flagged-gyro", FLAGGED_JUMP: "flagged-jump"}

#: Largest number of (window, detection) pairs held at once.
CHUNK_ROWS = 1_000_000


def robust_scale(pairs: Pairs, theta: np.ndarray, threshold: float,
                 sigma_floor: float) -> tuple[np.ndarray, np.ndarray]:
    """The robust scale ``s (K,)`` of every window and its consensus size ``k (K,)`` (c.12.3 step 3):
    1.4826 MAD of the consensus residuals of ``theta``, small-sample corrected (Rousseeuw & Leroy 1987,
    1 + 5 / (k - p)), floored at ``sigma_floor`` (the Doppler's quantisation). One sort for all windows:
    the key win + |r| / tau puts each window's consensus residuals in order, the rest after them."""
    K, p = pairs.K, pairs.p
    r = np.abs(pairs.residual(theta))
    cons = r <= threshold
    k_cons = np.rint(pairs.wsum(cons)).astype(np.int64)
    key = np.sort(pairs.win + np.where(cons, r / (threshold * (1 + 1e-9)), 1.0 - 1e-12))
    mid_lo = pairs.start + np.maximum((k_cons - 1) // 2, 0)
    mid_hi = pairs.start + np.maximum(k_cons // 2, 0)
    med = 0.5 * ((key[mid_lo] - np.arange(K)) + (key[mid_hi] - np.arange(K))) * threshold * (1 + 1e-9)
    with np.errstate(divide="ignore", invalid="ignore"):
        s = np.maximum(MAD_TO_STD * med * (1.0 + 5.0 / (k_cons - p)), sigma_floor)
    return s, k_cons


def biweight(pairs: Pairs, theta: np.ndarray, cs: np.ndarray, irls_steps: int) -> np.ndarray:
    """Tukey's biweight ``(K, p)`` by IRLS from ``theta`` at the fixed ``c s`` of each window ``cs (K,)``
    (c.12.3 step 4), until no component moves by 1e-6 (at most ``irls_steps`` steps)."""
    for _ in range(irls_steps):
        new = pairs.solve(None, theta, cs)     # the weights (1 - u^2)^2, u = r / cs, within the sums' pass
        diff = np.abs(new - theta)
        step = float(np.max(diff[np.isfinite(diff)], initial=0.0))
        theta = new
        if step < 1e-6:                # m/s, rad/s: far below any window's noise
            break
    return theta


def sandwich(pairs: Pairs, theta: np.ndarray, cs: np.ndarray,
             s: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The M-estimator's sandwich covariance ``s^2 n / (n - p) B^-1 M B^-1`` ``(K, p, p)`` of the biweight
    fit ``theta`` (c.12.3 step 5), with ``B = sum psi'(z) a a^T`` and ``M = sum psi(z)^2 a a^T`` over the
    ``n`` pairs inside ``|u| < 1``; ``s^2 (A^T W A)^-1`` where ``B`` is not positive. Returns ``(cov,
    N_w = A^T W A (K, p, p), n (K,), w (P,))`` with ``w`` the pairs' final Tukey weights."""
    p = pairs.p
    u = pairs.residual(theta) / cs
    inside = np.abs(u) < 1.0
    t2 = np.where(inside, 1.0 - u * u, 0.0)
    w = t2 * t2
    n_in = np.rint(pairs.wsum(inside)).astype(np.int64)
    B, _ = pairs.normal(t2 * (1.0 - 5.0 * u * u))
    M, _ = pairs.normal((u * TUKEY_C * w) ** 2)          # psi(z) = z t2^2 with z = u c
    Nw, _ = pairs.normal(w)
    Bi, detB = inv_batch(B)
    Ni, _ = inv_batch(Nw)
    posB = (detB > 0) & np.all(np.einsum("kii->ki", B) > 0, axis=1)
    with np.errstate(invalid="ignore", divide="ignore"):
        C = np.where(posB[:, None, None], Bi @ M @ np.swapaxes(Bi, 1, 2) * (n_in / (n_in - p))[:, None, None],
                     Ni)                           # B not positive (rows near the rejection edge): (A^T W A)^-1
    C = 0.5 * (C + np.swapaxes(C, 1, 2)) * (s * s)[:, None, None]
    return C, Nw, n_in, w


def loewner_max(C: np.ndarray, F: np.ndarray) -> np.ndarray:
    """``C + (F - C)_+`` ``(K, p, p)``: the least upper bound of the symmetric ``C`` and ``F`` along the
    eigenvectors of their difference (the positive part of ``F - C``); PSD and ``>= C``, ``>= F`` in the
    Loewner order (c.12.3 step 5: the sandwich never below the Doppler's floor). Non-finite windows
    stay as ``C``."""
    out = C.copy()
    D = F - C
    fin = np.all(np.isfinite(D.reshape(D.shape[0], -1)), axis=1)
    if fin.any():
        lam, V = np.linalg.eigh(0.5 * (D[fin] + np.swapaxes(D[fin], 1, 2)))
        out[fin] = C[fin] + np.einsum("kij,kj,klj->kil", V, np.maximum(lam, 0.0), V)
    return out


def systematic_terms(pairs: Pairs, theta: np.ndarray, cs: np.ndarray, rows: np.ndarray, dt: np.ndarray,
                     G: np.ndarray, sensor: np.ndarray, n_sensors: int) -> tuple[np.ndarray, np.ndarray]:
    """The fit's first-order response to what the sandwich does not see (c.12.3 step 5b), ``(T (K, p, p),
    J (K, p, S))``: ``theta_hat - theta(t_c) = T theta_dot`` when the motion changes linearly within the
    window (``T = H^-1 sum h_i dt_i a_i a_i^T``, ``dt_i`` each pair's time from its window's centre), and
    ``d theta_hat / d psi_s = J[:, :, s] = H^-1 sum_{i in s} h_i a_i (g_i^T theta)`` for a yaw error of
    radar ``s``'s mounting (``g_i = d a_i / d psi``, the rows of ``G``). ``H`` and ``h`` are the bread of
    the sandwich: ``B`` and ``psi'`` where ``B`` is positive, else ``A^T W A`` and the Tukey weights."""
    K, p = pairs.K, pairs.p
    u = pairs.residual(theta) / cs
    inside = np.abs(u) < 1.0
    t2 = np.where(inside, 1.0 - u * u, 0.0)
    hB, hW = t2 * (1.0 - 5.0 * u * u), t2 * t2
    B, _ = pairs.normal(hB)
    Bi, detB = inv_batch(B)
    posB = (detB > 0) & np.all(np.einsum("kii->ki", B) > 0, axis=1)
    Nw, _ = pairs.normal(hW)
    Hi = np.where(posB[:, None, None], Bi, inv_batch(Nw)[0])
    h = np.where(posB[pairs.win], hB, hW)
    Nt, _ = pairs.normal(h * dt)
    T = Hi @ Nt
    a = pairs._A[rows]
    gth = np.einsum("ij,ij->i", G[rows], theta[pairs.win])          # g_i^T theta: the Doppler's change per rad
    key = pairs.win * n_sensors + sensor[rows]
    S = np.zeros((K * n_sensors, p))
    for j in range(p):
        S[:, j] = np.bincount(key, weights=h * gth * a[:, j], minlength=K * n_sensors)
    J = Hi @ np.swapaxes(S.reshape(K, n_sensors, p), 1, 2)
    return T, J


def fit_chunk(A, d, lo, hi, rng, hypotheses, sample, threshold, sigma_floor, min_fraction, irls_steps, aux=None):
    """Fit the windows ``lo[k]:hi[k]`` (each of at least p + 2 rows) of one chunk (c.12.3).
    Returns ``(theta (K, p), cov (K, p, p), status (K,), sigma (K,), n_in (K,), w (P,), extra)`` with ``w``
    the final weights of the window-detection pairs, window after window, and ``extra`` None or (with
    ``aux = (t, t_c, G, sensor, n_sensors)``) the ``(T, J)`` of :func:`systematic_terms`. ``cov`` is
    the sandwich, never below ``sigma_floor^2 (A^T W A)^-1`` (:func:`loewner_max`)."""
    pairs = Pairs(A, d, lo, hi)
    K, p, m = pairs.K, pairs.p, pairs.m
    status = np.zeros(K, dtype=np.int64)
    theta = np.full((K, p), np.nan)
    cov = np.full((K, p, p), np.nan)
    sigma = np.full(K, np.nan)
    # 0. does the window observe every direction of theta at all? (one radar: no, c.12.2)
    N, _ = pairs.normal(np.ones(pairs.P))
    status[corr_det(N) <= RANK_TOL] = UNOBSERVABLE
    # 1.-2. RANSAC, least squares on its consensus
    th = consensus_fit(pairs, ransac(pairs, A, d, rng, hypotheses, sample, threshold), threshold)
    # 3. robust scale
    s, k_cons = robust_scale(pairs, th, threshold, sigma_floor)
    status[(k_cons < p + 2) & (status == OK)] = NO_CONSENSUS
    # 4. Tukey's biweight by IRLS at the fixed scale s; 5. its sandwich covariance
    cs = TUKEY_C * s
    th = biweight(pairs, th, cs, irls_steps)
    C, Nw, n_in, w = sandwich(pairs, th, cs[pairs.win], s)
    # 5a. the floor (c.12.3): the sandwich's own residuals can be below the Doppler's quantisation (exact
    # or quantised readings give M ~ 0), never the covariance below sigma_floor^2 (A^T W A)^-1
    with np.errstate(invalid="ignore", divide="ignore"):
        C = loewner_max(C, inv_batch(Nw)[0] * sigma_floor ** 2)
    extra = None
    if aux is not None:
        t, t_c, G, sensor, n_sensors = aux
        rows = np.repeat(lo - pairs.start, m) + np.arange(pairs.P)
        with np.errstate(invalid="ignore", divide="ignore"):
            extra = systematic_terms(pairs, th, cs[pairs.win], rows, t[rows] - t_c[pairs.win], G, sensor,
                                     n_sensors)
    # 6. valid when n >= p + 2, n >= min_fraction m and the rank is full
    cdet = corr_det(Nw)
    status[(status == OK) & ((n_in < p + 2) | (n_in < min_fraction * m))] = NO_CONSENSUS
    status[(status == OK) & (cdet <= RANK_TOL)] = UNOBSERVABLE
    status[(status == OK) & ~np.all(np.isfinite(C.reshape(K, -1)), axis=1)] = UNOBSERVABLE
    ok = status == OK
    theta[ok], cov[ok] = th[ok], C[ok]
    sigma[k_cons >= p + 2] = s[k_cons >= p + 2]
    return theta, cov, status, sigma, n_in, w, extra


def fit_windows(A, d, lo, hi, rng, hypotheses, sample, threshold, sigma_floor, min_fraction, irls_steps,
                keep_weights=False, aux=None):
    """:func:`fit_chunk` over every window in chunks of at most :data:`CHUNK_ROWS` pairs; windows
    with fewer than p + 2 rows are ``TOO_FEW``. With ``aux = (t (n,), t_c (K,), G (n, p), sensor (n,),
    S)`` also returns ``T (K, p, p)`` and ``J (K, p, S)`` (:func:`systematic_terms`; NaN where not fitted)."""
    K, p = lo.size, A.shape[1]
    theta = np.full((K, p), np.nan)
    cov = np.full((K, p, p), np.nan)
    status = np.full(K, TOO_FEW, dtype=np.int64)
    sigma = np.full(K, np.nan)
    n_in = np.zeros(K, dtype=np.int64)
    T = J = None
    if aux is not None:
        T, J = np.full((K, p, p), np.nan), np.full((K, p, int(aux[4])), np.nan)
    weights = []
    m = hi - lo
    fit = np.flatnonzero(m >= p + 2)
    cum = np.cumsum(m[fit])
    a = 0
    while a < fit.size:
        b = max(int(np.searchsorted(cum, (cum[a - 1] if a else 0) + CHUNK_ROWS, side="right")), a + 1)
        ks = fit[a:b]
        sub = None if aux is None else (aux[0], np.asarray(aux[1])[ks], *aux[2:])
        out = fit_chunk(A, d, lo[ks], hi[ks], rng, hypotheses, sample, threshold, sigma_floor, min_fraction,
                        irls_steps, sub)
        theta[ks], cov[ks], status[ks], sigma[ks], n_in[ks] = out[:5]
        if keep_weights:
            weights.append(out[5])
        if aux is not None:
            T[ks], J[ks] = out[6]
        a = b
    w = np.concatenate(weights) if weights else np.zeros(0)
    if aux is None:
        return theta, cov, status, sigma, n_in, w
    return theta, cov, status, sigma, n_in, w, T, J

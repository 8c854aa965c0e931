"""The consensus of many windows of a rig's Doppler at once (docs/method.md c.12.3, steps 1 and 2),
vectorised over windows: the window-detection pairs of a chunk of windows and their weighted normal
equations (:class:`Pairs`), RANSAC on minimal sets (:func:`ransac`) and the least squares on its
consensus (:func:`consensus_fit`). :mod:`radarslam.models._rig_robust` builds the robust fit on them;
:func:`radarslam.models.rig_velocity.fit_rig_velocity` and ``fit_rig_windows`` call that.

Every step is a numpy call over all windows of a chunk, or (the sums over each window's pairs and the
pairs' residuals) one compiled pass over the rows of each window in place
(:mod:`radarslam.models._doppler_compiled`), so a recording of a million detections costs a few passes
and no loop in Python per window.
"""

from __future__ import annotations

import numpy as np

from radarslam.models import _doppler_compiled as _C

#: RANSAC's first round of minimal sets per window, and the probability of an all-static set that
#: ends it (c.12.3): at 90% static detections 7 sets of 3 reach it.
FIRST_SETS, CONFIDENCE = 12, 0.9999


def inv_batch(M: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Inverses ``(K, p, p)`` and determinants ``(K,)`` of a stack of 2 x 2 or 3 x 3 matrices
    (adjugate over the determinant; a zero determinant gives inf/NaN, for the caller to mask)."""
    with np.errstate(divide="ignore", invalid="ignore"):
        if M.shape[-1] == 2:
            det = M[..., 0, 0] * M[..., 1, 1] - M[..., 0, 1] * M[..., 1, 0]
            adj = np.stack([np.stack([M[..., 1, 1], -M[..., 0, 1]], -1),
                            np.stack([-M[..., 1, 0], M[..., 0, 0]], -1)], -2)
            return adj / det[..., None, None], det
        r0, r1, r2 = M[..., 0, :], M[..., 1, :], M[..., 2, :]
        c0 = np.cross(r1, r2)
        det = np.einsum("...i,...i->...", r0, c0)
        inv = np.stack([c0, np.cross(r2, r0), np.cross(r0, r1)], -1)   # A c_j = det e_j
        return inv / det[..., None, None], det


def corr_det(N: np.ndarray) -> np.ndarray:
    """Determinants ``(K,)`` of the information matrices ``N (K, p, p)`` normalised to a unit diagonal."""
    dg = np.sqrt(np.maximum(np.einsum("kii->ki", N), 0.0))
    with np.errstate(divide="ignore", invalid="ignore"):
        C = N / (dg[:, :, None] * dg[:, None, :])
    _, det = inv_batch(np.where(np.isfinite(C), C, 0.0))
    return np.where(np.all(dg > 0, axis=1), det, 0.0)


class Pairs:
    """The (window, detection) pairs of the windows ``lo[k]:hi[k]`` of one chunk, window after window,
    and sums over each window's pairs (c.12.4).

    Attributes
    ----------
    K, p, P : int
        Windows, unknowns (3, or 2 without sideslip), pairs.
    lo, m, start : ndarray of int, shape (K,)
        Each window's first row of ``A``, its rows, its first pair.
    win : ndarray of int, shape (P,)
        Each pair's window.
    """

    def __init__(self, A: np.ndarray, d: np.ndarray, lo: np.ndarray, hi: np.ndarray):
        K, p = lo.size, A.shape[1]
        m = np.ascontiguousarray(hi - lo, dtype=np.int64)
        start = np.concatenate([[0], np.cumsum(m)[:-1]])
        P = int(m.sum())
        iu = np.triu_indices(p)
        self.K, self.p, self.P, self.lo, self.m, self.start = K, p, P, lo, m, start
        self.win = np.repeat(np.arange(K), m)
        # the pairs are never copied out: the compiled sums read each window's rows of A and d in place
        self._A, self._d = np.ascontiguousarray(A, dtype=float), np.ascontiguousarray(d, dtype=float)
        self._lo = np.ascontiguousarray(lo, dtype=np.int64)
        self._iu = iu
        self._q = iu[0].size

    def wsum(self, w: np.ndarray) -> np.ndarray:
        """``sum w`` over each window's pairs, ``(K,)``."""
        return _C.segment_sum(self.m, np.ascontiguousarray(w, dtype=float))

    def normal(self, w: np.ndarray | None, theta: np.ndarray | None = None,
               cs: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
        """``N = sum w a a^T (K, p, p)``, ``g = sum w a d (K, p)`` per window (c.12.3): one pass. With ``w``
        None, the weights are Tukey's at ``theta (K, p)`` and the scale ``cs (K,)`` of each window
        (:func:`radarslam.models._doppler_compiled.rig_normal`)."""
        K, p, iu, q = self.K, self.p, self._iu, self._q
        tukey = w is None
        S = _C.rig_normal(self._A, self._d, self._lo, self.m,
                          np.zeros(0) if tukey else np.ascontiguousarray(w, dtype=float),
                          np.ascontiguousarray(theta if tukey else np.zeros((0, p)), dtype=float),
                          np.ascontiguousarray(cs if tukey else np.zeros(0), dtype=float), tukey)
        N = np.empty((K, p, p))
        N[:, iu[0], iu[1]] = S[:, :q]
        N[:, iu[1], iu[0]] = S[:, :q]
        return N, S[:, q:]

    def residual(self, theta: np.ndarray) -> np.ndarray:
        """``d - a^T theta`` of every pair at its window's ``theta (K, p)``, ``(P,)``."""
        return _C.rig_residual(self._A, self._d, self._lo, self.m, np.ascontiguousarray(theta, dtype=float))

    def solve(self, w: np.ndarray | None, theta: np.ndarray, cs: np.ndarray | None = None) -> np.ndarray:
        """Weighted least squares ``N^-1 g`` of every window at the pairs' weights ``w`` (None: Tukey's at
        ``theta`` and the scale ``cs (K,)``, :meth:`normal`); ``theta`` kept where ``N`` is (nearly) singular."""
        N, g = self.normal(w, theta, cs)
        Ni, det = inv_batch(N)
        ok = np.abs(det) > 1e-12
        return np.where(ok[:, None], np.einsum("kij,kj->ki", np.where(ok[:, None, None], Ni, 0.0), g), theta)


def ransac(pairs: Pairs, A: np.ndarray, d: np.ndarray, rng: np.random.Generator, hypotheses: int, sample: int,
           threshold: float) -> np.ndarray:
    """RANSAC's best minimal-set solution ``(K, p)`` of every window (c.12.3 step 1): minimal sets of p
    rows, each scored on ``sample`` rows of its window (all rows when the window has no more), ties
    broken by the smaller sum of squares. Adaptive as Hartley & Zisserman's alg. 4.5, in two rounds:
    :data:`FIRST_SETS` sets for every window, then up to ``hypotheses`` for the windows whose best
    consensus so far does not yet give an all-static set with probability :data:`CONFIDENCE`."""
    K, p, lo, m = pairs.K, pairs.p, pairs.lo, pairs.m
    small = m <= sample
    s_off = np.where(small[:, None], np.arange(sample)[None, :] % m[:, None],
                     np.floor(rng.random((K, sample)) * m[:, None]).astype(np.int64))
    s_use = np.where(small[:, None], np.arange(sample)[None, :] < m[:, None], True)
    s_row = lo[:, None] + s_off
    n_scored = np.minimum(m, sample)
    As, ds = np.swapaxes(A[s_row], 1, 2), d[s_row]

    def best_of(ks, H):
        pick = lo[ks, None, None] + np.floor(rng.random((ks.size, H, p)) * m[ks, None, None]).astype(np.int64)
        Minv, det = inv_batch(A[pick])
        good = np.abs(det) > 1e-9
        hyp = np.where(good[..., None], np.einsum("khij,khj->khi", Minv, d[pick]), 0.0)
        R = ds[ks][:, None, :] - hyp @ As[ks]      # (k, H, S)
        R *= R
        inl = (R <= threshold * threshold) & s_use[ks][:, None, :]
        cnt = inl.sum(-1)
        score = np.where(good, cnt - (R * inl).sum(-1) / (sample * threshold * threshold + 1.0), -1.0)  # ties: RSS
        j = np.argmax(score, axis=1)
        i = np.arange(ks.size)
        return score[i, j], hyp[i, j]

    all_k = np.arange(K)
    score, th = best_of(all_k, min(FIRST_SETS, hypotheses))
    frac = np.clip(np.floor(score) / n_scored, 0.0, 1.0) ** p
    with np.errstate(divide="ignore"):
        needed = np.where(frac >= 1.0, 0.0, np.log(1.0 - CONFIDENCE) / np.log1p(-np.minimum(frac, 1.0 - 1e-16)))
    more = all_k[(needed > FIRST_SETS) & (hypotheses > FIRST_SETS)]
    if more.size:
        sc2, th2 = best_of(more, hypotheses - FIRST_SETS)
        better = sc2 > score[more]
        th[more[better]] = th2[better]
    return th


def consensus_fit(pairs: Pairs, theta: np.ndarray, threshold: float) -> np.ndarray:
    """Least squares ``(K, p)`` on the consensus ``|r| <= threshold`` of ``theta``, refined once on its
    own consensus (c.12.3 step 2, as c.10.2)."""
    for _ in range(2):
        w = (np.abs(pairs.residual(theta)) <= threshold).astype(float)
        theta = pairs.solve(w, theta)
    return theta

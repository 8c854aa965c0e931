"""Running EKF-SLAM over a recorded dataset (``radarslam run --dataset NAME PATH``).

A dataset is run as a recording is: its loaded data is the run's input, its event stream goes
through the one filter run of a recorded stream (:func:`~radarslam.runs.stream_run.run_stream`),
and the run is the one run type, :class:`~radarslam.runs.recording.RecordingRun`, with the GPS
and the reference detector's hits beside the record. The evaluations below take that run."""

from __future__ import annotations

import math
import sys
import time
import warnings

import numpy as np

from radarslam.config import Config, validate
from radarslam.core.errors import InputError
from radarslam.core.registry import EXTENT_ESTIMATORS
from radarslam.core.types import Odometry, Scan
from radarslam.extent.ellipse import trunk_diameter  # noqa: F401  (re-exported: its former home)
from radarslam.core.mounting import Mounting
from radarslam.metrics.alignment import error_against_fixes
from radarslam.models.radar import polar_to_xy
from radarslam.runs.recording import RecordingRun
from radarslam.runs.stream_run import refuse_drawn_start, run_stream
from radarslam.slam.driver import Observer
from radarslam.compiling.stream_plan import first_run_plan

#: Radius (m) within which a reference trunk detection is attributed to the nearest landmark.
#: Trunks in the park stand metres apart; a landmark centroid sits about pi d / 8 (< 0.4 m for
#: d < 1 m) in front of the trunk centre (the visible-arc mean), so 0.6 m keeps neighbours apart.
REFERENCE_GATE_M = 0.6


def __getattr__(name: str):
    """``DatasetRun``, the former run type of a dataset: now :class:`RecordingRun` (deprecated name)."""
    if name == "DatasetRun":
        warnings.warn("radarslam.runs.dataset.DatasetRun is now radarslam.runs.recording.RecordingRun, the one run "
                      "type of a recording or a dataset; import that", DeprecationWarning, stacklevel=2)
        return RecordingRun
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def victoria_park_options(config: Config, input: str = "laser", **extra) -> dict:
    """Loader options of a Victoria Park run with ``config``: the input mode and the detection range
    the filter's M/N test assumes (``filter.max_range_m``), plus ``extra`` (e.g. ``laser_time_offset``)."""
    return {"input": input, "max_range": config.filter.max_range_m, **extra}


def run_dataset(name: str, path, config: Config, *, first_scan: int | None = None, n_scans: int | None = None,
                progress: bool = True, loader_options: dict | None = None) -> RecordingRun:
    """Load dataset ``name`` from ``path`` and run the filter over its event stream as a
    recording's is run (:func:`~radarslam.runs.stream_run.run_stream`): a :class:`RecordingRun`
    whose ``recording`` is the loaded data, with its ``gps`` and, in Victoria Park's laser mode,
    ACFR's tree detections attributed to the landmarks after each scan (``reference_hits``); the
    map is kept after the last scan only, and ``metrics`` holds ``load_seconds``.

    The whole stream runs through the fused engine (docs/architecture.md "The fused engine"). On a
    machine whose compiled code is not built yet, :func:`first_run_plan` picks what ends sooner (the
    engine's steps or Python form, the same run) and says so on the first line of stderr."""
    from radarslam.runs.progress import Progress, scan_clock
    from radarslam.io.datasets import get_dataset

    config = validate(config)
    refuse_drawn_start(config)                  # b.5: a draw needs the true first pose of a simulation
    t0 = time.perf_counter()
    data = get_dataset(name)(path, first_scan=first_scan, n_scans=n_scans, **(loader_options or {}))
    load_s = time.perf_counter() - t0
    n = sum(isinstance(e, Scan) for e in data.events)
    trees = getattr(data, "trees", None)
    if getattr(data, "options", {}).get("input") == "trees":
        trees = None      # the trees are the input: there is no independent reference to attribute
    hits = _ReferenceHits(_Reference(trees, config.filter.max_range_m))
    plan = first_run_plan(config, n, bool(config.filter.fused))
    if plan.announce and progress:
        print(f"run: {plan.announce}", file=sys.stderr, flush=True)
    fused = plan.engine == "fused"
    # fused: the bar moves part by part (slam/fused/chunks.py), its clock from the run's start; event by
    # event, its first scan carries the imports and the compile
    bar = Progress(n, 0, enabled=progress, unit="scans", warm_up_unit=not fused)
    record = run_stream(config, data.events, plan, observers=[hits], maps="last",
                        on_scan=None if fused else scan_clock(bar), on_scans=bar.update if fused else None,
                        heartbeat=progress)
    if plan.engine == "python":
        record.engine = "python"                # the reference, also under filter.backend "python"
    ref = (np.concatenate(hits.hits) if hits.hits else np.empty((0, 3))) if trees is not None else None
    return RecordingRun(config, data, Mounting.from_config(config.sensor), data.events, record.times, record, None,
                        {"load_seconds": load_s}, name=name, gps=getattr(data, "gps", None), reference_hits=ref)


class _Reference:
    """A reference tree detector's detections by scan index (ACFR's, in laser mode), or none."""

    def __init__(self, trees, max_range: float):
        self.trees, self.max_range = trees, max_range
        self.rows = {int(i): r for r, i in enumerate(trees.index)} if trees is not None else {}

    def hits(self, scan_index: int, pose: np.ndarray, positions: np.ndarray, ids: np.ndarray) -> np.ndarray | None:
        """The scan's detections attributed to the landmarks (:func:`_attribute_reference`), or None."""
        row = self.rows.get(scan_index)
        if row is None or not ids.size:
            return None
        h = _attribute_reference(pose, positions, ids, self.trees.row(row), self.max_range)
        return h if h.size else None


class _ReferenceHits(Observer):
    """The reference detections attributed to the landmarks after each scan that has some."""

    def __init__(self, reference: _Reference):
        self.reference, self.hits = reference, []

    def scan_mask(self, scans):
        return np.array([int(ev.index) in self.reference.rows for ev in scans], dtype=bool)

    def after_scan(self, k, slam, scan, report):
        lm = slam.x[slam.x.shape[0] - 2 * slam.state.n_landmarks:].reshape(-1, 2)   # the last 2N entries (c.11)
        self._add(self.reference.hits(int(scan.index), slam.x[:3], lm, slam.state.ids()))

    def after_fused(self, slam, scans, result, associations):
        off = result["trace_offsets"]
        for s in np.flatnonzero(self.scan_mask(scans)).tolist():
            a, b = int(off[s]), int(off[s + 1])
            self._add(self.reference.hits(int(scans[s].index), result["poses"][s], result["trace_positions"][a:b],
                                          result["trace_ids"][a:b]))

    def _add(self, h) -> None:
        if h is not None:
            self.hits.append(h)


def dead_reckoning(data, config: Config) -> tuple[np.ndarray, np.ndarray]:
    """Odometry alone through the filter's motion model: ``(scan times (K,), poses (K, 3))``.

    The baseline SLAM has to beat; it starts from ``config.filter.initial_pose``.
    """
    from radarslam.models.motion import motion_model_from_config

    f = config.filter
    model = motion_model_from_config(f)
    pose = np.array(f.initial_pose, dtype=float)
    times, poses = [], []
    for ev in data.events:
        if isinstance(ev, Odometry):
            pose = model.step(pose, np.asarray(ev.control, dtype=float), ev.dt)
        else:
            times.append(ev.t)
            poses.append(pose.copy())
    return np.array(times), np.array(poses).reshape(-1, 3)


def _attribute_reference(pose: np.ndarray, positions: np.ndarray, ids: np.ndarray, det: np.ndarray,
                         max_range: float) -> np.ndarray:
    """Attribute one scan's reference trunk detections ``det`` ``[range, bearing, diameter]`` to the
    nearest current landmark (centroids ``positions (N, 2)``, ``ids (N,)``, N >= 1), in the world
    frame of the current estimate ``pose`` (where pose and map agree).

    Returns rows ``[landmark id, diameter, distance]`` for detections within :data:`REFERENCE_GATE_M`.
    """
    det = det[det[:, 0] < max_range]
    if not det.size:
        return np.empty((0, 3))
    pts = polar_to_xy(pose, det[:, :2])
    d2 = ((pts[:, None, :] - positions[None, :, :]) ** 2).sum(axis=-1)
    j = np.argmin(d2, axis=1)
    dist = np.sqrt(d2[np.arange(j.size), j])
    ok = dist <= REFERENCE_GATE_M
    return np.column_stack([np.asarray(ids)[j[ok]].astype(float), det[ok, 2], dist[ok]])


def compare_tree_diameters(run: RecordingRun, *, min_detections: int = 3) -> dict:
    """Trunk diameters of the final map against a reference tree detector (ACFR's ``detectTreesI16``).

    Every reference detection was attributed online to its nearest landmark (:func:`run_dataset`);
    a final-map landmark with an extent and at least ``min_detections`` attributed detections is a
    matched tree, and its reference diameter is their median. Landmarks merged away take their
    attributions with them.

    The run's extent estimator reads its extent and its baseline as diameters
    (``round_diameter``, ``baseline_round_diameter``): ``"visible-arc"`` its circle
    (``d = 2 sqrt(lambda)``, docs/method.md a.9) with the RMA matrix as baseline; ``"rma-efa"`` the
    RMA matrix through :func:`~radarslam.extent.ellipse.trunk_diameter`, with the EFA baseline.

    Returns
    -------
    dict
        ``estimator``, ``n_matched``, ``median_abs_diff_m``, ``mean_abs_diff_m``, ``median_ratio``
        (estimate / reference), ``spearman`` (rank correlation), ``median_reference_m``,
        ``median_estimate_m``, the baseline's ``baseline_median_abs_diff_m`` and ``baseline_spearman``,
        and per-tree arrays ``ids``, ``estimate_m``, ``baseline_m``, ``reference_m``, ``n_detections``.
    """
    if run.reference_hits is None:
        raise InputError(f"run: expected a run with reference tree detections, got none for {run.name!r}")
    if min_detections < 1:
        raise InputError(f"min_detections: expected an integer >= 1, got {min_detections!r}")
    mp = run.final_map
    try:
        estimator = EXTENT_ESTIMATORS.create(run.config.extent.estimator, run.config)
        read, read_base = estimator.round_diameter, estimator.baseline_round_diameter
    except AttributeError:
        raise InputError(f"extent.estimator: expected an estimator that reads round-object diameters "
                         f"(round_diameter, baseline_round_diameter), got {run.config.extent.estimator!r}") from None
    ok = np.all(np.isfinite(mp.rma.reshape(-1, 4)), axis=1)
    est_d = read(mp.rma[ok])
    base_d = read_base(np.where(np.isfinite(mp.efa[ok]), mp.efa[ok], 0.0))
    d_est = dict(zip(mp.ids[ok].tolist(), est_d.tolist()))
    d_base = dict(zip(mp.ids[ok].tolist(), base_d.tolist()))
    hits = run.reference_hits
    ids, est, bas, ref, cnt = [], [], [], [], []
    order = np.argsort(hits[:, 0], kind="stable")
    uid, start = np.unique(hits[order, 0], return_index=True)
    for i, d in zip(uid.astype(int).tolist(), np.split(hits[order, 1], start[1:])):
        if i in d_est and d.size >= min_detections:
            ids.append(i), est.append(d_est[i]), bas.append(d_base[i]), ref.append(float(np.median(d)))
            cnt.append(d.size)
    est, bas, ref = np.array(est), np.array(bas), np.array(ref)
    out = {"estimator": estimator.name, "baseline": estimator.baseline_name, "n_matched": len(ids),
           "n_landmarks_with_extent": int(ok.sum()), "min_detections": min_detections, "gate_m": REFERENCE_GATE_M,
           "ids": np.array(ids, dtype=int), "estimate_m": est, "baseline_m": bas, "reference_m": ref,
           "n_detections": np.array(cnt, dtype=int)}
    if ids:
        from scipy.stats import spearmanr

        err = np.abs(est - ref)
        out.update(median_abs_diff_m=float(np.median(err)), mean_abs_diff_m=float(err.mean()),
                   median_ratio=float(np.median(est / ref)), median_reference_m=float(np.median(ref)),
                   median_estimate_m=float(np.median(est)), baseline_median_abs_diff_m=float(np.median(np.abs(bas - ref))),
                   spearman=float(spearmanr(est, ref).statistic) if len(ids) > 2 else float("nan"),
                   baseline_spearman=float(spearmanr(bas, ref).statistic) if len(ids) > 2 else float("nan"))
    return out


#: Radii (m) at which :func:`duplicate_landmarks` also counts pairs of landmarks.
DUPLICATE_RADII_M = (1.0, 1.5, 2.0, 3.0)


def duplicate_landmarks(run: RecordingRun, diameter_m: float | None = None) -> dict:
    """Pairs of final landmarks closer than a trunk diameter: one trunk mapped twice.

    ``diameter_m`` defaults to the median reference diameter of the run's trees (ACFR's detector),
    else 0.42 m, the median over the whole recording. Merging (c.9) removes every pair closer than
    ``landmarks.merge_distance_m`` (0.8 m in the Victoria Park profiles), so that count is zero by
    construction there; ``pairs_within`` also counts the pairs within 1, 1.5, 2 and 3 m, where trees
    mapped twice show (the park's trunks mostly stand metres apart: ACFR's detections give no pair
    within 3 m). Returns ``n_pairs``, ``n_landmarks``, ``diameter_m``, ``pairs_within`` (radius in m
    -> count) and the ``pairs`` of ids closer than a diameter.
    """
    mp = run.final_map
    if diameter_m is None:
        tr = getattr(run.recording, "trees", None)
        diameter_m = float(np.nanmedian(tr.diameters)) if tr is not None and np.any(tr.valid) else 0.42
    if not diameter_m > 0:
        raise InputError(f"diameter_m: expected a positive number, got {diameter_m!r}")
    from radarslam.landmarks.merging import merge_candidates

    pairs = merge_candidates(mp.positions, max(diameter_m, *DUPLICATE_RADII_M))   # one search, nearest first
    d = np.array([p[2] for p in pairs])
    within = {r: int(np.sum(d < r)) for r in DUPLICATE_RADII_M}
    close = [(int(mp.ids[i]), int(mp.ids[j])) for i, j, dij in pairs if dij < diameter_m]
    return {"n_pairs": len(close), "n_landmarks": int(mp.ids.size), "diameter_m": float(diameter_m),
            "pairs_within": within, "pairs": close}


def _gps(run: RecordingRun):
    """The run's position fixes (``run.gps``), refused in one line when it has none."""
    if run.gps is None:
        raise InputError(f"run: expected a run with GPS fixes (gps), got none for {run.name!r}")
    return run.gps


def evaluate_published(run: RecordingRun, poses: np.ndarray | None = None) -> dict:
    """The published protocol (docs/method.md v.4): no alignment; the error at every scan within
    25 ms of a GPS fix, over the unfiltered fixes. The run must have started at the first fix in the
    GPS frame (``--protocol published``)."""
    from radarslam.io.datasets.victoria_park import PUBLISHED_TOLERANCE_S
    from radarslam.metrics.alignment import error_at_fixes

    gps = _gps(run)
    poses = run.poses if poses is None else np.asarray(poses)
    return error_at_fixes(run.times, poses[:, :2], np.asarray(gps.t), np.asarray(gps.xy), PUBLISHED_TOLERANCE_S)


def evaluate_against_gps(run: RecordingRun, poses: np.ndarray | None = None) -> dict:
    """GPS-aligned position error of the estimated sensor track (the antenna sits at the laser).

    GPS jumps are removed by the fixes' own implied speed (> 8 m/s; the car's top speed is about
    6.6 m/s); the remaining fixes are aligned by least squares with no residual-based rejection.
    ``poses (K, 3)`` at the run's scan times replaces the estimate (e.g. :func:`dead_reckoning`).
    """
    gps = _gps(run)
    poses = run.poses if poses is None else np.asarray(poses)
    return error_against_fixes(run.times, poses[:, :2], np.asarray(gps.t), np.asarray(gps.xy),
                               robust=False, max_speed=8.0)


#: Two-sided probability of the NIS band on real data (docs/method.md v.6).
NIS_BAND_PROBABILITY = 0.95


def nis_fraction(run: RecordingRun, *, window: int = 100) -> dict:
    """The NIS of every association update of a run against its chi-square band (2 dof each).

    A consistent filter's NIS is chi-square with 2 degrees of freedom, so 95% of the updates fall
    within ``[chi2.ppf(0.025, 2), chi2.ppf(0.975, 2)] = [0.051, 7.38]`` and the mean is 2. Returns
    ``n``, ``mean``, ``median``, ``inside`` / ``below`` / ``above`` (fractions of the updates), the
    ``band``, and per ``window`` scans the series ``window_scan`` (first scan position), ``window_mean``
    and ``window_inside`` for the figure. All NaN with no updates.
    """
    from radarslam.extent.sifting import chi2_2dof_quantile

    if run.nis is None:
        raise InputError(f"run: expected a run with recorded NIS, got none for {run.name!r}")
    if isinstance(window, bool) or not isinstance(window, int) or window < 1:
        raise InputError(f"window: expected an integer >= 1, got {window!r}")
    lo, hi = (chi2_2dof_quantile((1 - NIS_BAND_PROBABILITY) / 2), chi2_2dof_quantile((1 + NIS_BAND_PROBABILITY) / 2))
    scan, q = run.nis[:, 0], run.nis[:, 1]
    out = {"n": int(q.size), "band": (float(lo), float(hi)), "probability": NIS_BAND_PROBABILITY}
    if not q.size:
        nan = float("nan")
        return {**out, "mean": nan, "median": nan, "inside": nan, "below": nan, "above": nan,
                "window_scan": np.empty(0), "window_mean": np.empty(0), "window_inside": np.empty(0)}
    inside = (q >= lo) & (q <= hi)
    w = (scan // window).astype(int)
    ws = np.unique(w)
    return {**out, "mean": float(q.mean()), "median": float(np.median(q)), "inside": float(inside.mean()),
            "below": float(np.mean(q < lo)), "above": float(np.mean(q > hi)), "window_scan": ws * window,
            "window_mean": np.array([q[w == k].mean() for k in ws]),
            "window_inside": np.array([inside[w == k].mean() for k in ws])}


#: The GPS's own error (m, std per axis) that :func:`position_consistency` adds to the filter's
#: bound (docs/method.md v.7): the fixes wander by 0.2-0.6 m (std per axis) while the car stands
#: still for 10-18 s (t = 814-832 s, 1539-1549 s), and ACFR's note calls the unit failing (jumps,
#: slow multipath drifts of metres); 1 m is the value this project states, not a fitted one.
GPS_STD_M = 1.0
#: Two-sided probability of "within 2 sigma" of one Gaussian axis, and the chi-square(2) quantile
#: of the same probability for the error ellipse.
TWO_SIGMA_PROBABILITY = 0.9545


def position_consistency(run: RecordingRun, published: dict, gps_std_m: float = GPS_STD_M) -> dict:
    """The filter's position covariance against the GPS error of the published protocol (v.7).

    At every scan of ``published`` (:func:`evaluate_published`: ``index``, ``fix``) the error
    ``e = p_hat - p_GPS`` (east, north) is compared with the filter's position covariance ``P_xy``
    plus twice the GPS's own ``g^2 I`` (``g = gps_std_m``): once for the fix compared with and once
    for the first fix, where the published protocol starts the filter (a translation of the whole
    estimate, which the filter's initial std of 0.01 m leaves out and which changes no estimate:
    EKF-SLAM is invariant to it, tested). Per axis ``|e_i| <= 2 sqrt(P_ii + 2 g^2)`` (95.45% for a
    consistent filter and a GPS of that std), both axes at once, and the ellipse
    ``e^T (P_xy + 2 g^2 I)^-1 e <= chi2_2(0.9545) = 6.18``; also with ``g = 0`` (the filter alone).

    Returns ``t`` (K,), ``error_m`` (K, 2), ``sigma_filter_m`` (K, 2), ``gps_std_m``, the fractions
    ``inside_east``, ``inside_north``, ``inside_both``, ``inside_ellipse``, ``inside_both_filter_only``,
    ``mean_mahalanobis2`` (2 expected) and ``n``.
    """
    from radarslam.extent.sifting import chi2_2dof_quantile

    if not (isinstance(gps_std_m, (int, float)) and math.isfinite(gps_std_m) and gps_std_m >= 0):
        raise InputError(f"gps_std_m: expected a finite number >= 0, got {gps_std_m!r}")
    idx, fix = np.asarray(published["index"], dtype=int), np.asarray(published["fix"], dtype=int)
    e = run.poses[idx, :2] - np.asarray(_gps(run).xy, dtype=float)[fix]
    Pf = run.pose_covs[idx, :2, :2]
    var_f = np.stack([Pf[:, 0, 0], Pf[:, 1, 1]], axis=1)
    sig = np.sqrt(var_f + 2.0 * gps_std_m ** 2)
    inside = np.abs(e) <= 2.0 * sig
    C = Pf + 2.0 * gps_std_m ** 2 * np.eye(2)
    m2 = np.einsum("ki,kij,kj->k", e, np.linalg.inv(C), e) if idx.size else np.empty(0)
    frac = (lambda a: float(np.mean(a)) if a.size else float("nan"))
    return {"n": int(idx.size), "t": run.times[idx], "error_m": e, "sigma_filter_m": np.sqrt(var_f),
            "gps_std_m": float(gps_std_m), "inside_east": frac(inside[:, 0]), "inside_north": frac(inside[:, 1]),
            "inside_both": frac(inside.all(axis=1)),
            "inside_ellipse": frac(m2 <= chi2_2dof_quantile(TWO_SIGMA_PROBABILITY)),
            "inside_both_filter_only": frac((np.abs(e) <= 2.0 * np.sqrt(var_f)).all(axis=1)),
            "mean_mahalanobis2": frac(m2), "probability": TWO_SIGMA_PROBABILITY}

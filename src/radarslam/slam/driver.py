"""The one event driver: a stream of odometry and scans through :class:`EkfSlam`, the estimate
recorded after every scan (docs/architecture.md "The path of a recording"). The fused engine runs
the whole stream in one compiled call where it covers the configuration; the orchestrator runs it
event by event; both give the same :class:`FilterRecord`."""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np

from radarslam.config import Config
from radarslam.core.errors import ConfigError
from radarslam.core.types import Odometry, Scan
from radarslam.slam import _fused
from radarslam.slam.filter import EkfSlam, MapSnapshot


@dataclass
class FilterRecord:
    """What the filter estimated after every scan.

    Attributes
    ----------
    poses : ndarray (K, 3)
    pose_covs : ndarray (K, 3, 3)
    maps : list of MapSnapshot
    n_detections, n_associated, n_landmarks : ndarray of int (K,)
    nis_sum, nis_count : ndarray (K,)
        Sum and number of the normalised innovations squared of the scan's EKF updates (2 dof each).
    seconds : float
        Wall time of the filter alone.
    engine : str
        Which engine ran it: ``"fused"`` (one compiled call) or ``"orchestrator"`` (per event).
    """

    poses: np.ndarray
    pose_covs: np.ndarray
    maps: list[MapSnapshot]
    n_detections: np.ndarray
    n_associated: np.ndarray
    n_landmarks: np.ndarray
    seconds: float = 0.0
    events: list = field(default_factory=list)
    nis_sum: np.ndarray = field(default_factory=lambda: np.empty(0))
    nis_count: np.ndarray = field(default_factory=lambda: np.empty(0))
    engine: str = "orchestrator"


#: ``engine`` of :func:`run_filter`: the fused engine where it covers the configuration, or never.
ENGINES = ("auto", "orchestrator")


def run_filter(config: Config, events: list[Odometry | Scan], slam: EkfSlam | None = None,
               on_scan=None, engine: str = "auto") -> FilterRecord:
    """Run :class:`EkfSlam` over an event stream, recording the estimate after every scan;
    ``on_scan()`` (optional) is called after each scan (a progress bar).

    Without ``slam`` and with ``engine="auto"``, a configuration the fused engine covers
    (:func:`radarslam.slam._fused.why_not`) runs the whole stream in one compiled call: the same
    record (docs/architecture.md "The fused engine"); ``on_scan`` is then called once per scan at
    the end. ``engine="orchestrator"`` runs it event by event whatever the configuration (the same
    associations, values equal to 1e-9: the first run on a machine uses it while the fused engine
    has not been compiled yet, compiling/warmup.py)."""
    if engine not in ENGINES:
        raise ConfigError(f"engine: expected one of {', '.join(ENGINES)}, got {engine!r}")
    t0 = time.perf_counter()
    if slam is None:
        slam = EkfSlam(config)
        if engine == "auto" and _fused.why_not(slam, events) is None:
            return _fused_record(slam, events, t0, on_scan)
    poses, covs, maps, ndet, nass, nlm, nis_sum, nis_n = [], [], [], [], [], [], [], []
    for ev in events:
        rep = slam.process(ev)
        if rep is None:
            continue
        poses.append(slam.x[:3].copy())
        covs.append(slam.P[:3, :3].copy())
        maps.append(slam.snapshot())
        ndet.append(rep.n_detections)
        nass.append(rep.n_associated)
        nlm.append(slam.state.n_landmarks)
        nis_sum.append(float(rep.nis.sum()))
        nis_n.append(rep.nis.size)
        if on_scan is not None:
            on_scan()
    return FilterRecord(np.array(poses).reshape(-1, 3), np.array(covs).reshape(-1, 3, 3), maps,
                        np.array(ndet), np.array(nass), np.array(nlm), time.perf_counter() - t0,
                        nis_sum=np.array(nis_sum), nis_count=np.array(nis_n, dtype=float))


def _fused_record(slam: EkfSlam, events, t0: float, on_scan) -> FilterRecord:
    """:func:`run_filter` by the fused engine (:mod:`radarslam.slam._fused`): the same record."""
    r, _ = _fused.run(slam, events)
    off = r["map_offsets"].tolist()
    maps = [MapSnapshot(r["ids"][a:b], r["positions"][a:b], r["covs"][a:b], r["rma"][a:b], r["efa"][a:b],
                        r["created"][a:b]) for a, b in zip(off[:-1], off[1:])]
    seconds = time.perf_counter() - t0
    if on_scan is not None:
        for _ in maps:
            on_scan()
    return FilterRecord(r["poses"], r["pose_covs"], maps, r["n_detections"], r["n_associated"], r["n_landmarks"],
                        seconds, nis_sum=r["nis_sum"], nis_count=r["nis_count"].astype(float), engine="fused")

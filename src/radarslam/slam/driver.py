"""The one event driver: a stream of odometry and scans through the filter, the estimate recorded after
every scan (docs/architecture.md "The path of a recording").

:func:`drive` is the only loop over the filter above the engine. A new filter runs the whole stream through
the fused engine in calls over parts of it (slam/fused/plan.py ``run``); a given :class:`EkfSlam` runs it
event by event (the same engine, one event per call); both give the same :class:`FilterRecord`. What a
command records beyond it (a detection's fate, a reference's hits, an animation's frames) is an
:class:`Observer`, told of every scan of a run event by event or of the whole run at its end."""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np

from radarslam.config import Config
from radarslam.core.errors import ConfigError
from radarslam.core.types import Odometry, Scan
from radarslam.slam import _fused
from radarslam.slam.fused import plan as _plan
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
        Which form of the fused engine ran it: ``"fused"`` (compiled), or its code run by the
        interpreter, ``"fused-steps"`` (its steps in Python over compiled kernels) or ``"fused-python"``
        (all of it; :func:`radarslam.slam.fused.engine.form`); ``"events"``, a given filter event by
        event (:class:`EkfSlam`'s own form).
    times : ndarray (K,)
        The scans' times (s).
    nis_rows : ndarray (u, 2)
        Every association update's scan position and NIS (2 dof), in update order.
    bias : ndarray (K, 2m) or None
        Under the odometry-bias states (docs/method.md c.11): their values and standard deviations
        after every scan; None without them.
    bias_names, bias_units : tuple of str (m,)
        The bias states' names and units; empty without them.
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
    engine: str = "events"
    times: np.ndarray = field(default_factory=lambda: np.empty(0))
    nis_rows: np.ndarray = field(default_factory=lambda: np.empty((0, 2)))
    bias: np.ndarray | None = None
    bias_names: tuple[str, ...] = ()
    bias_units: tuple[str, ...] = ()


#: ``engine`` of :func:`run_filter`: the configuration's form of the fused engine (compiled, or its steps
#: form under ``filter.fused`` false), or its own code as Python, above its compiled kernels or whole.
ENGINES = ("auto", "fused-steps", "fused-python")
#: ``maps`` of :func:`drive`: the map after every scan, or after the last one only (a long recording).
MAPS = ("all", "last")


class Observer:
    """What a command records of a run beyond its :class:`FilterRecord`; :func:`drive` tells it of
    the run by one of the two methods, whichever engine runs the stream."""

    def scan_mask(self, scans: Sequence[Scan]) -> np.ndarray | None:
        """The scans after which the fused engine must record the landmarks (ids and centroids,
        ``trace_*`` of :func:`radarslam.slam._fused.run`), one flag per scan; None for none."""
        return None

    def after_scan(self, k: int, slam: EkfSlam, scan: Scan, report) -> None:
        """The given filter ran scan ``k`` (its :class:`~radarslam.slam.filter.ScanReport`)."""

    def after_fused(self, slam: EkfSlam, scans: Sequence[Scan], result: dict, associations: np.ndarray) -> None:
        """The fused engine ran the stream: its arrays by name and the ``(scan, detection, landmark
        id)`` rows of its associations."""


def drive(config: Config, events: Sequence[Odometry | Scan], *, slam: EkfSlam | None = None, engine: str = "auto",
          observers: Sequence[Observer] = (), maps: str = "all",
          on_scan: Callable[[], None] | None = None, on_scans: Callable[[int], None] | None = None) -> FilterRecord:
    """Run ``events`` through the filter and return its :class:`FilterRecord`; each of ``observers``
    is told of the run (:class:`Observer`); ``on_scan()`` is called after each scan (a progress bar;
    with the fused engine, once per scan of each part of the stream as the part ends, about every half
    second: slam/fused/chunks.py); ``on_scans(n)`` is told of the scans done ``n`` at a time (a part's,
    or one).

    ``slam`` (an :class:`EkfSlam` of ``config``) runs event by event; without it, the whole stream runs
    through a new filter's fused engine in the form ``engine`` asks for: ``"auto"`` compiled (its steps
    form under ``filter.fused`` false), ``"fused-steps"`` and ``"fused-python"`` the engine's own code
    through the interpreter (its steps, or all of it). ``maps="last"`` keeps the map after the last scan
    only."""
    if engine not in ENGINES:
        raise ConfigError(f"engine: expected one of {', '.join(ENGINES)}, got {engine!r}")
    if maps not in MAPS:
        raise ConfigError(f"maps: expected one of {', '.join(MAPS)}, got {maps!r}")
    t0 = time.perf_counter()
    if slam is None:
        how = engine.removeprefix("fused-") if engine != "auto" else "compiled" if config.filter.fused else "steps"
        return _drive_fused(EkfSlam(config), events, observers, maps, _told(on_scan, on_scans), t0, how)
    if engine != "auto":
        raise ConfigError(f"engine: {engine!r} runs a new filter, not the given slam; got slam and {engine!r}")
    told = _told(on_scan, on_scans)
    return _drive_events(slam, events, observers, maps, None if told is None else (lambda: told(1)), t0)


def _told(on_scan, on_scans):
    """One callback of a count of scans done, from ``on_scan()`` (per scan) and ``on_scans(n)``, or None."""
    if on_scan is None and on_scans is None:
        return None

    def told(n: int) -> None:
        if on_scan is not None:
            for _ in range(n):
                on_scan()
        if on_scans is not None:
            on_scans(n)
    return told


def _bias_row(slam: EkfSlam) -> np.ndarray:
    """The odometry-bias states and their standard deviations (c.11)."""
    return np.concatenate([slam.state.bias, np.sqrt(np.diag(slam.state.bias_cov))])


def _bias_labels(slam: EkfSlam) -> dict:
    """The odometry-bias states' names and units (c.11), empty without them."""
    b = slam.bias_model
    return {"bias_names": b.names, "bias_units": b.units} if b is not None and b.dim else {}


def _drive_events(slam: EkfSlam, events, observers, maps: str, on_scan, t0: float) -> FilterRecord:
    """:func:`drive` event by event (:meth:`EkfSlam.process`)."""
    poses, covs, snaps, ndet, nass, nlm, nis_sum, nis_n, times, nis_rows, bias = ([] for _ in range(11))
    m = 0 if slam.bias_model is None else slam.bias_model.dim
    for ev in events:
        rep = slam.process(ev)
        if rep is None:
            continue
        k = len(poses)
        poses.append(slam.x[:3].copy())
        covs.append(slam.P[:3, :3].copy())
        if maps == "all":
            snaps.append(slam.snapshot())
        ndet.append(rep.n_detections)
        nass.append(rep.n_associated)
        nlm.append(slam.state.n_landmarks)
        nis_sum.append(float(rep.nis.sum()))
        nis_n.append(rep.nis.size)
        times.append(ev.t)
        if rep.nis.size:
            nis_rows.append(np.column_stack([np.full(rep.nis.size, float(k)), rep.nis]))
        if m:
            bias.append(_bias_row(slam))
        for o in observers:
            o.after_scan(k, slam, ev, rep)
        if on_scan is not None:
            on_scan()
    if maps == "last":
        snaps = [slam.snapshot()]
    return FilterRecord(np.array(poses).reshape(-1, 3), np.array(covs).reshape(-1, 3, 3), snaps, np.array(ndet),
                        np.array(nass), np.array(nlm), time.perf_counter() - t0, nis_sum=np.array(nis_sum),
                        nis_count=np.array(nis_n, dtype=float), times=np.array(times, dtype=float),
                        nis_rows=np.concatenate(nis_rows) if nis_rows else np.empty((0, 2)),
                        bias=np.array(bias).reshape(-1, 2 * m) if m else None, **_bias_labels(slam))


def fused_maps(result: dict, maps: str = "all") -> list[MapSnapshot]:
    """The maps of a fused run's arrays (:func:`radarslam.slam._fused.run`): after every scan, or
    (``maps="last"``, a run with ``all_maps`` False) after the last one."""
    off = result["map_offsets"].tolist()
    bounds = list(zip(off[:-1], off[1:])) if maps == "all" else [(off[-2], off[-1])]
    return [MapSnapshot(result["ids"][a:b], result["positions"][a:b], result["covs"][a:b], result["rma"][a:b],
                        result["efa"][a:b], result["created"][a:b]) for a, b in bounds]


def _drive_fused(slam: EkfSlam, events, observers, maps: str, told, t0: float,
                 how: str = "compiled") -> FilterRecord:
    """:func:`drive` by the fused engine (:mod:`radarslam.slam._fused`) in form ``how``: the same record;
    ``told(n)`` of each part's scans (:func:`_told`)."""
    scans = [ev for ev in events if isinstance(ev, Scan)]
    masks = [mk for mk in (o.scan_mask(scans) for o in observers) if mk is not None]
    trace = np.logical_or.reduce([np.asarray(mk, dtype=bool) for mk in masks]) if masks else None
    form = _plan.run_form(slam, how)
    r, arows = _fused.run(slam, events, all_maps=maps == "all", trace=trace, how=form, on_scans=told)
    snaps = fused_maps(r, maps) if scans or maps == "all" else [slam.snapshot()]
    nis_rows = np.column_stack([np.repeat(np.arange(len(scans), dtype=float), r["nis_count"]), r["nis"]])
    bias = None
    if r["bias"].shape[1]:                                  # c.11: the values and stds, as _bias_row
        bias = np.concatenate([r["bias"], np.sqrt(np.diagonal(r["bias_covs"], axis1=1, axis2=2))], axis=1)
    record = FilterRecord(r["poses"], r["pose_covs"], snaps, r["n_detections"], r["n_associated"], r["n_landmarks"],
                          time.perf_counter() - t0, nis_sum=r["nis_sum"], nis_count=r["nis_count"].astype(float),
                          engine="fused" if form == "compiled" else f"fused-{form}",
                          times=np.array([ev.t for ev in scans], dtype=float), nis_rows=nis_rows, bias=bias,
                          **_bias_labels(slam))
    for o in observers:
        o.after_fused(slam, scans, r, arows)
    return record


def run_filter(config: Config, events: list[Odometry | Scan], slam: EkfSlam | None = None,
               on_scan=None, engine: str = "auto") -> FilterRecord:
    """:func:`drive` with every scan's map and no observer (a trial, a recording's record)."""
    return drive(config, events, slam=slam, engine=engine, on_scan=on_scan)

"""The fused engine's Python side: its parameters by name (:class:`FusedParams`, from the configuration by :func:`_parameters`), and :func:`run`, which calls the
compiled :func:`~radarslam.slam.fused.engine.run_stream` of the configuration's family
(:func:`~radarslam.slam.fused.engine.engine`, :func:`family`) and names what it returns.

The records passed to the compiled code are named tuples (:class:`typing.NamedTuple`) of fixed
types (int64, float64, bool, and float64 or int64 arrays), so that numba compiles one
specialisation whatever the configuration.
"""

from __future__ import annotations

import math
import time
from typing import NamedTuple

import numpy as np

from radarslam.slam.fused.engine import BAD_PREDICTION, ODOMETRY, OK, VELOCITY, family_of, form
from radarslam.slam.fused.chunks import Pacer, joined, part
from radarslam.slam.fused.events import initial_carry
from radarslam.slam.fused.own import builtin_associators, own_associator, reference_kernels, run_form, user_components
from radarslam.slam.fused.stream import Stream, _stream_arrays
from radarslam.slam.fused.view import ViewParams, view_parameters


#: ``FusedParams.pre_spread``: none (R alone), the prior spread, the buffered detections' scatter (once 3
#: are held, the prior before); slam/fused/tracking.py ``_inflation``.
PRE_SPREADS = ("none", "prior", "scatter")


class FusedParams(NamedTuple):
    """The configuration of :func:`~radarslam.slam.fused.engine.run_stream`, by name."""

    assoc: int             #: associator: 0 nearest neighbour, 1 batch, 2 batch-joint, 3 JCBB (fused.tracking)
    n_near: int            #: associator.n_nearest
    n_new: int             #: associator.n_nearest_new (the alpha test)
    min_samples: int       #: landmarks.cluster_min_samples
    confirm_points: int    #: landmarks.confirm_points (Rule 1, Rule 2)
    confirm_window: int    #: landmarks.confirm_window (Rule 2)
    confirm_hits: int      #: landmarks.confirm_hits (Rule 2)
    removal_window: int    #: landmarks.removal_window (c.5)
    removal_max: int       #: landmarks.removal_max_hits (c.5)
    merge_max: int         #: landmarks.merge_max_per_scan (0: no limit)
    init_cluster: bool     #: landmarks.init == "cluster": a new landmark at its cluster's mean
    track: bool            #: extent.track
    contour: bool          #: extent.use_in_slam and extent.contour_sifting
    inflate: bool          #: extent.use_in_slam and extent.inflate_noise
    pre_spread: int        #: extent.pre_init_spread, the spread before the extent (a.7.2): its index in PRE_SPREADS
    w_mode: int            #: extent.w_mode: the scan's W (h.3; extent.measurement.W_MAX_TRACE, W_MAX_DET, W_MEAN)
    n_init: int            #: extent.n_init
    posterior: bool        #: extent.use_posterior_landmark
    upper: bool            #: not extent.efa_noise_correct
    efa_window: int        #: extent.efa_window under efa_mode "sliding" (Decision 5); 0: the EFA of each scan
    spread_at_birth: bool  #: the estimator has an initial spread
    literal: bool          #: extent.sifting_mode == "literal"
    timing: bool           #: record each scan's wall time
    all_maps: bool         #: record the map after every scan (else after the last one only)
    motion: int            #: motion model: 0 unicycle, 1 Ackermann (fused.tracking.UNICYCLE, ACKERMANN)
    arc: bool              #: the extent estimator is "visible-arc" (docs/method.md a.9)
    arc_min_scans: int     #: extent.arc_min_scans
    beta: float            #: associator.beta
    alpha: float           #: landmarks.alpha (the alpha test)
    sift_radius: float     #: landmarks.sift_radius_m
    eps: float             #: landmarks.cluster_eps_m
    tentative_gate: float  #: landmarks.tentative_gate_m
    merge_distance: float  #: landmarks.merge_distance_m
    merge_axis_tol: float  #: landmarks.merge_axis_tol_m
    max_range: float       #: filter.max_range_m
    half_fov: float        #: half filter.field_of_view_deg, in radians
    retire2: float         #: landmarks.retire_distance_m squared (0: never retire, c.15)
    gate: float            #: the extent estimator's gate
    gamma: float           #: extent.spread_factor
    alpha0: float          #: extent.alpha0
    tau: float             #: extent.tau_s
    eig_floor: float       #: extent.eig_floor_m2
    kappa: float           #: extent.kappa
    beam_step: float       #: extent.beam_step_deg, in radians (visible-arc)
    mem: bool              #: the extent estimator is "mem-ekf" (MEM-EKF*, docs/method.md a.10)
    mem_noise: int         #: extent.mem_ekf_noise: 0 sensor, 1 no-centroid, 2 full (extent.rows.MEM_SENSOR, ...)
    mem_q_theta: float     #: extent.mem_ekf_process_std[0], in radians per sqrt(s)
    mem_q_axis: float      #: extent.mem_ekf_process_std[1] (m per sqrt(s))
    wheelbase: float       #: Ackermann L (filter.vehicle_L_m)
    encoder_offset: float  #: Ackermann H (filter.vehicle_H_m)
    lever: float           #: Ackermann laser lever arm from the rear axle, L + a (filter.sensor_a_m)
    sensor_b: float        #: Ackermann b (filter.sensor_b_m)
    fej: bool              #: filter.jacobians == "fej": first-estimates Jacobians (docs/method.md c.2.1)
    jcbb_max_nodes: int    #: JCBB: landmarks.jcbb_max_nodes (docs/method.md c.4.1)
    jcbb_prefilter: int    #: JCBB: nearest landmarks gated per observation (slam.jcbb.N_PREFILTER)
    jcbb_eps: float        #: JCBB: the observations' DBSCAN radius (landmarks.cluster_eps_m)
    jcbb_min_samples: int  #: JCBB: their DBSCAN minimum (landmarks.cluster_min_samples)
    doppler_gate: bool     #: filter.doppler_gate (docs/method.md c.10.4)
    gate_memory: int       #: filter.doppler_memory_scans
    gate_probation: int    #: filter.doppler_probation_scans
    gate_radius: float     #: filter.doppler_memory_radius_m
    turn_index: int        #: the turning input whose variance grows with the turn (c.11.8), -1 for none
    turn_gain2: float      #: its k^2 (slam.bias.turn_noise_gain2)
    noise_ref: float       #: filter.noise_interval_s: U and Q are a reading's over it (c.2.2)
    offset_k: float        #: the part in view's offset, times a landmark's spread (extent.view_offset, c.17; 0 none)
    platform: int          #: the platform block's size: 3, or 3 + m with m odometry-bias states (c.11)
    bias_scaled: np.ndarray  #: (k,) int64, the inputs the speed-scale bias scales (InputBias.scaled; empty: none)
    bias_offset: int       #: the turning input (InputBias.offset)
    bias_turn: int         #: its error: models.input_bias.TURN_OFFSET, TURN_SCALE or TURN_BOTH (c.11.8)
    bias_thrust: int       #: the thrust angle's index among the bias states, -1 none (BiasStates.thrust_index)
    bias_drift: np.ndarray   #: (m,) the bias states' drift per sqrt(s) (BiasStates.drift)
    bias_tau: float        #: their time constant, 0 for a random walk (filter.bias_tau_s)
    held_end: int          #: filter.car_states "consider": the platform block's end (c.13.4), else 3 (none held)
    pv: ViewParams         #: the partial-view model's parameters (docs/method.md a.12; fused.view)


class Noise(NamedTuple):
    """The noise matrices and the prior spread of :func:`~radarslam.slam.fused.engine.run_stream`."""

    R: np.ndarray             #: (2, 2) measurement noise
    R_ext: np.ndarray         #: (2, 2) the extent estimator's measurement noise
    U: np.ndarray             #: (2, 2) control noise
    Q: np.ndarray             #: (3, 3) process noise
    prior_spread: np.ndarray  #: (2, 2) the prior spread (zeros when not used)
    gates: np.ndarray         #: (K + 1,) JCBB's joint gates of k pairings (slam._jcbb_numba.joint_gates)
    Cp0: np.ndarray           #: (3, 3) MEM-EKF*'s initial shape covariance (zeros for the other estimators)
    R_assoc: np.ndarray       #: (2, 2) measurement noise of association and update (n_c R, c.11.9)


def family(slam):
    """The :class:`~radarslam.slam.fused.engine.Family` of ``slam``'s compiled engine: the optional
    branches its configuration takes (from the same
    :func:`_parameters` :func:`run` passes)."""
    return family_of(_parameters(slam))


def _parameters(slam, timing: bool = False, all_maps: bool = True) -> FusedParams:
    """The :class:`FusedParams` of ``slam``'s configuration and components."""
    lc, ec, f = slam.config.landmarks, slam.config.extent, slam.config.filter
    from radarslam.extent.mem_ekf import MemEkfEstimator
    from radarslam.slam.map_rows import retire_radius
    from radarslam.extent.visible_arc import VisibleArcEstimator
    from radarslam.models.ackermann import AckermannModel
    from radarslam.extent.measurement import W_MODES
    from radarslam.extent.rows import MEM_NOISE
    from radarslam.slam.fused.tracking import ACKERMANN, UNICYCLE

    model = slam.model
    ackermann = type(model) is AckermannModel
    arc = type(slam.extent) is VisibleArcEstimator
    mem = type(slam.extent) is MemEkfEstimator

    in_slam = bool(ec.use_in_slam)
    return FusedParams(
        assoc=builtin_associators().get(type(slam.associator), 0),
        n_near=int(getattr(slam.associator, "n_nearest", 1)), n_new=int(getattr(slam.associator, "n_nearest_new", 1)),
        min_samples=int(lc.cluster_min_samples),
        confirm_points=int(lc.confirm_points), confirm_window=int(lc.confirm_window),
        confirm_hits=int(lc.confirm_hits),
        removal_window=int(lc.removal_window), removal_max=int(lc.removal_max_hits),
        merge_max=int(lc.merge_max_per_scan),
        init_cluster=lc.init == "cluster",
        track=bool(ec.track),
        contour=in_slam and bool(ec.contour_sifting),
        inflate=in_slam and bool(ec.inflate_noise),
        pre_spread=PRE_SPREADS.index(ec.pre_init_spread),
        w_mode=W_MODES.index(ec.w_mode),
        n_init=int(ec.n_init),
        posterior=bool(ec.use_posterior_landmark),
        upper=not ec.efa_noise_correct,
        efa_window=int(ec.efa_window) if ec.efa_mode == "sliding" else 0,
        spread_at_birth=slam.extent.initial_spread() is not None,
        literal=ec.sifting_mode == "literal",
        timing=bool(timing), all_maps=bool(all_maps),
        motion=ACKERMANN if ackermann else UNICYCLE,
        arc=arc, arc_min_scans=int(slam.extent.min_scans) if arc else 1,
        beta=float(getattr(slam.associator, "beta", 0.0)), alpha=float(lc.alpha),
        sift_radius=float(lc.sift_radius_m), eps=float(lc.cluster_eps_m), tentative_gate=float(lc.tentative_gate_m),
        merge_distance=float(lc.merge_distance_m), merge_axis_tol=float(lc.merge_axis_tol_m),
        max_range=float(f.max_range_m), half_fov=math.radians(f.field_of_view_deg) / 2.0,
        retire2=retire_radius(slam.config) ** 2,          # c.15: the reach plus the lever-arm margin
        gate=float(getattr(slam.extent, "gate", 0.0)), gamma=float(ec.spread_factor),
        alpha0=float(ec.alpha0), tau=float(ec.tau_s), eig_floor=float(ec.eig_floor_m2), kappa=float(ec.kappa),
        beam_step=float(slam.extent.beam_step) if arc else 0.0,
        mem=mem, mem_noise=MEM_NOISE[ec.mem_ekf_noise],
        mem_q_theta=float(slam.extent.q_theta) if mem else 0.0, mem_q_axis=float(slam.extent.q_axis) if mem else 0.0,
        wheelbase=float(model.L) if ackermann else 0.0, encoder_offset=float(model.H) if ackermann else 0.0,
        lever=float(model.lever) if ackermann else 0.0, sensor_b=float(model.b) if ackermann else 0.0,
        fej=f.jacobians == "fej",
        jcbb_max_nodes=int(getattr(slam.associator, "max_nodes", 1)),
        jcbb_prefilter=int(getattr(slam.associator, "n_prefilter", 1)),
        jcbb_eps=float(getattr(slam.associator, "cluster_eps", 1.0)),
        jcbb_min_samples=int(getattr(slam.associator, "cluster_min_samples", 1)),
        doppler_gate=bool(f.doppler_gate), gate_memory=int(f.doppler_memory_scans),
        gate_probation=int(f.doppler_probation_scans), gate_radius=float(f.doppler_memory_radius_m),
        turn_index=-1 if slam._turn_k[0] is None else int(slam._turn_k[0]), turn_gain2=float(slam._turn_k[1]),
        noise_ref=float(slam._noise_ref), offset_k=float(slam._offset_k),
        held_end=int(slam.held_end),
        **_bias_parameters(slam.bias_model),
        pv=view_parameters(slam),
    )


def _bias_parameters(bias) -> dict:
    """The :class:`FusedParams` fields of the odometry-bias states ``bias`` (a
    :class:`~radarslam.slam.bias.BiasStates`, or None without them; c.11)."""
    if bias is None:
        return dict(platform=3, bias_scaled=np.zeros(0, dtype=np.int64), bias_offset=0, bias_turn=0, bias_thrust=-1,
                    bias_drift=np.zeros(0), bias_tau=0.0)
    return dict(platform=int(bias.platform_dim), bias_scaled=bias.spec.scaled_index,
                bias_offset=int(bias.spec.offset), bias_turn=int(bias.spec.turn_code),
                bias_thrust=int(bias.thrust_index),
                bias_drift=np.ascontiguousarray(bias.drift, dtype=float), bias_tau=float(bias.tau))


def run(slam, events, timing: bool = False, all_maps: bool = True, trace=None, how: str = "compiled",
        on_scans=None):
    """Run ``events`` through the fused engine with ``slam``'s configuration and components. Returns ``(record, associations)``: the arrays of
    :func:`~radarslam.slam.fused.engine.run_stream` by name, and the ``(scan, detection, landmark
    id)`` rows. ``timing`` adds ``"seconds"``: each scan's wall time with the predictions before it
    (``benchmarks/bench_scaling.py``).

    ``all_maps`` False records the map after the last scan only (its rows are
    ``map_offsets[-2]:map_offsets[-1]``; a long recording's maps need not be kept); ``trace``, a
    boolean per scan, records the landmarks' ids and centroids after the scans it marks
    (``trace_offsets``, ``trace_ids``, ``trace_positions``). ``nis`` holds the NIS of every update,
    those of scan ``s`` at ``nis_offsets[s]:nis_offsets[s + 1]``. ``bias`` (S, m) and ``bias_covs``
    (S, m, m) are the odometry-bias states and their covariance after each scan (docs/method.md
    c.11; m = 0 without them). ``kept`` holds the rows of each scan's detections the Doppler gate
    kept (c.10.4), those of scan ``s`` at ``kept_offsets[s]:kept_offsets[s + 1]``. ``how``: the
    engine's form (:func:`~radarslam.slam.fused.engine.form`: compiled, or its steps or all of it as Python);
    a component of the user's own (:func:`user_components`) runs the steps form where ``how`` is compiled
    (:func:`run_form`). The stream runs in parts (:mod:`~radarslam.slam.fused.chunks`, each about half a
    second of wall time; the same arithmetic as one call), and ``on_scans(n)`` is told of each part's
    ``n`` scans as it ends.

    Raises
    ------
    InputError
        As :class:`EkfSlam` would, for a bad event or an event that makes the state non-finite.
    """
    from radarslam.core.errors import InputError

    stream = _stream_arrays(events, slam=slam)
    if trace is not None:
        trace = np.asarray(trace, dtype=np.bool_)
        if trace.shape != stream.trace.shape:
            raise InputError(f"trace: expected one flag per scan, shape {stream.trace.shape}, got {trace.shape}")
        stream = stream._replace(trace=trace)
    cfg = _parameters(slam, timing, all_maps)
    largest = largest_scan(stream)
    rec, maps, arows = _parts(engine_of(slam, cfg, how)[0], events, stream, first_carry(slam, cfg, largest),
                              noises(slam, cfg, largest), cfg, on_scans)
    if stream.kept.shape[0] and arows.shape[0]:           # the gate's kept rows back to the scan's detections
        arows[:, 1] = stream.kept[stream.scan_off[arows[:, 0]] + arows[:, 1]]
    out = {"poses": rec.poses, "pose_covs": rec.pose_covs, "n_detections": rec.n_det, "n_associated": rec.n_ass,
           "n_landmarks": rec.n_lm, "nis_sum": rec.nis_sum, "nis_count": rec.nis_cnt, "map_offsets": rec.map_off,
           "ids": maps.ids, "positions": maps.pos, "covs": maps.cov, "rma": maps.rma, "efa": maps.efa,
           "created": maps.created, "nis": rec.nis, "nis_offsets": rec.nis_off, "trace_offsets": rec.trace_off,
           "trace_ids": rec.trace_ids, "trace_positions": rec.trace_pos, "bias": rec.bias,
           "bias_covs": rec.bias_covs, "kept": stream.kept, "kept_offsets": stream.scan_off}
    if timing:
        out["seconds"] = rec.seconds
    return out, arows


def engine_of(slam, cfg, how: str = "compiled"):
    """The engine of ``slam``'s family (``cfg``: its parameters) in the form ``how`` asks for
    (:func:`run_form`), with ``slam``'s components of the user's own (:func:`user_components`) and, in
    the Python form, the reference's EKF updates (:func:`reference_kernels`). Returns ``(engine,
    extents)``: ``extents`` the states of an extent estimator of the user's own (own.UserExtents), else
    None."""
    how = run_form(slam, how)
    pairs = user_components(slam) + reference_kernels(how) if how != "compiled" else ()
    return form(family_of(cfg), how, pairs), getattr(dict(pairs).get("scan_event"), "extents", None)


def first_carry(slam, cfg, largest: int):
    """The engine's state before ``slam``'s first event (:func:`~radarslam.slam.fused.events.initial_carry`),
    room buffered for scans of ``largest`` detections; landmarks added to ``slam.state`` by hand before
    it (``SlamState.add_landmark``) with their records, tentatives and extents (:func:`_seeded`)."""
    carry = initial_carry(slam.state.x, slam.state.P, cfg.n_init + largest + 1)
    st = slam.state
    if st.n_landmarks == 0 and st.tentatives.count.shape[0] == 0 and st.next_id == 0:
        return carry
    return _seeded(carry, st, slam.extent)


def _seeded(carry, st, estimator):
    """``carry`` with the landmarks of the state ``st`` (a :class:`~radarslam.slam.state.SlamState`): their
    bookkeeping, their extents as the built-in estimator ``estimator`` holds them in rows (``_gather``),
    the tentatives and the next id."""
    from radarslam.core.errors import InputError
    from radarslam.slam.fused.storage import new_landmarks

    n, lm = st.n_landmarks, carry.lm
    gather = getattr(estimator, "_gather", None)
    if n and gather is None:
        raise InputError(f"slam.state: expected landmarks added by hand with a built-in extent estimator, got "
                         f"{n} with {type(estimator).__name__}; add them after the first event")
    if n:
        E = gather(st.extents)
        B = max(lm.buf.shape[1], E.buf.shape[1])
        lm = new_landmarks.py_func(max(16, 2 * n), B)
        r = st.records
        for name in ("ids", "created", "mbits", "rbits", "first"):
            getattr(lm, name)[:n] = getattr(r, name)[:n]
        for name in ("einit", "X", "alpha", "Xefa", "nbuf", "shape", "Cs", "xi", "Pxi", "nview"):
            getattr(lm, name)[:n] = getattr(E, name)
        lm.buf[:n, :E.buf.shape[1]] = E.buf
    return carry._replace(lm=lm, N=np.int64(n), next_id=np.int64(st.next_id), tent=st.tentatives)


def largest_scan(stream: Stream) -> int:
    """The most detections a scan of ``stream`` holds (at least 1)."""
    off = stream.scan_off
    return max(1, int((off[1:] - off[:-1]).max(initial=1)))


def noises(slam, cfg, largest: int) -> Noise:
    """The :class:`Noise` of ``slam`` under the parameters ``cfg``, for scans of up to ``largest``
    detections (JCBB's gates: one for every depth a scan's candidates allow)."""
    ext = slam.extent
    spread = ext.initial_spread()           # an estimator of the user's own may hold no prior_spread
    prior_spread = getattr(ext, "prior_spread", spread) if spread is not None or cfg.pre_spread else None
    prior_spread = np.zeros((2, 2)) if prior_spread is None else prior_spread
    from radarslam.slam._jcbb_numba import joint_gates

    gates = np.zeros(2)
    if cfg.assoc == 3:                      # the reference backend's JCBB holds no gates of its own
        own = getattr(slam.associator, "gates", None)
        gates = own(largest) if own is not None else joint_gates(slam.associator.gate_probability, largest)
    Cp0 = np.asarray(ext.Cp0, dtype=float) if cfg.mem else np.zeros((3, 3))
    return Noise(slam.R, getattr(ext, "R_extent", slam.R), slam.U, slam.Q,
                 np.ascontiguousarray(prior_spread, dtype=float), gates, Cp0,
                 np.ascontiguousarray(slam.R_assoc, dtype=float))


def _parts(engine, events, stream: Stream, carry, noise, cfg, on_scans):
    """``stream`` through ``engine`` (a form of the engine) from the state ``carry`` in consecutive parts
    (:class:`~radarslam.slam.fused.chunks.Pacer`), the filter's state carried from each to the next:
    the run's ``(record, maps, association rows)``."""
    from radarslam.core.errors import InputError

    pacer, parts, e0, n_events = Pacer(), [], 0, stream.kinds.shape[0]
    while True:
        e1 = pacer.end(stream, e0)
        sub, s0 = part(stream, e0, e1)
        t0 = time.perf_counter()
        status, n, (rec, maps), arows, carry, _ = engine(sub, carry, noise, cfg)
        pacer.ran(n, time.perf_counter() - t0)
        if status[0] != OK:
            raise InputError(_failure(events, stream, (status[0], e0 + status[1]), s0 + n))
        parts.append((s0, rec, maps, arows))
        if on_scans is not None:
            on_scans(n)
        e0 = e1
        if e0 >= n_events:
            break
    return joined(parts, bool(cfg.all_maps)) if len(parts) > 1 else (rec, maps, arows)


def _failure(events, stream: Stream, status, n_scans: int) -> str:
    """The one-line message for the event ``status[1]`` of ``stream`` that made the state non-finite."""
    from radarslam.core.types import Scan

    ev, kind = int(status[1]), int(stream.kinds[int(status[1])])
    scan = [e for e in events if isinstance(e, Scan)][n_scans] if kind != ODOMETRY else None
    off = stream.scan_off
    if status[0] == BAD_PREDICTION and kind == VELOCITY:
        e = int((stream.kinds[:ev] == VELOCITY).sum())
        return (f"odometry before the scan at t={scan.t!r}: expected an input that keeps the state finite "
                f"(u {stream.vel[e].tolist()}, dt {float(stream.vel_dt[e])!r}), got one that makes it non-finite")
    if status[0] == BAD_PREDICTION:
        odo = events[ev]
        what = f"odometry at t={odo.t!r} (control {np.asarray(odo.control, dtype=float).tolist()}, dt {float(odo.dt)!r})"
    else:
        what = f"scan {scan.index} (t={scan.t!r}, {off[n_scans + 1] - off[n_scans]} detections)"
    return f"{what}: expected an input that keeps the state finite, got one that makes it non-finite"

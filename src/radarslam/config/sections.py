"""The configuration's sections: one dataclass per section, each field with its documentation,
unit and admissible range (:func:`param`), and the constants the checks use (:mod:`radarslam.config`).

Fields marked [PROP] in their doc are assumptions where the papers are silent (docs/method.md tags).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from radarslam.config.tables import (  # noqa: F401  (re-exported: their former home)
    CARPARK_VEHICLES,
    MAX_DETECTIONS_PER_SCAN,
    MAX_STEPS,
    MAX_VEHICLES,
    PARTIAL_VIEW_SPREAD_MODELS,
    SPREAD_FACTORS,
)
from radarslam.config.fields import param  # noqa: F401  (re-exported: its former home)
from radarslam.config.simulation import (  # noqa: F401  (re-exported: their former home)
    OdometerConfig,
    RadarConfig,
    TrajectoryConfig,
    WorldConfig,
)
from radarslam.core.mounting import Mounting
from radarslam.core.registry import (
    ASSOCIATORS,
    BACKENDS,
    EXTENT_ESTIMATORS,
    MOTION_MODELS,
)


# --------------------------------------------------------------------------------------------
# Estimation
# --------------------------------------------------------------------------------------------
@dataclass
class FilterConfig:
    """EKF-SLAM noise models and initialisation (docs/method.md b.5). Defaults equal the simulation's."""

    motion_model: str = param("unicycle", "motion model of the platform (a registered name)", registry=MOTION_MODELS)
    measurement_model: str = param("range-azimuth", "sensor measurement model: the one built in, range and "
                                   "azimuth (docs/method.md a.2; the EKF kernels and associators are written for it)",
                                   choices=("range-azimuth",))
    backend: str = param("numba", "how the filter's steps run: 'numba' (compiled, the default) or 'python' (the "
                         "reference, for checking: the same functions by the interpreter; docs/architecture.md "
                         "\"Backends\")", choices=BACKENDS)
    fused: bool = param(True, "run the events through the fused engine compiled whole (docs/architecture.md \"The "
                        "fused engine\"); false = its steps form, the same steps as Python over the compiled kernels")
    initial_pose: list[float] = param([0.1, 0.1, math.pi / 180.0], "initial estimate [x_m, y_m, theta_rad]", length=3)
    initial_pose_std: list[float] = param([0.15, 0.15, math.pi / 180.0], "initial std [x_m, y_m, theta_rad] of the "
                                          "simulation (b.5) and of a recording run started at filter.initial_pose "
                                          "(each >= 0; > 0 in the simulation)", length=3)
    truth_pose_std: list[float] = param([0.05, 0.05, 0.0017], "[PROP] a recording run started at its truth's first "
                                        "pose takes this initial std [x_m, y_m, theta_rad]: the truth's own "
                                        "accuracy, default a lidar-map or RTK-INS localisation's few centimetres and "
                                        "a tenth of a degree (each >= 0; a run started at zero takes 0, the anchored "
                                        "frame; b.5.1)", length=3)
    calibration: str = param("", "[PROP] a car's calibration file from 'radarslam calibrate' "
                             "(car_calibration.json: thrust angle, wheel scale, each radar's yaw and clock; "
                             "docs/method.md c.16) applied to a recording run; '' none; --calibration wins")
    radar_clock: str = param("as-stamped", "[PROP] a recording run's radar stamps: as-stamped, online (the rig's "
                             "clock offset against the wheels estimated from the first sweep on, from its Doppler "
                             "speed against the wheel speed, and each detection moved by the estimate known at its "
                             "time; docs/method.md c.12.8) or auto (online where the recording has a rig of radars "
                             "with Doppler and wheel speeds and no calibration gives the radars' clocks, else "
                             "as-stamped)", choices=("as-stamped", "online", "auto"))
    radar_clock_std_s: float = param(0.1, "[PROP] prior std of the rig's clock offset under radar_clock online (s)",
                                     low=0.0, low_open=True)
    initial_error: str = param("fixed", "[PROP] simulation: the initial estimate's error (b.5): fixed (initial_pose, "
                               "the paper's, the same offset in every trial) or draw (the true first pose plus a draw "
                               "from N(0, diag(initial_pose_std^2)), per trial from its own child stream)",
                               choices=("fixed", "draw"))
    jacobians: str = param("standard", "[PROP] where the EKF's Jacobians are evaluated (c.2.1): standard (the "
                           "current estimate) or fej (first estimates, Huang/Mourikis/Roumeliotis)",
                           choices=("standard", "fej"))
    range_std_m: float = param(0.5, "R: range std (m)", low=0.0, low_open=True)
    azimuth_std_deg: float = param(1.0, "R: azimuth std (deg)", low=0.0, low_open=True)
    speed_std_mps: float = param(0.02, "U: speed std (m/s)", low=0.0)
    turn_rate_std_deg_s: float = param(0.008, "U: turn-rate std (deg/s); unicycle control", low=0.0)
    steering_std_deg: float = param(2.0, "U: steering-angle std (deg); ackermann control [v_e, alpha]", low=0.0)
    process_var_xy_m2: float = param(1.5e-3, "Q: variance on x and y (m^2)", low=0.0)
    process_var_heading_rad2: float = param(5e-5, "Q: variance on the heading (rad^2)", low=0.0)
    noise_interval_s: float = param(0.16, "the odometry interval at which U's stds and Q's variances are quoted (s): a "
                                    "reading over dt takes U noise_interval_s / dt and Q dt / noise_interval_s, so that "
                                    "the same drive gives the same estimate at any odometry rate (docs/method.md c.2.2; "
                                    "the car park's step)", low=0.0, low_open=True)
    max_range_m: float = param(20.0, "sensor range used by the M/N in-range test (m)", low=0.0, low_open=True)
    field_of_view_deg: float = param(360.0, "sensor field of view centred on the heading, for the M/N in-range test (deg)",
                                     low=0.0, low_open=True, high=360.0)
    vehicle_L_m: float = param(2.83, "ackermann: wheelbase L (m)", low=0.0, low_open=True)
    vehicle_H_m: float = param(0.76, "ackermann: lateral offset H of the encoder wheel (m)")
    sensor_a_m: float = param(0.95, "ackermann: sensor ahead of the FRONT axle, a (m)")
    sensor_b_m: float = param(0.5, "ackermann: sensor to the left of the centre line, b (m)")
    doppler_gate: bool = param(False, "[PROP] keep detections whose Doppler fails the static-world test out of "
                               "association and landmark creation (c.10.4); needs Scan.channels['doppler_mps']")
    doppler_gate_probability: float = param(0.99, "[PROP] chi-square probability of the static-world test (c.10.4)",
                                            low=0.0, low_open=True, high=0.999999)
    doppler_object_radius_m: float = param(2.0, "[PROP] under filter.doppler_gate, detections within this distance "
                                           "of each other form one object, tested as a whole against the static "
                                           "world (m; 0 = the per-detection test alone; c.10.4.2)", low=0.0)
    doppler_object_probability: float = param(0.99, "[PROP] chi-square probability of the object test (c.10.4.2)",
                                              low=0.0, low_open=True, high=0.999999)
    doppler_memory_scans: int = param(5, "[PROP] under filter.doppler_gate, a moving object's detections keep new "
                                      "clusters near them from becoming landmarks for this many scans (0 = no "
                                      "memory; c.10.4.3)", low=0, high=10_000)
    doppler_memory_radius_m: float = param(3.0, "[PROP] radius (m) of that memory around each remembered detection "
                                           "(c.10.4.3)", low=0.0)
    doppler_probation_scans: int = param(5, "[PROP] under filter.doppler_gate, a landmark younger than this many scans "
                                         "is removed when a moving object is seen within doppler_memory_radius_m of "
                                         "it (0 = never; c.10.4.4)", low=0, high=10_000)
    doppler_threshold_mps: float = param(0.3, "[PROP] RANSAC consensus threshold |d + u.v| (m/s; c.10.2)", low=0.0,
                                         low_open=True)
    doppler_iterations: int = param(50, "[PROP] RANSAC minimal sets per scan (c.10.2)", low=1, high=100_000)
    doppler_std_floor_mps: float = param(0.0, "[PROP] floor of the Doppler residual std (m/s; a quantised Doppler "
                                         "of step q: q / sqrt(12); c.10.3)", low=0.0)
    zero_velocity_probability: float = param(0.99, "[PROP] chi-square probability of the at-rest test (c.10.3)",
                                             low=0.0, low_open=True, high=0.999999)
    odometry: str = param("odometer", "[PROP] what drives the prediction (c.10.5): odometer (the readings, the "
                          "paper), doppler (each scan's Doppler ego-velocity fit and the gyro; the odometer is "
                          "ignored), both (the odometer's speed fused with the Doppler fit) or auto (a recording: both when its "
                          "detections carry Doppler and its odometry a speed and a yaw rate, else odometer; c.10.5.2)",
                          choices=("odometer", "doppler", "both", "auto"))
    yaw_rate: str = param("gyro", "[PROP] under filter.odometry doppler: where the yaw rate comes from: gyro (the "
                          "odometry events' gyro_rad_s, c.10.5) or doppler (the radar alone: the no-sideslip model "
                          "turns the sensor's fitted velocity into forward speed and yaw rate, needs sensor.mount_x_m "
                          "!= 0; c.10.5.1)", choices=("gyro", "doppler"))
    gyro_std_deg_s: float = param(0.1, "[PROP] U: gyro yaw-rate std (deg/s) under filter.odometry doppler/both",
                                  low=0.0)
    doppler_hold_std_mps: float = param(1.0, "[PROP] under filter.odometry doppler/both, a scan without a valid "
                                        "ego-velocity fit holds the last one with this std added (m/s; c.10.5)",
                                        low=0.0)
    odometry_bias: str = param("none", "[PROP] systematic odometry errors (c.11): none (white noise U only, the "
                               "paper) or states (a speed scale and a steering or turn-rate offset estimated as "
                               "slowly varying states after the pose)", choices=("none", "states"))
    bias_scale_std: float = param(0.05, "[PROP] prior std of the speed-scale error eps (v = (1 + eps) v_meas; c.11)",
                                  low=0.0)
    bias_scale_drift_per_rt_s: float = param(1e-5, "[PROP] random-walk intensity of eps (1/sqrt(s); c.11)", low=0.0)
    bias_steering_std_deg: float = param(2.0, "[PROP] ackermann: prior std of the steering offset (deg; c.11)",
                                         low=0.0)
    bias_steering_drift_deg_per_rt_s: float = param(0.001, "[PROP] ackermann: random-walk intensity of the steering "
                                                    "offset (deg/sqrt(s); c.11)", low=0.0)
    bias_turn_rate_std_deg_s: float = param(0.5, "[PROP] unicycle, body-velocity: prior std of the turn-rate offset "
                                            "(deg/s; c.11)", low=0.0)
    bias_turn_rate_drift_deg_s_per_rt_s: float = param(0.001, "[PROP] unicycle, body-velocity: random-walk intensity "
                                                       "of the turn-rate offset (deg/s/sqrt(s); c.11)", low=0.0)
    bias_turn: str = param("offset", "[PROP] under odometry_bias states, the turning input's error: offset (steering or "
                           "turn-rate offset delta), scale (kappa: u_turn -> (1 + kappa) u_turn, an error proportional "
                           "to the turn) or both (c.11.8)", choices=("offset", "scale", "both"))
    bias_turn_scale_std: float = param(0.05, "[PROP] prior std of the turn-scale error kappa (c.11.8)", low=0.0)
    bias_turn_scale_drift_per_rt_s: float = param(1e-4, "[PROP] random-walk intensity of kappa (1/sqrt(s); c.11.8)",
                                                  low=0.0)
    bias_thrust: bool = param(False, "[PROP] under odometry_bias states and filter.odometry odometer, a thrust-angle "
                              "state beta: the rear axle moves at beta from the car's heading (v_y = v tan beta), "
                              "learnt through the landmarks (c.11.12)")
    bias_thrust_std_deg: float = param(1.0, "[PROP] prior std of the thrust angle beta (deg; c.11.12)", low=0.0)
    bias_thrust_drift_deg_per_rt_s: float = param(0.0, "[PROP] random-walk intensity of beta (deg/sqrt(s); 0: a "
                                                  "constant of the car; c.11.12)", low=0.0)
    radar_yaw_states: bool = param(False, "[PROP] under odometry_bias states and a rig (sensors), each radar's yaw "
                                   "offset psi_j from its stated mounting as a state, learnt through the landmarks "
                                   "(c.13.1)")
    radar_yaw_std_deg: float = param(1.0, "[PROP] prior std of each radar's yaw offset (deg; c.13.1)", low=0.0)
    radar_yaw_drift_deg_per_rt_s: float = param(0.0, "[PROP] random-walk intensity of each yaw offset "
                                                "(deg/sqrt(s); 0: a constant of the car; c.13.1)", low=0.0)
    radar_yaw_reference: str = param("rig", "[PROP] what fixes the car's axis against the offsets: rig (their mean "
                                     "held at 0, as radarslam calibrate's rig reference, c.16) or none (each offset "
                                     "free within its prior; c.13.1)", choices=("rig", "none"))
    radar_time_states: bool = param(False, "[PROP] under odometry_bias states, filter.odometry odometer and a rig "
                                    "(sensors), each radar's time offset tau_j (its scans measured at stamp + tau_j) "
                                    "as a state, learnt through the landmarks (c.13.2)")
    radar_time_std_ms: float = param(50.0, "[PROP] prior std of each radar's time offset (ms; c.13.2)", low=0.0)
    radar_time_drift_ms_per_rt_s: float = param(0.0, "[PROP] random-walk intensity of each time offset "
                                                "(ms/sqrt(s); 0: a constant of the car; c.13.2)", low=0.0)
    car_states: str = param("estimate", "[PROP] the platform states after the pose (odometry biases, thrust angle, "
                            "each radar's yaw and time offset): estimate (learnt through the landmarks) or consider "
                            "(a Schmidt-Kalman filter: held at their prior, their uncertainty carried in the "
                            "covariance of the pose and the map; c.13.4)", choices=("estimate", "consider"))
    online_car_states: str = param("allow", "[PROP] refuse: a recording run with the car's online states "
                                   "(bias_thrust, radar_yaw_states, radar_time_states) is refused in one line (the "
                                   "automotive profile's: they make the given drives worse, c.13.3); allow runs them",
                                   choices=("refuse", "allow"))
    turn_noise_gain: float = param(0.0, "[PROP] k: each odometry sample's turning-input variance grows by (k u_turn)^2 "
                                   "(steering in rad, turn rate in rad/s), heteroscedastic input noise; 0: U alone "
                                   "(c.11.8)", low=0.0)
    measurement_corr_scans: float = param(1.0, "[PROP] n_c >= 1: a landmark's measurement error is correlated over "
                                          "consecutive scans with integrated correlation time n_c scans; association "
                                          "and updates take the equivalent white noise n_c R (c.11.9)", low=1.0)
    bias_tau_s: float = param(0.0, "[PROP] 0: the bias states are random walks; > 0: first-order Gauss-Markov "
                              "processes about 0 with this time constant (s), the drift driving them (c.11)", low=0.0)
    odometry_tau_s: float = param(0.0, "[PROP] 0: U is white noise per odometry sample (the paper); > 0: the input "
                                  "errors are Gauss-Markov with U's stds and this correlation time (s), and each "
                                  "sample takes the equivalent white noise U 2 tau / odometry_sample_s (c.11.6)", low=0.0)
    odometry_sample_s: float = param(0.0, "[PROP] the odometry sample interval (s) for filter.odometry_tau_s "
                                     "(Victoria Park: 0.025)", low=0.0)

    @property
    def R(self) -> np.ndarray:
        """Radar noise covariance diag(sigma_r^2, sigma_phi^2)."""
        return np.diag([self.range_std_m**2, math.radians(self.azimuth_std_deg) ** 2])

    @property
    def Q(self) -> np.ndarray:
        """Process noise covariance on the pose."""
        return np.diag([self.process_var_xy_m2, self.process_var_xy_m2, self.process_var_heading_rad2])


@dataclass
class LandmarkConfig:
    """Landmark management (docs/method.md c.1; APSIPA Table I unless marked)."""

    associator: str = param("nearest-neighbour", "data association (a registered name; c.4): nearest-neighbour "
                            "(sequential, the paper), batch (one update per landmark per scan), batch-joint (the batch measurements of "
                            "all landmarks in one stacked update per scan; a.7.4) or jcbb (joint compatibility "
                            "per cluster with batch updates; c.4.1)", registry=ASSOCIATORS)
    init: str = param("nearest", "[PROP] new landmark from its cluster: nearest (the detection of smallest range "
                      "with R, the paper) or cluster (the cluster mean, with the mean's noise and the extent "
                      "estimator's prior spread)", choices=("nearest", "cluster"))
    alpha: float = param(500.0, "log-distance threshold a new cluster must exceed to every landmark")
    beta: float = param(20.0, "log-distance association threshold (profile-dependent)")
    sift_radius_m: float = param(3.0, "gamma_s: sifting radius (m)", low=0.0, low_open=True)
    cluster_eps_m: float = param(2.5, "gamma_c: DBSCAN eps (m)", low=0.0, low_open=True)
    cluster_min_samples: int = param(2, "N_c2: DBSCAN minPts, the point itself included", low=1)
    tentative_gate_m: float = param(3.5, "gamma_a: cluster <-> unconfirmed-landmark gate (m, profile-dependent)", low=0.0, low_open=True)
    confirm_points: int = param(6, "N_c1: cluster size confirmed at once (Rule 1)", low=1)
    confirm_window: int = param(5, "M of the M/N confirmation (Rule 2)", low=1)
    confirm_hits: int = param(3, "N of the M/N confirmation (Rule 2)", low=1)
    removal_window: int = param(10, "M of the M/N removal", low=1)
    removal_max_hits: int = param(2, "delete when associated in <= this many of the last M scans", low=0)
    n_nearest_assoc: int = param(3, "N_s: nearest landmarks scored in association [REF]", low=1)
    n_nearest_new: int = param(5, "N_a: nearest landmarks scored in the alpha test [REF]", low=1)
    merge_distance_m: float = param(1.5, "merge landmarks closer than this (m, profile-dependent)", low=0.0)
    merge_axis_tol_m: float = param(math.inf, "also require |dx| or |dy| <= this (m); inf = no axis test", low=0.0,
                                    allow_inf=True)
    merge_max_per_scan: int = param(0, "at most this many merges per scan; 0 = unlimited", low=0)
    retire_distance_m: float = param(0.0, "[PROP] a landmark farther than this (m) from the scan's radar leaves "
                                     "the filter's state for the map (marginalised, never updated again; c.15); "
                                     "0 = never", low=0.0)
    jcbb_gate_probability: float = param(0.99, "[PROP] jcbb: chi-square gate probability of individual and joint "
                                         "compatibility (c.4.1)", low=0.0, low_open=True, high=0.999999)
    jcbb_max_nodes: int = param(2000, "[PROP] jcbb: hypothesis nodes the branch and bound may visit per scan; "
                                "the best found so far is used when they run out (c.4.1)", low=1)


@dataclass
class ExtentConfig:
    """Landmark extents (docs/method.md a.3-a.7, d; Decisions 3-6)."""

    estimator: str = param("rma-efa", "extent estimator (a registered name; a.3-a.5)", registry=EXTENT_ESTIMATORS)
    track: bool = param(True, "estimate RMA and EFA extents for every landmark")
    use_in_slam: bool = param(False, "'With extent' (Decision 6): contour sifting + extent-inflated noise")
    contour_sifting: bool = param(True, "with use_in_slam: extent-aware sifting (a.7.1); false = radius test for all")
    sifting_mode: str = param("measurement-contour", "extent-aware sifting test (a.7.1, Decision 6): the gate of the "
                              "predicted detection spread, or the paper's literal X ellipse (kappa)",
                              choices=("measurement-contour", "literal"))
    gate_probability: float = param(0.95, "measurement-contour gate probability (chi-square, 2 dof; a.7.1; chosen by "
                                    "scripts/sweep_sifting.py on training seeds)",
                                    low=0.0, low_open=True, high=0.999999)
    pre_init_spread: str = param("none", "[PROP] detection spread of a landmark whose extent is not initialised, "
                                 "for R_eff and sifting: none (R only, the paper), prior (prior_extent_radius_m) "
                                 "or scatter (its buffered detections, the prior until 3 are held)",
                                 choices=("none", "prior", "scatter"))
    prior_extent_radius_m: float = param(2.0, "[PROP] radius of the circular prior extent X0 = r^2 I (m; chosen on "
                                         "training seeds)",
                                         low=0.0, low_open=True)
    inflate_noise: bool = param(True, "with use_in_slam: R_eff = R + H_p gamma X H_p^T (a.7.2); for ablations")
    view_offset: str = param("none", "[PROP] with use_in_slam and the batch associators: where the part of an object "
                             "in view is centred (docs/method.md c.17): none (at the object's centre: the mean of m "
                             "detections has the spread / m) or uniform (anywhere on the object: X / 4 is added once, "
                             "not divided by m, so a long object seen in part does not drag the pose along itself)",
                             choices=("none", "uniform"))
    n_init: int = param(20, "N_i: initialise once more than this many detections are buffered", low=1)
    alpha0: float = param(50.0, "alpha_0 at initialisation", low=2.0, low_open=True)
    tau_s: float = param(100.0, "tau: extent decay constant (s)", low=0.0, low_open=True)
    spread_model: str = param("surface", "[PROP] where a landmark's detections lie, which sets the spread factor "
                              "gamma_z (docs/method.md a.11): surface (1/4, the paper's), contour or visible-faces "
                              "(1/2), scatter-centres (0.6)", choices=tuple(SPREAD_FACTORS))
    gamma_z: float = param(0.0, "gamma_z: spread factor, detection scatter = gamma_z X (seed eq. 4); 0 = the factor "
                           "of extent.spread_model (1/4 for the paper's surface model)", low=0.0)
    kappa: float = param(1.0, "contour-sifting scale kappa (a.7, h.12)", low=0.0, low_open=True)
    w_mode: str = param("max_trace", "scan-level W from the W(i) (h.3)", choices=("max_trace", "max_det", "mean"))
    eig_floor_m2: float = param(1e-4, "[PROP] eigenvalue floor of X after each update (m^2)", low=0.0, low_open=True)
    efa_mode: str = param("per_scan", "EFA baseline data (Decision 5)", choices=("per_scan", "sliding"))
    efa_window: int = param(20, "buffer length of the sliding EFA variant", low=3)
    efa_noise_correct: bool = param(False, "noise-corrected EFA semi-axes instead of the upper bound (d.3)")
    use_posterior_landmark: bool = param(False, "RM update against p_{k|k}, P_{k|k} instead of the prior (h.4)")
    beam_step_deg: float = param(0.5, "[PROP] visible-arc estimator: angular step of the scanner's beams (deg; "
                                 "docs/method.md a.9)", low=0.0, low_open=True, high=10.0)
    arc_min_scans: int = param(5, "[PROP] visible-arc estimator: per-scan widths needed before a trunk's circle "
                               "is reported (a.9)", low=1)
    mem_ekf_init_std: list[float] = param([10.0, 0.5], "[PROP] mem-ekf estimator: std of the initial shape about "
                                          "the EFA fit, [orientation_deg, semi_axis_m] (> 0; a.10)", length=2)
    mem_ekf_noise: str = param("sensor", "[PROP] mem-ekf estimator: what each detection's noise holds besides the "
                               "shape (a.10): full (the centroid's covariance and W(i) with the pose's), "
                               "no-centroid (W(i) only) or sensor (W(i) of the sensor noise alone; chosen on training "
                               "seeds, scripts/mem_ekf_noise.py)",
                               choices=("full", "no-centroid", "sensor"))
    mem_ekf_process_std: list[float] = param([0.5, 0.01], "[PROP] mem-ekf estimator: shape random walk per "
                                             "sqrt(s), [orientation_deg, semi_axis_m] (>= 0; a.10)", length=2)
    range_std_m: float = param(0.0, "[PROP] R of the extent step (W of seed eq. 5): range std (m); 0 = filter.range_std_m",
                               low=0.0)
    azimuth_std_deg: float = param(0.0, "[PROP] R of the extent step: azimuth std (deg); 0 = filter.azimuth_std_deg",
                                   low=0.0)
    view_model: str = param("auto", "[PROP] with use_in_slam: where a landmark's detections centre (a.12): full (its "
                            "centroid), partial (the mean of its outline's visible arc), auto (partial where "
                            "extent.spread_model is a partial-view model)", choices=("auto", "full", "partial"))
    view_shape: str = param("estimated", "[PROP] partial view: the shape of the arc model, estimated (the "
                            "partial-view estimator's), rma, or prior (X0); for ablations (a.12.8)",
                            choices=("estimated", "rma", "prior"))
    view_model_error_m: float = param(0.3, "[PROP] partial view: std (m) per axis of the model error of a "
                                      "landmark's mean detection, per scan (a.12.5; chosen on training seeds "
                                      "777-778, scripts/partial_view_sweep.py)", low=0.0)
    view_walk_m2_per_rad: float = param(0.0, "[PROP] partial view: random walk of a landmark's centroid with the "
                                        "viewing angle, q_w in P_pp += q_w |delta phi| I (m^2/rad; a.12.5)", low=0.0)
    view_shape_uncertainty: bool = param(True, "[PROP] partial view: add the shape's uncertainty, J P_xi J^T, to "
                                         "the model error of a landmark's predicted mean (a.12.5; chosen on "
                                         "training seeds 777-778)")
    view_init_correct: bool = param(True, "[PROP] partial view: a new landmark's cluster mean moved to the "
                                    "centroid of the prior shape seen from the sensor (a.12.6)")
    view_prior_radius_m: float = param(1.0, "[PROP] partial view: radius of the circular prior shape X0 = r^2 I of "
                                       "a newborn landmark, and of its prior spread (m; chosen on training seeds "
                                       "777-778, scripts/partial_view_sweep.py; a.12.6-a.12.7)",
                                       low=0.0, low_open=True)
    view_prior_std: float = param(1.0, "[PROP] partial-view estimator: std of each log-matrix entry of the "
                                  "newborn shape about X0 (a.12.7)", low=0.0, low_open=True)
    view_process_std: float = param(0.01, "[PROP] partial-view estimator: random walk of the log-matrix entries "
                                    "per scan (a.12.7)", low=0.0)
    view_shape_data: str = param("mean-spread", "[PROP] partial-view estimator: what of each scan updates the "
                                 "shape, the detections' mean and spread, or the spread alone (which does not "
                                 "depend on the centroid's estimate; a.12.7)", choices=("mean-spread", "spread"))
    view_spread_rel_error: float = param(0.3, "[PROP] partial-view estimator: relative model error of the "
                                         "detections' spread (a.12.7)", low=0.0)
    view_jacobian: str = param("analytic", "[PROP] partial view: the arc's shape derivatives, analytic (a.12.9) "
                               "or central-difference (step 1e-4)", choices=("analytic", "central-difference"))

    @property
    def partial_view(self) -> bool:
        """True when SLAM uses the partial-view measurement model (a.12): ``use_in_slam`` and
        ``view_model`` partial, or auto with a partial-view ``spread_model``."""
        if not self.use_in_slam or self.view_model == "full":
            return False
        return self.view_model == "partial" or self.spread_model in PARTIAL_VIEW_SPREAD_MODELS

    @property
    def spread_factor(self) -> float:
        """gamma_z: ``extent.gamma_z`` when set, else the factor of ``extent.spread_model`` (a.11)."""
        return self.gamma_z or SPREAD_FACTORS[self.spread_model]

    def R(self, filter_R: np.ndarray) -> np.ndarray:
        """Detection noise of the extent step: the sensor's, where the SLAM R also carries a point
        landmark's spread (its own entries when set, else ``filter_R``'s)."""
        r = self.range_std_m or math.sqrt(filter_R[0, 0])
        a = math.radians(self.azimuth_std_deg) if self.azimuth_std_deg else math.sqrt(filter_R[1, 1])
        return np.diag([r * r, a * a])


@dataclass
class MetricsConfig:
    """Evaluation (docs/method.md e, f; Decision 7)."""

    match_gate_m: float = param(5.0, "[PROP] landmark <-> vehicle matching gate (m)", low=0.0, low_open=True)
    include_stale: bool = param(False, "match landmarks of departed vehicles in the GWD (h.10)")
    missed_grace_scans: int = param(5, "[PROP] scans in range before an unmapped vehicle counts as missed", low=0)


@dataclass
class SensorConfig:
    """Where the radar sits on the platform (docs/recordings.md "Mounting"), and the 3-D settings.

    ``mount_x_m``, ``mount_y_m``, ``mount_yaw_deg`` are the configuration's way to state one radar's
    mounting; :meth:`radarslam.core.mounting.Mounting.from_config` turns them into the one mounting
    type (``EstimatorConfig.mounting``) and :meth:`~radarslam.core.mounting.Mounting.sensor_config`
    writes one back. The simulator measures from it (zero by default: the platform origin); a
    bag's ``/tf_static`` wins over these values when it has the radar's frame, and under a rig a
    recording run writes here the mounting it takes for the steps that take one (the radar of the
    most detections; docs/recordings.md "Several radars").
    """

    mount_x_m: float = param(0.0, "sensor position ahead of the platform origin (m)")
    mount_y_m: float = param(0.0, "sensor position to the left of the platform origin (m)")
    mount_yaw_deg: float = param(0.0, "sensor boresight relative to the platform heading, counter-clockwise (deg)",
                                 low=-360.0, high=360.0)
    mount_z_m: float = param(0.0, "3-D recordings: sensor height above the platform origin (m; docs/recordings.md "
                             "\"Mounting\")")
    mount_roll_deg: float = param(0.0, "3-D recordings: sensor roll about its x axis (deg, ZYX with pitch and yaw; "
                                  "180 = upside down)", low=-360.0, high=360.0)
    mount_pitch_deg: float = param(0.0, "3-D recordings: sensor pitch (deg, ZYX)", low=-360.0, high=360.0)
    mount_quaternion: list[float] = param([], "3-D recordings: sensor-to-platform rotation [x, y, z, w]; when given "
                                          "it replaces mount_roll/pitch/yaw_deg")
    elevation_gate_deg: float = param(90.0, "[PROP] 3-D recordings run as SLAM: keep detections within this elevation "
                                      "of the levelled horizontal plane (deg; docs/method.md c.10.6)", low=0.0,
                                      high=90.0)
    height_min_m: float = param(-math.inf, "[PROP] 3-D recordings run as SLAM: keep detections at least this high "
                                "above the IMU in the levelled frame (m; -inf = no bound; c.10.6)", allow_inf=True)
    height_max_m: float = param(math.inf, "[PROP] 3-D recordings run as SLAM: keep detections at most this high above "
                                "the IMU in the levelled frame (m; inf = no bound; c.10.6)", allow_inf=True)
    attitude_time_constant_s: float = param(2.0, "[PROP] 3-D recordings run as SLAM: time constant of the "
                                            "accelerometer's pull on the gyro-integrated attitude (s; c.10.6)",
                                            low=0.0, low_open=True)
    doppler_sign: int = param(1, "sign of the recording's Doppler column: 1 when positive receding (the raw radial "
                              "velocity, docs/recordings.md \"Doppler\"), -1 for a column stored approaching-positive "
                              "(multiplied by -1 when read); a column whose static consensus disagrees with the "
                              "odometry's speed is refused", choices=(1, -1))
    doppler_scale: float = param(1.0, "[PROP] what the recording's Doppler column reads of the radial speed: the column "
                                 "is divided by it (a 2-D radar reads v cos(elevation) of a target above or below "
                                 "its plane, < 1; docs/method.md c.16.5); a calibration with its own (reference "
                                 "truth) replaces it", low=0.5, high=1.5)
    gyro_bias_from_rest: bool = param(True, "[PROP] 3-D recordings run as SLAM: subtract the gyro's mean over the "
                                      "scans at rest before the first motion (its bias; c.10.6)")


@dataclass
class RigSensorConfig:
    """One radar of a multi-radar rig given in the config: a ``[[sensors]]`` table, the same as one row of
    a recording's ``sensors.csv`` (docs/recordings.md "A rig in the config") except that its yaw is in
    degrees, as the single ``[sensor]`` table's ``mount_yaw_deg`` is. ``id``, ``x_m``, ``y_m`` and
    ``yaw_deg`` are required (checked by :func:`radarslam.config.loading._apply_rig`); ``max_range_m``
    and ``fov_deg`` are None when not stated (absent from the TOML, which has no null)."""

    id: int = param(0, "the sensor_id of this radar's detections (a whole number >= 0)", low=0)
    x_m: float = param(0.0, "radar position ahead of the platform origin (m)")
    y_m: float = param(0.0, "radar position to the left of the platform origin (m)")
    yaw_deg: float = param(0.0, "radar boresight relative to the platform heading, counter-clockwise (DEGREES; "
                           "sensors.csv's yaw_rad is radians)", low=-360.0, high=360.0)
    name: str = param("", "the radar's name (optional)")
    max_range_m: float | None = param(None, "the radar's maximum range (m, > 0; optional)", low=0.0, low_open=True)
    fov_deg: float | None = param(None, "the radar's full opening angle (deg, in (0, 360]; optional)", low=0.0,
                                  low_open=True, high=360.0)


#: The keys of a ``[[sensors]]`` table that must be given (as sensors.csv's required columns).
RIG_REQUIRED = ("id", "x_m", "y_m", "yaw_deg")


@dataclass(frozen=True)
class EstimatorConfig:
    """The sections the estimator receives (config by owner): ``filter``, ``landmarks``, ``extent`` and
    ``sensor`` (the radar's mounting, for the Doppler), and the rig's mountings.

    The simulation, world and metrics sections never reach :class:`~radarslam.slam.EkfSlam`.
    """

    filter: FilterConfig
    landmarks: LandmarkConfig
    extent: ExtentConfig
    #: The radar's mounting: the Doppler's directions and the sensor's velocity (c.10.1, c.10.4, c.10.5.1).
    sensor: SensorConfig = field(default_factory=SensorConfig)
    #: A multi-radar rig's :class:`~radarslam.core.mounting.Mounting` s (the config's ``[[sensors]]``,
    #: or the recording's sensors.csv set by the recording run), empty for one radar (``sensor``): what
    #: the radar alone observes (c.10.5.1, c.12.2) and the retirement's lever-arm margin (c.15).
    rig: tuple = ()

    @property
    def mounting(self) -> Mounting:
        """The one radar's mounting, ``[sensor]``'s (:meth:`Mounting.from_config`): what the steps that
        take one mounting use for a scan in the platform frame (the Doppler gate's and odometry's
        directions, c.10.1), and without a rig the radar alone's lever arm and the retirement's margin."""
        return Mounting.from_config(self.sensor)


@dataclass
class Config:
    """Everything a run needs apart from the seed."""

    profile: str = param("apsipa", "parameter profile (Decision 1; victoria-park for the real data)",
                         profiles=True)
    trajectory: TrajectoryConfig = field(default_factory=TrajectoryConfig)
    odometer: OdometerConfig = field(default_factory=OdometerConfig)
    radar: RadarConfig = field(default_factory=RadarConfig)
    world: WorldConfig = field(default_factory=WorldConfig)
    filter: FilterConfig = field(default_factory=FilterConfig)
    landmarks: LandmarkConfig = field(default_factory=LandmarkConfig)
    extent: ExtentConfig = field(default_factory=ExtentConfig)
    metrics: MetricsConfig = field(default_factory=MetricsConfig)
    sensor: SensorConfig = field(default_factory=SensorConfig)
    #: A multi-radar rig, ``[[sensors]]`` in TOML (docs/recordings.md "A rig in the config"): one
    #: :class:`RigSensorConfig` per radar, in place of the recording's ``sensors.csv`` (``--sensors FILE``
    #: wins over it). Empty (the default): the recording's own rig, if any. Not a section: an array of tables.
    sensors: list[RigSensorConfig] = field(default_factory=list, metadata={
        "doc": "a multi-radar rig, one [[sensors]] table per radar (id, x_m, y_m, yaw_deg [, name, max_range_m, "
               "fov_deg]); replaces the recording's sensors.csv"})

    @property
    def estimator(self) -> EstimatorConfig:
        """The estimator's own sections (shared, not copied)."""
        rig = tuple(Mounting.from_rig_config(s) for s in self.sensors)
        return EstimatorConfig(self.filter, self.landmarks, self.extent, self.sensor, rig)

"""The simulation's configuration sections (docs/method.md section b): the platform's trajectory, its
odometer, the radar and the car park, re-exported by :mod:`radarslam.config.sections`."""

from __future__ import annotations

from dataclasses import dataclass

from radarslam.config.fields import param
from radarslam.config.tables import CARPARK_VEHICLES, MAX_STEPS


# --------------------------------------------------------------------------------------------
# Simulation (docs/method.md section b)
# --------------------------------------------------------------------------------------------

@dataclass
class TrajectoryConfig:
    """Platform trajectory and true motion (docs/method.md b.2)."""

    n_steps: int = param(120, "number of time steps K (at most 100,000: memory and time)", low=2, high=MAX_STEPS)
    dt_s: float = param(0.16, "time step (s)", low=0.0, low_open=True)
    speed_mps: float = param(4.0, "commanded speed v (m/s)")
    turn_rate_rad_s: float = param(0.32, "commanded turn rate psi during the turn (rad/s)")
    turn_start: int = param(10, "first step k (1-based) with psi != 0", low=1)
    turn_end: int = param(100, "last step k (inclusive) with psi != 0", low=1)
    initial_pose: list[float] = param([0.0, 0.0, 0.0], "true pose at k = 1 [x_m, y_m, theta_rad]", length=3)
    process_var_xy_m2: float = param(1.5e-3, "process-noise variance Q on x and y (m^2)", low=0.0)
    process_var_heading_rad2: float = param(5e-5, "process-noise variance Q on the heading (rad^2)", low=0.0)


@dataclass
class OdometerConfig:
    """Odometer readings u_bar = u + eta + bias (docs/method.md b.3)."""

    speed_std_mps: float = param(0.02, "speed-noise std (m/s)", low=0.0)
    turn_rate_std_deg_s: float = param(0.008, "turn-rate-noise std (deg/s)", low=0.0)
    speed_bias_mps: float = param(0.0, "[PROP] constant speed bias (m/s); 0 in both papers (h.15)")
    speed_scale: float = param(1.0, "[PROP] the speed reading is speed_scale times the true speed (a wheel-radius "
                               "error; 1 = none; c.11)", low=0.0, low_open=True)
    turn_rate_bias_deg_s: float = param(0.0, "[PROP] constant turn-rate bias (deg/s)")
    gyro_std_deg_s: float = param(0.1, "[PROP] simulated gyro's yaw-rate noise std (deg/s), drawn with radar.doppler "
                                  "on from the trial's child stream 3 (docs/method.md b.4.3, c.10.5)", low=0.0)


@dataclass
class RadarConfig:
    """The 'ideal' radar of both papers (docs/method.md b.4)."""

    max_range_m: float = param(20.0, "radar range R_max (m)", low=0.0, low_open=True)
    range_std_m: float = param(0.5, "range-noise std (m)", low=0.0)
    azimuth_std_deg: float = param(1.0, "azimuth-noise std (deg)", low=0.0)
    detection_probability: float = param(0.9, "P_D of each potential detection", low=0.0, high=1.0)
    points_per_m2: float = param(0.8, "mean potential detections per m^2 of vehicle area (at most 100)", low=0.0,
                                 high=100.0)
    points_var: float = param(1.5, "variance of the potential-detection count (at most 10,000)", low=0.0, high=1e4)
    clutter_rate_per_m2: float = param(0.005, "clutter rate lambda (1/m^2, Decision 9; at most 10)", low=0.0,
                                       high=10.0)
    clutter_grid_m: float = param(0.2, "clutter position grid (m)", low=0.0, low_open=True)
    scene_min_m: float = param(-15.0, "lower corner of the square clutter scene (m)")
    scene_max_m: float = param(45.0, "upper corner of the square clutter scene (m)")
    shuffle_detections: bool = param(True, "[PROP] shuffle each scan's detection order (b.4)")
    spread_model: str = param("surface", "where a car's detections lie (b.4.1): surface (uniform over the rectangle, "
                              "the paper's), contour (uniform on its outline), visible-faces (on the sides that "
                              "face the sensor, count set by the projected width) or scatter-centres (Poisson "
                              "returns from the visible corners and wheel houses, the visible faces and the "
                              "footprint, fewer with range)",
                              choices=("surface", "contour", "visible-faces", "scatter-centres"))
    points_per_m: float = param(1.5, "[PROP] visible-faces: mean potential detections per metre of the car's width "
                                "seen from the sensor (at most 100)", low=0.0, high=100.0)
    # scatter-centres (docs/method.md b.4.2): expected potential returns per scan at the reference range
    scatter_corner_points: float = param(1.0, "[PROP] scatter-centres: mean returns of each visible corner (at most "
                                         "100)", low=0.0, high=100.0)
    scatter_wheel_points: float = param(0.75, "[PROP] scatter-centres: mean returns of each visible wheel house (at "
                                        "most 100)", low=0.0, high=100.0)
    scatter_face_points_per_m: float = param(0.55, "[PROP] scatter-centres: mean face returns per metre of the width "
                                             "the car presents (at most 100)", low=0.0, high=100.0)
    scatter_underbody_points: float = param(0.4, "[PROP] scatter-centres: mean far-side / under-body returns, uniform "
                                            "on the footprint (at most 100)", low=0.0, high=100.0)
    scatter_wheel_inset_m: float = param(0.85, "[PROP] scatter-centres: wheel centre from the nearer end of the car "
                                         "(m; at most a quarter of the length is used)", low=0.0, high=10.0)
    scatter_jitter_m: float = param(0.1, "[PROP] scatter-centres: std of a corner or wheel return about its "
                                     "scatterer, per axis (m)", low=0.0, high=1.0)
    scatter_ref_range_m: float = param(10.0, "[PROP] scatter-centres: range at which the means above hold (m)",
                                       low=0.0, low_open=True, high=1000.0)
    scatter_near_range_m: float = param(3.0, "[PROP] scatter-centres: the count stops growing inside this range (m)",
                                        low=0.1, high=1000.0)
    scatter_range_exponent: float = param(1.0, "[PROP] scatter-centres: the means scale as (ref_range / range)^p "
                                          "(p, at most 4)", low=0.0, high=4.0)
    doppler: bool = param(False, "[PROP] give each detection a radial velocity, Scan.channels['doppler_mps'] "
                          "(b.4.3); false leaves the simulation bit-identical")
    doppler_std_mps: float = param(0.1, "[PROP] Doppler noise std of a vehicle detection (m/s; b.4.3)", low=0.0)
    clutter_doppler_max_mps: float = param(5.0, "[PROP] a clutter detection's Doppler is uniform in +-this (m/s; "
                                           "b.4.3)", low=0.0)


@dataclass
class WorldConfig:
    """The car park (docs/method.md b.1)."""

    layout: str = param("paper", "where the vehicles come from (b.1): 'paper' (the list world.vehicles, with the "
                        "trajectory of b.2) or 'rows' (a generated car park of parked rows driven past by a "
                        "serpentine through its aisles, b.1.1)", choices=("paper", "rows"))
    vehicles: list[list[float]] = param(CARPARK_VEHICLES, "rectangles [x_left, y_bottom, size_x, size_y] (m); "
                                        "layout 'paper'")
    rows: int = param(10, "[PROP] layout 'rows': rows of parked cars, two per aisle (b.1.1)", low=1, high=1000)
    cars_per_row: int = param(50, "[PROP] layout 'rows': cars side by side in each row", low=1, high=10_000)
    car_length_m: float = param(4.5, "[PROP] layout 'rows': car length, across the row (m)", low=0.0, low_open=True)
    car_width_m: float = param(1.8, "[PROP] layout 'rows': car width, along the row (m)", low=0.0, low_open=True)
    car_gap_m: float = param(0.8, "[PROP] layout 'rows': gap between neighbouring cars of a row (m)", low=0.0)
    aisle_width_m: float = param(8.0, "[PROP] layout 'rows': width of the aisle the platform drives along (m)",
                                 low=0.0, low_open=True)
    row_back_gap_m: float = param(0.0, "[PROP] layout 'rows': strip between two rows parked back to back (m)",
                                  low=0.0)
    row_margin_m: float = param(5.0, "[PROP] layout 'rows': straight driving before the first and after the last "
                                "car of a row (m)", low=0.0)
    departing_vehicle: int = param(5, "index of the vehicle that leaves (-1: none); 5 is the car at (-13, 6)", low=-1)
    departure_step: int = param(60, "[PROP] first step k at which it is gone (Decision 2, h.10)", low=1)
    moving_vehicles: int = param(0, "[PROP] cars driving to and fro on their own straight lanes through the car "
                                 "park, detected like parked ones (b.4.3); 0 leaves the simulation bit-identical",
                                 low=0, high=100)
    moving_speed_mps: float = param(3.0, "[PROP] speed of the moving cars (m/s; b.4.3)", low=0.0)

"""``radarslam run``: one seeded car-park trial, a summary table and its result files."""

from __future__ import annotations

import argparse
import dataclasses
import sys
import time

import numpy as np

from radarslam import __version__
from radarslam.cli.common import add_backend_arg, add_config_args, config_from_args
from radarslam.config import to_dict, to_toml
from radarslam.core.errors import InputError
from radarslam.io.results import (atomic_write_text, prepare_out_dir, refuse_finished, write_bias_csv, write_json,
                                  write_trajectory_csv, write_tum)


def add_parser(sub) -> None:
    p = sub.add_parser("run", help="run one seeded trial of the simulated car park, a dataset (--dataset) or your "
                       "own recording (--recording)")
    p.add_argument("--seed", type=int, default=1, help="trial seed (default 1)")
    add_config_args(p)
    ext = p.add_mutually_exclusive_group()
    ext.add_argument("--extent", dest="extent", action="store_true", default=None,
                     help="'With extent': contour sifting and extent-inflated noise (Decision 6)")
    ext.add_argument("--no-extent", dest="extent", action="store_false", help="'No extent' (the default)")
    p.add_argument("--out", required=True, metavar="DIR",
                   help="output directory (created with its parents); one that holds a run is refused")
    p.add_argument("--overwrite", action="store_true", help="replace the run already in --out")
    p.add_argument("--dataset", nargs=2, metavar=("NAME", "PATH"),
                   help="run on a recorded dataset instead of the simulation (victoria-park DIR; nuscenes DATAROOT "
                        "--scene NAME or radarscenes DATAROOT --sequence N in their official layouts, run as "
                        "--recording runs a recording)")
    p.add_argument("--protocol", choices=("aligned", "published"), default="aligned",
                   help="--dataset victoria-park: 'aligned' (map frame of the first scan, GPS-aligned RMSE) or "
                        "'published' (start at the first GPS fix in the GPS frame, no alignment, error within "
                        "25 ms of each fix; the TUM file in that frame on the MAT time base)")
    p.add_argument("--input", choices=("laser", "trees"), default="laser",
                   help="--dataset victoria-park: the raw laser returns ('laser', default profile victoria-park) or "
                        "ACFR's tree detections ('trees', default profile victoria-park-trees)")
    p.add_argument("--first-scan", type=int, default=None, help="--dataset: first scan (0-based)")
    p.add_argument("--scans", type=int, default=None, help="--dataset: number of scans")
    p.add_argument("--no-plot", action="store_true", help="skip the figure even if matplotlib is installed")
    from radarslam.cli.recording import add_recording_args

    add_recording_args(p, run=True)
    from radarslam.cli.official import add_official_args

    add_official_args(p)
    add_backend_arg(p)
    p.set_defaults(func=run)


#: A car-park run of at least this many scans shows a progress bar even when stderr is not a terminal.
LONG_RUN_SCANS = 2000


def run(args: argparse.Namespace) -> int:
    from radarslam.cli.official import OFFICIAL, check_official_args, official_run_args

    check_official_args(args)
    official = bool(args.dataset) and args.dataset[0] in OFFICIAL   # nuScenes, RadarScenes: run as recordings
    if args.recording or official:
        from radarslam.cli.recording import run_recording_cmd

        return run_recording_cmd(official_run_args(args) if official else args)
    if args.dataset:
        return run_dataset_cmd(args)
    from radarslam.simulation.trial import check_simulation_config, run_trial    # the car park's trial only

    if args.seed < 0:
        raise InputError(f"--seed: expected an integer >= 0, got {args.seed}")
    config = config_from_args(args)
    if args.extent is not None:
        config = dataclasses.replace(config, extent=dataclasses.replace(config.extent, use_in_slam=args.extent))
    check_simulation_config(config)   # before --out is created: an argument error leaves nothing behind
    out = prepare_out_dir(args.out)
    refuse_finished(out / "run.json", "--out", args.overwrite)
    t0 = time.perf_counter()
    # a long single run shows its progress (a terminal, or more than LONG_RUN_SCANS scans)
    from radarslam.runs.progress import Progress

    from radarslam.compiling.first_run import announce, choose

    first = choose(config.filter.backend, simulation=True, matching=True, config=config)  # the first-run rule
    announce(first, config)
    n = config.trajectory.n_steps
    bar = Progress(n, 0, unit="scans", enabled=n >= LONG_RUN_SCANS or sys.stderr.isatty())
    res = run_trial(config, args.seed, on_scan=bar.update, first_run=first)
    wall = time.perf_counter() - t0
    write_outputs(out, res, wall, argv=sys.argv)
    print(summary_table(res))
    print(f"\nwrote {out}/ (metrics.json, per_step.csv, trajectory.csv, map.json, config.toml, run.json"
          + (", map.png)" if (out / "map.png").exists() else ")"))
    return 0


def _defined(value: float, fmt: str, why: str) -> str:
    """``value`` formatted, or "not defined: <why>" for a NaN (never a bare nan in a summary)."""
    return format(value, fmt) if np.isfinite(value) else f"not defined: {why}"


def summary_table(res) -> str:
    m = res.metrics
    lines = [
        f"radarslam run  seed={res.seed}  profile={res.config.profile}  extent={'on' if res.config.extent.use_in_slam else 'off'}",
        "",
        "| metric | value |",
        "|---|---|",
        f"| position avg. RMSE (m) | {m['position_avg_rmse_m']:.3f} |",
        f"| heading avg. RMSE (deg) | {m['heading_avg_rmse_deg']:.3f} |",
        f"| final position error (m) | {m['final_position_error_m']:.3f} |",
        f"| landmarks at the end | {m['n_landmarks_final']} |",
        f"| false landmarks at the end | {m['final_false']} (mean over scans {m['mean_false']:.2f}, max {m['max_false']}) |",
        f"| missed vehicles at the end | {m['final_missed']} (mean {m['mean_missed']:.2f}, max {m['max_missed']}) |",
        f"| landmark position MAE at the end (m) | "
        f"{_defined(m['landmark_mae_m'], '.3f', 'no vehicle has a landmark at the end')} |",
        f"| mean inclusion delay (scans) | "
        f"{_defined(m['mean_inclusion_delay'], '.2f', 'no vehicle was both in range and mapped')} |",
        f"| removal delay of the departed car (scans) | {_defined(m['mean_removal_delay'], '.2f', 'the departed car never had a landmark, or the platform did not come back in range')} |",
    ]
    for key in ("gwd_rma_final_moment", "gwd_efa_final_moment", "gwd_rma_final_full", "gwd_efa_final_full"):
        if key in m:
            value = _defined(m[key], ".3f", "no landmark with an initialised extent matched a vehicle at the end")
            lines.append(f"| final mean GWD {key.split('_')[1].upper()} ({key.split('_')[-1]}) (m) | {value} |")
    lines += ["", "| vehicle | centre | error at the end (m) |", "|---|---|---|"]
    for v, e in zip(res.scenario.truth.vehicles, m["final_errors"]):
        state = "departed" if not v.present(res.record.poses.shape[0]) else ("not mapped" if not np.isfinite(e) else f"{e:.2f}")
        lines.append(f"| {v.index} | ({v.center[0]:g}, {v.center[1]:g}) | {state} |")
    return "\n".join(lines)


def write_outputs(out, res, wall: float, argv=None) -> None:
    """Every file of a single run."""
    m = res.metrics
    K = res.record.poses.shape[0]
    t = np.array([s.t for s in res.scenario.scans])
    scalars = {k: v for k, v in m.items() if np.ndim(v) == 0}
    per_vehicle = {k: m[k] for k in ("final_errors", "inclusion_delay", "removal_delay")}
    write_json(out / "metrics.json", {"scalars": scalars, "per_vehicle": per_vehicle})
    cols = {"k": np.arange(1, K + 1), "t": t, "position_error_m": m["position_error_m"],
            "heading_error_rad": m["heading_error_rad"], "nees": m["nees"], "n_landmarks": res.record.n_landmarks,
            "n_detections": res.record.n_detections, "n_associated": res.record.n_associated,
            "false_landmarks": m["false_per_scan"], "missed_vehicles": m["missed_per_scan"]}
    for key in ("gwd_rma_moment", "gwd_efa_moment", "gwd_rma_full", "gwd_efa_full"):
        if key in m:
            cols[key] = m[key]
    header = ",".join(cols)
    rows = [",".join(repr(float(c[i])) if isinstance(c[i], (float, np.floating)) else str(c[i]) for c in cols.values())
            for i in range(K)]
    atomic_write_text(out / "per_step.csv", header + "\n" + "\n".join(rows) + "\n")
    write_trajectory_csv(out / "trajectory.csv", t, res.record.poses, res.scenario.truth.poses)
    write_tum(out / "trajectory_tum.txt", t, res.record.poses)
    write_tum(out / "groundtruth_tum.txt", t, res.scenario.truth.poses)
    mp = res.record.maps[-1]
    write_json(out / "map.json", {"landmarks": [
        {"id": int(i), "position": p, "cov": c, "created_scan": int(cr),
         "rma_extent": x if np.all(np.isfinite(x)) else None, "efa_extent": e if np.all(np.isfinite(e)) else None}
        for i, p, c, cr, x, e in zip(mp.ids, mp.positions, mp.covs, mp.created, mp.rma, mp.efa)]})
    atomic_write_text(out / "config.toml", to_toml(res.config))
    write_json(out / "run.json", {"seed": res.seed, "version": __version__, "argv": argv,
                                  "wall_seconds": wall, "filter_seconds": res.record.seconds,
                                  "engine": res.record.engine,
                                  "config": to_dict(res.config)})
    from radarslam.viz import have_matplotlib

    if have_matplotlib():
        from radarslam.viz.carpark import plot_carpark_run

        plot_carpark_run(out / "map.png", res)


def run_dataset_cmd(args: argparse.Namespace) -> int:
    """``radarslam run --dataset NAME PATH``: the whole recording, run as a recording is (one
    :class:`~radarslam.runs.recording.RecordingRun`), evaluated against its GPS."""
    from radarslam.runs.dataset import (compare_tree_diameters, dead_reckoning, evaluate_against_gps, duplicate_landmarks, evaluate_published, nis_fraction, position_consistency, run_dataset, victoria_park_options)
    from radarslam.runs.recording_outputs import bias_metrics
    from radarslam.io.datasets import list_datasets

    name, path = args.dataset
    if name not in list_datasets():
        from radarslam.cli.official import OFFICIAL

        raise InputError(f"--dataset: expected one of {sorted([*list_datasets(), *OFFICIAL])}, got {name!r}")
    if args.input != "laser" and name != "victoria-park":
        raise InputError(f"--input: 'trees' is defined for --dataset victoria-park, got --dataset {name}")
    if args.profile is None and not args.config:
        from radarslam.io.datasets.victoria_park import INPUT_PROFILES

        args.profile = INPUT_PROFILES[args.input] if name == "victoria-park" else "apsipa"
    config = config_from_args(args)
    if args.extent is not None:
        config = dataclasses.replace(config, extent=dataclasses.replace(config.extent, use_in_slam=args.extent))
    published = args.protocol == "published"
    if published:
        from radarslam.io.datasets.victoria_park import PUBLISHED_START

        if name != "victoria-park" or args.first_scan:
            raise InputError("--protocol: 'published' is defined for the whole victoria-park run from its first "
                             f"scan, got --dataset {name} --first-scan {args.first_scan}")
        config = dataclasses.replace(config, filter=dataclasses.replace(config.filter, initial_pose=list(PUBLISHED_START)))
    out = prepare_out_dir(args.out)
    refuse_finished(out / "run.json", "--out", args.overwrite)
    t0 = time.perf_counter()
    loader = victoria_park_options(config, args.input) if name == "victoria-park" else None
    res = run_dataset(name, path, config, first_scan=args.first_scan, n_scans=args.scans, loader_options=loader)
    ev = evaluate_against_gps(res)
    pub = evaluate_published(res) if published else None
    cons = position_consistency(res, pub) if published else None     # docs/method.md v.7
    dr_poses = dead_reckoning(res.recording, res.config)[1]
    dr_ev = evaluate_against_gps(res, dr_poses)
    diam = compare_tree_diameters(res) if res.reference_hits is not None and args.input == "laser" else None
    nis = nis_fraction(res)
    dup = duplicate_landmarks(res)
    wall = time.perf_counter() - t0
    mp = res.final_map
    write_trajectory_csv(out / "trajectory.csv", res.times, res.poses)
    if res.bias is not None:                      # filter.odometry_bias "states" (docs/method.md c.11)
        write_bias_csv(out / "bias.csv", res.times, res.bias, res.bias_std, res.bias_names)
    if published:  # the GPS frame, seconds on the MAT time base, for evo or a few lines of numpy
        from radarslam.io.datasets.victoria_park import MAT_EPOCH_MS

        write_tum(out / "trajectory_tum.txt", res.times + MAT_EPOCH_MS / 1000.0, res.poses)
    else:
        write_tum(out / "trajectory_tum.txt", res.times, res.poses)
    frame = "GPS frame (x = Lo_m, y = La_m)" if published else "odometry frame of the first scan"
    write_json(out / "map.json", {"frame": frame, "landmarks": [
        {"id": int(i), "position": p, "cov": c, "created_scan": int(cr),
         "rma_extent": x if np.all(np.isfinite(x)) else None, "efa_extent": e if np.all(np.isfinite(e)) else None}
        for i, p, c, cr, x, e in zip(mp.ids, mp.positions, mp.covs, mp.created, mp.rma, mp.efa)]})
    metrics = {"dataset": name, "input": args.input, "scans": int(res.times.size), "landmarks_final": int(mp.ids.size),
               "gps_aligned_rmse_m": ev["rmse_m"], "gps_aligned_max_m": ev["max_m"],
               "gps_aligned_median_m": ev.get("median_m"), "gps_rmse_all_fixes_m": ev.get("rmse_all_m"),
               "gps_fixes": ev["n_fixes"], "gps_jumps_removed": ev.get("n_gps_jumps_removed"),
               "alignment_rotation_deg": ev.get("rotation_deg"), "alignment_translation_m": ev.get("translation_m"),
               "odometry_only_rmse_m": dr_ev["rmse_m"], "odometry_only_max_m": dr_ev["max_m"],
               "trunk_diameters": None if diam is None else {
                   k: v for k, v in diam.items() if not isinstance(v, np.ndarray)},
               "protocol": args.protocol,
               "published_rmse_m": None if pub is None else pub["rmse_m"],
               "published_max_m": None if pub is None else pub["max_m"],
               "published_scans_matched": None if pub is None else pub["n_matched"],
               "duplicated_trunks": {"n_pairs": dup["n_pairs"], "n_landmarks": dup["n_landmarks"],
                                     "diameter_m": dup["diameter_m"],
                                     "pairs_within_m": {str(k): v for k, v in dup["pairs_within"].items()}},
               "consistency": None if cons is None else {
                   k: v for k, v in cons.items() if not isinstance(v, np.ndarray)},
               "nis": {k: nis[k] for k in ("n", "mean", "median", "inside", "below", "above", "band", "probability")},
               "odometry_bias": bias_metrics(res.record),
               "engine": res.engine, "filter_seconds": res.seconds, "filter_ms_per_scan": 1e3 * res.seconds / max(res.times.size, 1),
               "load_seconds": res.metrics["load_seconds"], "wall_seconds": wall}
    write_json(out / "metrics.json", metrics)
    atomic_write_text(out / "config.toml", to_toml(res.config))
    write_json(out / "run.json", {"dataset": name, "input": args.input, "path": str(path), "first_scan": args.first_scan,
                                  "scans": args.scans, "version": __version__, "argv": sys.argv,
                                  "config": to_dict(res.config)})
    if not args.no_plot:
        _dataset_plots(out, res, ev, (dr_poses, dr_ev), diam, pub, nis, args, cons)
    _print_dataset_summary(name, metrics, res, ev, dr_ev, pub, nis, diam, dup, config)
    if cons is not None:
        print(f"2-sigma bound (filter + GPS std {cons['gps_std_m']:g} m at this fix and the first) contains the GPS error on both axes at "
              f"{100 * cons['inside_both']:.1f}% of {cons['n']} scans (east {100 * cons['inside_east']:.1f}%, north "
              f"{100 * cons['inside_north']:.1f}%; filter alone {100 * cons['inside_both_filter_only']:.1f}%; "
              f"95.4% per axis expected)")
    print(f"wrote {out}/")
    return 0


def _dataset_plots(out, res, ev, dead_reckoning, diam, pub, nis, args, cons=None) -> None:
    """``map.png``, ``errors.png`` and, under the published protocol, ``consistency.png`` of
    :func:`run_dataset_cmd`, when matplotlib is there."""
    from radarslam.viz import have_matplotlib

    if have_matplotlib():
        from radarslam.viz.dataset import plot_dataset_errors, plot_dataset_map

        mp = res.final_map
        plot_dataset_map(out / "map.png", res.poses, mp.positions, mp.rma, ev, name=res.name,
                         dead_reckoning=dead_reckoning, diameters=diam,
                         extent_label=f"extent ({res.config.extent.estimator})")
        if pub is not None:
            err_t, err = res.times[pub["index"]], pub["errors_m"]
        else:
            err_t, err = ev["fix_t"], ev["errors_m"]
        plot_dataset_errors(out / "errors.png", err_t, err, nis, protocol=args.protocol,
                            name=f"{res.name} ({args.input})", scan_times=res.times)
        if cons is not None:
            from radarslam.viz.dataset import plot_consistency

            plot_consistency(out / "consistency.png", cons, name=f"{res.name} ({args.input})")
        if res.bias is not None:
            from radarslam.viz.dataset import plot_bias

            plot_bias(out / "bias.png", res.times, res.bias, res.bias_std, res.bias_names, res.bias_units,
                      name=f"{res.name} ({args.input})")


def _print_dataset_summary(name, metrics, res, ev, dr_ev, pub, nis, diam, dup, config) -> None:
    """The summary lines of :func:`run_dataset_cmd`."""
    print(f"radarslam run --dataset {name}: {metrics['scans']} scans, {metrics['landmarks_final']} landmarks, "
          f"GPS-aligned RMSE {ev['rmse_m']:.2f} m (max {ev['max_m']:.2f} m over {ev['n_fixes']} fixes; "
          f"{ev.get('n_gps_jumps_removed', 0)} GPS jumps left out; odometry alone {dr_ev['rmse_m']:.2f} m), "
          f"filter {res.seconds:.1f} s")
    if pub is not None:
        print(f"published protocol (start at the first GPS fix, no alignment): RMSE {pub['rmse_m']:.2f} m, "
              f"max {pub['max_m']:.2f} m over {pub['n_matched']} scans within 25 ms of a fix")
    print(f"NIS of {nis['n']} association updates: {100 * nis['inside']:.1f}% inside the 95% chi-square band "
          f"[{nis['band'][0]:.2f}, {nis['band'][1]:.2f}], mean {nis['mean']:.2f} (2 expected); "
          f"{metrics['filter_ms_per_scan']:.2f} ms per scan")
    if diam is not None and diam["n_matched"]:
        print(f"trunk diameters ({diam['estimator']}): {diam['n_matched']} matched trees, median |estimate - ACFR| "
              f"{diam['median_abs_diff_m']:.3f} m (median ratio {diam['median_ratio']:.2f}, "
              f"Spearman {diam['spearman']:.2f}; baseline {diam['baseline']}: {diam['baseline_median_abs_diff_m']:.3f} m, "
              f"Spearman {diam['baseline_spearman']:.2f})")
    print(f"duplicated trunks: {dup['n_pairs']} pairs of landmarks closer than a trunk diameter "
          f"({dup['diameter_m']:.2f} m, the median of ACFR's detections; merging removes pairs below "
          f"{config.landmarks.merge_distance_m:g} m); pairs within "
          + ", ".join(f"{r:g} m: {n}" for r, n in dup["pairs_within"].items()))

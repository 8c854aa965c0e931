"""The figure of a dataset run: estimated path and map over the GPS track.

Everything drawn is given: the estimate as arrays and the evaluation as the dict of
:func:`radarslam.metrics.alignment.error_against_fixes` (alignment, error and the GPS fixes with
their jump flags); nothing here evaluates anything.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from radarslam.core.errors import InputError

_GPS_EVAL_KEYS = ("R", "translation_m", "rmse_m", "span_xy", "span_jumps")


def _check_eval(name: str, ev) -> None:
    missing = [k for k in _GPS_EVAL_KEYS if not isinstance(ev, dict) or k not in ev]
    if missing:
        raise InputError(f"{name}: expected the dict of metrics.alignment.error_against_fixes with keys "
                         f"{list(_GPS_EVAL_KEYS)}, got {sorted(ev) if isinstance(ev, dict) else type(ev).__name__}")


def plot_dataset_map(path: str | Path, poses: np.ndarray, landmarks: np.ndarray, extents: np.ndarray,
                     gps_eval: dict, *, name: str = "dataset", title: str | None = None,
                     dead_reckoning: tuple[np.ndarray, dict] | None = None,
                     diameters: dict | None = None, extent_label: str = "RMA extent") -> None:
    """Save the estimated sensor path and landmarks (extent ellipses in red), rotated and translated
    into the GPS frame by the alignment of ``gps_eval``, over the GPS fixes (jumps grey).

    Parameters
    ----------
    path : str or Path
    poses : ndarray (K, 3)
        Estimated sensor poses.
    landmarks : ndarray (N, 2)
        Final landmark centroids.
    extents : ndarray (N, 2, 2)
        Their extent matrices (NaN where none; the run's extent estimator's, labelled by ``extent_label``).
    gps_eval : dict
        :func:`~radarslam.metrics.alignment.error_against_fixes` of ``poses``: ``R``,
        ``translation_m``, ``rmse_m``, ``span_xy``, ``span_jumps`` (and ``max_speed``).
    name : str
        Named in the default title.
    dead_reckoning : (ndarray (K, 3), dict), optional
        The odometry-only poses and their own ``error_against_fixes`` (aligned by its own fit).
    diameters : dict, optional
        :func:`~radarslam.runs.dataset.compare_tree_diameters`: adds a second panel of
        ``estimate_m`` against ``reference_m``.
    extent_label : str
        Legend entry of the drawn extents (the run's extent estimator).
    """
    _check_eval("gps_eval", gps_eval)
    if dead_reckoning is not None:
        _check_eval("dead_reckoning[1]", dead_reckoning[1])
    poses = np.asarray(poses, dtype=float)
    landmarks = np.asarray(landmarks, dtype=float).reshape(-1, 2)
    extents = np.asarray(extents, dtype=float).reshape(-1, 2, 2)
    if poses.ndim != 2 or poses.shape[1] < 2:
        raise InputError(f"poses: expected shape (K, 3), got {poses.shape}")
    if extents.shape[0] != landmarks.shape[0]:
        raise InputError(f"extents: expected {landmarks.shape[0]} matrices (one per landmark), got {extents.shape[0]}")

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from radarslam.viz.carpark import draw_extents

    R, t = gps_eval["R"], gps_eval["translation_m"]
    if diameters is not None and diameters.get("n_matched", 0):
        fig, (ax, ax2) = plt.subplots(1, 2, figsize=(15, 7.5), gridspec_kw={"width_ratios": [2, 1]})
    else:
        fig, ax = plt.subplots(figsize=(9, 8))
        ax2 = None
    gxy = np.asarray(gps_eval["span_xy"], dtype=float).reshape(-1, 2)
    jump = np.asarray(gps_eval["span_jumps"], dtype=bool)
    ax.plot(gxy[~jump, 0], gxy[~jump, 1], ".", color="tab:green", ms=2, label="GPS fixes")
    if jump.any():
        vmax = gps_eval.get("max_speed")
        ax.plot(gxy[jump, 0], gxy[jump, 1], "x", color="0.6", ms=3,
                label="GPS jumps" + (f" (> {vmax:g} m/s, left out)" if vmax is not None else ""))
    if dead_reckoning is not None:
        dp, dev = dead_reckoning
        q = np.asarray(dp)[:, :2] @ dev["R"].T + dev["translation_m"]
        ax.plot(q[:, 0], q[:, 1], "-", color="tab:orange", lw=0.6, alpha=0.8,
                label=f"odometry only (RMSE {dev['rmse_m']:.1f} m)")
    p = poses[:, :2] @ R.T + t
    ax.plot(p[:, 0], p[:, 1], "-", color="m", lw=0.8, label="estimated laser path")
    L = landmarks @ R.T + t
    ax.plot(L[:, 0], L[:, 1], "+", color="k", ms=3, label=f"landmarks ({len(L)})")
    draw_extents(ax, L, R @ extents @ R.T, color="red", label=extent_label, lw=0.6, n=24)
    ax.set_aspect("equal")
    ax.set_xlabel("east (m)")
    ax.set_ylabel("north (m)")
    ax.set_title(title or f"{name}: GPS-aligned RMSE {gps_eval['rmse_m']:.2f} m")
    ax.legend(loc="upper center", bbox_to_anchor=(0.5, -0.08), ncol=3, fontsize=8)  # below: never over the map
    ax.grid(alpha=0.3)
    if ax2 is not None:
        ref, est = diameters["reference_m"], diameters["estimate_m"]
        ax2.plot(ref, est, ".", ms=4, color="tab:red")
        hi = float(max(ref.max(), est.max())) * 1.05
        ax2.plot([0, hi], [0, hi], "k--", lw=0.8, label="equal")
        ax2.set_xlim(0, hi)
        ax2.set_ylim(0, hi)
        ax2.set_aspect("equal")
        ax2.set_xlabel("reference trunk diameter (m)")
        ax2.set_ylabel(f"{diameters.get('estimator', 'rma-efa')} trunk diameter (m)")
        ax2.set_title(f"{diameters['n_matched']} matched trees: median |diff| "
                      f"{diameters['median_abs_diff_m']:.3f} m, Spearman {diameters['spearman']:.2f}", fontsize=9)
        ax2.legend(loc="upper left", fontsize=8)
        ax2.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(path, dpi=130, bbox_inches="tight")  # keep the outside legend
    plt.close(fig)


def plot_dataset_errors(path: str | Path, error_t: np.ndarray, error_m: np.ndarray, nis: dict, *,
                        protocol: str = "aligned", name: str = "dataset", scan_times: np.ndarray | None = None) -> None:
    """Save the position error against the GPS over time (top) and the NIS of the associations
    against its chi-square band (bottom).

    Parameters
    ----------
    path : str or Path
    error_t, error_m : ndarray (n,)
        Time (s) and position error (m) at each evaluated fix (the published or the aligned protocol).
    nis : dict
        :func:`~radarslam.runs.dataset.nis_fraction` of the run: ``band``, ``inside``, ``mean``
        and the per-window series ``window_scan``, ``window_mean``, ``window_inside``.
    protocol : str
        Named in the title ("published" or "aligned").
    scan_times : ndarray (K,), optional
        Scan times, to put the NIS windows on the time axis (else the scan position).
    """
    error_t = np.asarray(error_t, dtype=float).ravel()
    error_m = np.asarray(error_m, dtype=float).ravel()
    if error_t.shape != error_m.shape:
        raise InputError(f"error_m: expected the shape of error_t {error_t.shape}, got {error_m.shape}")
    missing = [k for k in ("band", "inside", "mean", "window_scan", "window_mean", "window_inside") if k not in nis]
    if missing:
        raise InputError(f"nis: expected the dict of runs.dataset.nis_fraction, missing {missing}")

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, (ax, ax2) = plt.subplots(2, 1, figsize=(10, 7), sharex=scan_times is not None)
    rmse = float(np.sqrt(np.mean(error_m ** 2))) if error_m.size else float("nan")
    ax.plot(error_t, error_m, ".", ms=2, color="tab:blue")
    ax.set_ylabel("position error (m)")
    ax.set_title(f"{name}: error against the GPS ({protocol} protocol; RMSE {rmse:.2f} m over {error_m.size} fixes)")
    ax.grid(alpha=0.3)
    ws = np.asarray(nis["window_scan"], dtype=int)
    x = np.asarray(scan_times)[ws] if scan_times is not None and ws.size else ws
    lo, hi = nis["band"]
    ax2.plot(x, nis["window_mean"], "-", color="tab:red", lw=0.8, label="mean NIS per window (2 dof: expect 2)")
    ax2.axhline(2.0, color="k", ls="--", lw=0.8)
    ax2.set_ylabel("mean NIS")
    ax2.set_xlabel("time (s)" if scan_times is not None else "scan")
    ax3 = ax2.twinx()
    ax3.plot(x, nis["window_inside"], "-", color="tab:green", lw=0.8,
             label=f"fraction inside [{lo:.2f}, {hi:.2f}] (expect {nis.get('probability', 0.95):.2f})")
    ax3.set_ylim(0, 1.05)
    ax3.set_ylabel("fraction inside the band")
    ax2.set_title(f"NIS of the association updates: {100 * nis['inside']:.1f}% inside the band, mean {nis['mean']:.2f}",
                  fontsize=10)
    h1, l1 = ax2.get_legend_handles_labels()
    h2, l2 = ax3.get_legend_handles_labels()
    ax2.legend(h1 + h2, l1 + l2, loc="upper center", bbox_to_anchor=(0.5, -0.18), ncol=2, fontsize=8)
    ax2.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(path, dpi=120, bbox_inches="tight")  # keep the outside legend
    plt.close(fig)


def plot_bias(path: str | Path, t: np.ndarray, values: np.ndarray, stds: np.ndarray, names, units, *,
              name: str = "dataset") -> None:
    """Save one panel per odometry-bias state (docs/method.md c.11): its estimate over time ``t``
    (K,) with the +-2 sigma band; ``values``, ``stds`` ``(K, m)``. Angles (unit rad or rad/s) are
    drawn in degrees, a scale error in percent, a time offset (unit s) in milliseconds."""
    t = np.asarray(t, dtype=float).ravel()
    values, stds = np.asarray(values, dtype=float), np.asarray(stds, dtype=float)
    if values.shape != stds.shape or values.ndim != 2 or values.shape[0] != t.size or values.shape[1] != len(names):
        raise InputError(f"values, stds: expected two arrays of shape ({t.size}, {len(names)}), got "
                         f"{values.shape} and {stds.shape}")
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    m = values.shape[1]
    fig, axes = plt.subplots(m, 1, figsize=(10, 2.6 * m + 0.6), sharex=True, squeeze=False)
    for i, ax in enumerate(axes[:, 0]):
        unit = units[i]
        k, label = ((100.0, "%") if unit == "1" else (1e3, "ms") if unit == "s"       # a radar's clock (c.13.2)
                    else (np.degrees(1.0), unit.replace("rad", "deg")))
        v, s = k * values[:, i], k * stds[:, i]
        ax.fill_between(t, v - 2 * s, v + 2 * s, color="tab:blue", alpha=0.25, lw=0, label="+-2 sigma")
        ax.plot(t, v, "-", color="tab:blue", lw=0.9, label="estimate")
        ax.axhline(0.0, color="k", lw=0.6)
        ax.set_ylabel(f"{names[i]} ({label})")
        ax.set_title(f"{names[i]}: final {v[-1]:.3g} +- {2 * s[-1]:.2g} {label} (2 sigma)", fontsize=10)
        ax.grid(alpha=0.3)
    axes[0, 0].legend(loc="upper right", fontsize=8)
    axes[-1, 0].set_xlabel("time (s)")
    fig.suptitle(f"{name}: odometry-bias states")
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def plot_consistency(path: str | Path, cons: dict, *, name: str = "dataset") -> None:
    """Save the GPS error of the published protocol per axis (east, north) over time with the
    filter's +-2 sigma bound, alone and with the GPS's own std added (docs/method.md v.7).

    ``cons`` is :func:`~radarslam.runs.dataset.position_consistency`'s dict (``t``,
    ``error_m``, ``sigma_filter_m``, ``gps_std_m`` and the fractions)."""
    missing = [k for k in ("t", "error_m", "sigma_filter_m", "gps_std_m", "inside_east", "inside_north",
                           "inside_both", "inside_both_filter_only") if k not in cons]
    if missing:
        raise InputError(f"cons: expected the dict of runs.dataset.position_consistency, missing {missing}")
    t = np.asarray(cons["t"], dtype=float)
    e, sf = np.asarray(cons["error_m"], dtype=float), np.asarray(cons["sigma_filter_m"], dtype=float)
    if e.shape != (t.size, 2) or sf.shape != e.shape:
        raise InputError(f"cons: expected error_m and sigma_filter_m of shape ({t.size}, 2), got {e.shape}, {sf.shape}")
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    g = cons["gps_std_m"]
    fig, axes = plt.subplots(2, 1, figsize=(10, 6.5), sharex=True)
    for i, (ax, axis) in enumerate(zip(axes, ("east", "north"))):
        bound = 2.0 * np.sqrt(sf[:, i] ** 2 + 2.0 * g ** 2)
        ax.fill_between(t, -bound, bound, color="tab:orange", alpha=0.25, lw=0,
                        label=f"+-2 sigma, filter and GPS (std {g:g} m, this fix and the first)")
        ax.fill_between(t, -2 * sf[:, i], 2 * sf[:, i], color="tab:blue", alpha=0.35, lw=0, label="+-2 sigma, filter")
        ax.plot(t, e[:, i], ".", ms=2, color="k", label="estimate - GPS")
        ax.axhline(0.0, color="k", lw=0.5)
        ax.set_ylabel(f"{axis} error (m)")
        ax.set_title(f"{axis}: {100 * cons[f'inside_{axis}']:.1f}% inside the bound with the GPS std "
                     f"(95.4% expected)", fontsize=10)
        ax.grid(alpha=0.3)
    axes[0].legend(loc="upper left", fontsize=8)
    axes[1].set_xlabel("time (s)")
    fig.suptitle(f"{name}: error against the GPS and the filter's bound (published protocol); both axes inside: "
                 f"{100 * cons['inside_both']:.1f}% (filter alone {100 * cons['inside_both_filter_only']:.1f}%)",
                 fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)

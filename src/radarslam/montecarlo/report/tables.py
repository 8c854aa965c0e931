"""The report's tables as dicts: seed Table 1, seed Fig. 3 curves, APSIPA Table II, pose NEES (docs/method.md f).

Every function is pure computation on the dict of :func:`~radarslam.montecarlo.trials.load_results`
and covers every variant of ``res["variants"]`` in order (without that key: the two
:data:`~radarslam.config.variants.DEFAULT_VARIANTS`); the first variant is the *baseline* of
the relative changes.

Definitions (docs/method.md e, f.1; the statistics are [PROP], :mod:`radarslam.metrics.statistics`):

- *avg. RMSE* over trials: ``mean_k sqrt(mean_r e_{r,k}^2)`` (:func:`~radarslam.metrics.pose.avg_rmse`).
  Its 95% confidence interval is the percentile interval of the trial bootstrap. The relative
  change of a variant against the baseline uses a *paired* bootstrap: each resample takes the same
  trial indices for every variant (they ran on the same simulated data).
- *RMSE of the average GWD* at scan k: ``sqrt(mean over runs r with a value of gbar_{r,k}^2)``; the
  number of contributing runs is reported beside it.
- *Average NEES* at scan k: the mean over the N runs of the 3-dof pose NEES; a consistent filter
  keeps it inside the two-sided chi-square band of ``chi2(3 N) / N`` at most scans.
"""

from __future__ import annotations

import math
from collections.abc import Mapping

import numpy as np

from radarslam.core.errors import InputError
from radarslam.config.variants import PAPER_VARIANTS, Variant
from radarslam.metrics.extent import CONVENTIONS
from radarslam.metrics.pose import avg_rmse, chi2_band
from radarslam.metrics.statistics import bootstrap_avg_rmse, bootstrap_counts, percentile_interval, rmse_over_defined

#: Scans at which the note quotes the Fig. 3 curves.
GWD_KEY_STEPS = (5, 10, 20, 30, 40, 60, 80, 100, 120)
#: Summaries of the Fig. 3 curves run over k >= this scan (after the initial transient).
GWD_SETTLED_FROM = 10
#: Ground-truth conventions the report covers (Decision 7).
REPORT_CONVENTIONS = ("moment", "full")
ESTIMATORS = ("rma", "efa")
#: The two metrics of Table 1.
TABLE1_METRICS = ("position_avg_rmse_m", "heading_avg_rmse_deg")


# --------------------------------------------------------------------------------------------------
# input access


def variant_labels(res: dict) -> dict[str, str]:
    """``{name: label}`` of the variants of ``res``, in order (the first is the baseline).

    ``res["variants"]`` may hold :class:`~radarslam.config.variants.Variant` objects, dicts with
    ``name`` (and ``label``) or plain names; without the key, the default two.
    """
    if not isinstance(res, dict):
        raise InputError(f"res: expected a load_results dict, got {type(res).__name__}")
    vs = res.get("variants", PAPER_VARIANTS)
    out: dict[str, str] = {}
    for v in vs if isinstance(vs, (list, tuple)) else [vs]:
        if isinstance(v, Variant):
            name, label = v.name, v.label
        elif isinstance(v, Mapping) and isinstance(v.get("name"), str):
            name, label = v["name"], str(v.get("label", v["name"]))
        elif isinstance(v, str):
            name, label = v, v
        else:
            raise InputError(f"res['variants']: expected Variants, {{name, label}} dicts or names, got {v!r}")
        if name in out:
            raise InputError(f"res['variants']: expected unique names, got {name!r} twice")
        out[name] = label
    if not out:
        raise InputError("res['variants']: expected at least one variant, got none")
    return out


def _block(res: dict, name: str) -> dict:
    if not isinstance(res, dict) or name not in res or not isinstance(res[name], dict):
        raise InputError(f"res: expected a load_results dict with a {name!r} variant, got "
                         f"{sorted(res) if isinstance(res, dict) else type(res).__name__}")
    return res[name]


def _array(res: dict, name: str, key: str, ndim: int = 2) -> np.ndarray:
    d = _block(res, name)
    if key not in d:
        raise InputError(f"res[{name!r}]: expected an array {key!r}, got keys {sorted(d)}")
    a = np.asarray(d[key], dtype=float)
    if a.ndim != ndim or a.shape[0] < 1:
        raise InputError(f"res[{name!r}][{key!r}]: expected {ndim} dimensions with at least one run, "
                         f"got shape {a.shape}")
    return a


def _nan_stat(fn, x: np.ndarray) -> float:
    """``fn`` over the finite entries of ``x``; NaN (without a warning) when there are none."""
    x = np.asarray(x, dtype=float)
    x = x[np.isfinite(x)]
    return float(fn(x)) if x.size else math.nan


# --------------------------------------------------------------------------------------------------
# Table 1


def table1(res: dict, n_boot: int = 2000, rng_seed: int = 0, level: float = 0.95) -> dict:
    """Seed Table 1 for every variant, with bootstrap confidence intervals over trials.

    Parameters
    ----------
    res : dict
        From :func:`~radarslam.montecarlo.trials.load_results`; reads ``position_error_m`` and
        ``heading_error_rad`` ``(N, K)`` of every variant.
    n_boot : int
        Bootstrap resamples (>= 1).
    rng_seed : int
        Seed of the ``numpy.random.default_rng`` that draws the resamples (the report is reproducible).
    level : float
        Confidence level of the percentile intervals.

    Returns
    -------
    dict
        ``n_runs``, ``n_boot``, ``level``, ``rng_seed``, ``variants`` (names in order), ``labels``
        {name: label}, ``baseline`` (the first name), and per metric (``position_avg_rmse_m``,
        ``heading_avg_rmse_deg``) a dict with, per variant name, ``{"estimate", "ci"}`` and
        ``change_pct``: for every non-baseline variant, ``{"estimate", "ci"}`` of
        ``100 (variant / baseline - 1)``, the interval from the paired bootstrap.
    """
    if isinstance(n_boot, bool) or not isinstance(n_boot, (int, np.integer)) or n_boot < 1:
        raise InputError(f"n_boot: expected an integer >= 1, got {n_boot!r}")
    if not 0.0 < level < 1.0:
        raise InputError(f"level: expected a probability in (0, 1), got {level!r}")
    labels = variant_labels(res)
    names = list(labels)
    base = names[0]
    errs = {}
    for name in names:
        errs[name] = {"position_avg_rmse_m": _array(res, name, "position_error_m"),
                      "heading_avg_rmse_deg": np.degrees(_array(res, name, "heading_error_rad"))}
    shapes = {e.shape for d in errs.values() for e in d.values()}
    if len(shapes) != 1:
        raise InputError(f"res: expected equal (N, K) error arrays in every variant, got {sorted(shapes)}")
    n_runs = shapes.pop()[0]
    counts = bootstrap_counts(n_runs, int(n_boot), np.random.default_rng(rng_seed))  # shared: paired
    out: dict = {"n_runs": int(n_runs), "n_boot": int(n_boot), "level": level, "rng_seed": rng_seed,
                 "variants": names, "labels": labels, "baseline": base}
    for metric in TABLE1_METRICS:
        row: dict = {}
        boots = {}
        for name in names:
            e = errs[name][metric]
            boots[name] = bootstrap_avg_rmse(e, counts)
            row[name] = {"estimate": avg_rmse(e), "ci": percentile_interval(boots[name], level)}
        row["change_pct"] = {
            name: {"estimate": 100.0 * (row[name]["estimate"] / row[base]["estimate"] - 1.0),
                   "ci": percentile_interval(100.0 * (boots[name] / boots[base] - 1.0), level)}
            for name in names[1:]}
        out[metric] = row
    return out


# --------------------------------------------------------------------------------------------------
# Fig. 3


def _curve_summary(rmse: np.ndarray, n: np.ndarray) -> dict:
    K = rmse.shape[0]
    any_k = np.flatnonzero(n > 0)
    settled = rmse[GWD_SETTLED_FROM - 1:]
    fin = settled[np.isfinite(settled)]
    return {
        "rmse": rmse, "n_runs": n,
        "first_k": int(any_k[0] + 1) if any_k.size else None,
        "at": {k: float(rmse[k - 1]) for k in GWD_KEY_STEPS if k <= K},
        "final": float(rmse[-1]),
        "mean_k10": float(fin.mean()) if fin.size else math.nan,
        "std_k10": float(fin.std()) if fin.size >= 2 else math.nan,
        "range_k10": float(fin.max() - fin.min()) if fin.size >= 2 else math.nan,
    }


def gwd_curves(res: dict, convention: str) -> dict:
    """Seed Fig. 3: RMSE of the average GWD per scan for RMA and EFA, every variant.

    Parameters
    ----------
    res : dict
        Reads ``gwd_rma_<convention>`` and ``gwd_efa_<convention>`` ``(N, K)`` of every variant
        (the per-run mean GWD over matched landmarks with an initialised extent; NaN where none).
    convention : str
        Ground-truth ellipse convention (Decision 7): ``moment``, ``full``, ``inscribed``, ``enclosing``.

    Returns
    -------
    dict
        ``convention``, ``k`` (K,) = 1..K, and ``configs[name]`` for every variant, in order, with
        ``label``, ``frac_rma_below_efa_k10`` (fraction of the scans k >= 10 with both curves defined
        at which RMA < EFA; NaN if none) and, per estimator (``rma``, ``efa``): ``rmse`` (K,),
        ``n_runs`` (K,), ``first_k`` (first scan with any value, or None), ``at`` {k: value} for the
        key scans ``GWD_KEY_STEPS`` <= K, ``final`` (value at K), and over k >= 10 the ``mean_k10``,
        ``std_k10`` (population standard deviation) and ``range_k10`` (max - min) of the curve.
    """
    if convention not in CONVENTIONS:
        raise InputError(f"convention: expected one of {sorted(CONVENTIONS)}, got {convention!r}")
    out: dict = {"convention": convention, "configs": {}}
    K = None
    for name, label in variant_labels(res).items():
        c: dict = {"label": label}
        for est in ESTIMATORS:
            g = _array(res, name, f"gwd_{est}_{convention}")
            if K is not None and g.shape[1] != K:
                raise InputError(f"res[{name!r}][gwd_{est}_{convention!r}]: expected {K} scans, got {g.shape[1]}")
            K = g.shape[1]
            c[est] = _curve_summary(*rmse_over_defined(g))
        r, e = c["rma"]["rmse"][GWD_SETTLED_FROM - 1:], c["efa"]["rmse"][GWD_SETTLED_FROM - 1:]
        both = np.isfinite(r) & np.isfinite(e)
        c["frac_rma_below_efa_k10"] = float(np.mean(r[both] < e[both])) if both.any() else math.nan
        out["configs"][name] = c
    out["k"] = np.arange(1, K + 1)
    return out


# --------------------------------------------------------------------------------------------------
# APSIPA Table II


def landmark_table(res: dict) -> dict:
    """APSIPA Table II for each variant (docs/method.md f.4).

    Parameters
    ----------
    res : dict
        Reads per variant ``position_error_m``, ``heading_error_rad``, ``false_per_scan``,
        ``missed_per_scan``, ``n_landmarks`` ``(N, K)`` and ``scalars`` (``landmark_mae_m``,
        ``mean_inclusion_delay``, ``mean_removal_delay``).

    Returns
    -------
    dict
        ``configs[name]`` for every variant, in order, with ``label``; ``position_avg_rmse_m`` and
        ``heading_avg_rmse_deg`` (avg. RMSE over all trials); ``landmark_mae_m``,
        ``mean_inclusion_delay``, ``mean_removal_delay``: the mean over trials of each trial's value,
        skipping trials where it is undefined (NaN), with ``n_trials_<name>`` the number of trials
        that define it; ``mean_false`` / ``max_false`` and ``mean_missed`` / ``max_missed``: mean over
        trials and scans, and max over all, of the per-scan counts; ``mean_landmarks_final``: mean
        over trials of the number of landmarks at the last scan; ``n_trials``.
    """
    out: dict = {"configs": {}}
    for name, label in variant_labels(res).items():
        d = _block(res, name)
        sc = d.get("scalars")
        if not isinstance(sc, dict):
            raise InputError(f"res[{name!r}]: expected a 'scalars' dict, got {type(sc).__name__}")
        row: dict = {"label": label,
                     "position_avg_rmse_m": avg_rmse(_array(res, name, "position_error_m")),
                     "heading_avg_rmse_deg": avg_rmse(np.degrees(_array(res, name, "heading_error_rad")))}
        for key in ("landmark_mae_m", "mean_inclusion_delay", "mean_removal_delay"):
            if key not in sc:
                raise InputError(f"res[{name!r}]['scalars']: expected {key!r}, got {sorted(sc)}")
            v = np.asarray(sc[key], dtype=float)
            row[key] = _nan_stat(np.mean, v)
            row[f"n_trials_{key}"] = int(np.isfinite(v).sum())
        for short, key in (("false", "false_per_scan"), ("missed", "missed_per_scan")):
            a = _array(res, name, key)
            row[f"mean_{short}"] = float(a.mean())
            row[f"max_{short}"] = int(a.max())
        row["mean_landmarks_final"] = float(_array(res, name, "n_landmarks")[:, -1].mean())
        row["n_trials"] = int(_array(res, name, "position_error_m").shape[0])
        out["configs"][name] = row
    return out


# --------------------------------------------------------------------------------------------------
# NEES


def initial_error_of(res: dict, name: str) -> str:
    """How variant ``name`` of ``res`` drew its initial error (docs/method.md b.5): its overlay's
    ``filter.initial_error``, else the run configuration's; "fixed" when neither says."""
    base = getattr(getattr(res.get("config"), "filter", None), "initial_error", "fixed")
    for v in res.get("variants", ()):
        if isinstance(v, Variant) and v.name == name:
            return str(v.overlay.get("filter", {}).get("initial_error", base))
    return str(base)


def nees_summary(res: dict, prob: float = 0.95) -> dict:
    """Average 3-dof pose NEES per scan against the chi-square band of the average of N runs.

    Parameters
    ----------
    res : dict
        Reads ``nees`` ``(N, K)`` of every variant.
    prob : float
        Two-sided probability of the band.

    Returns
    -------
    dict
        ``prob``, ``dof`` (3), ``n_runs`` N, ``band`` [low, high] = ``chi2_band(3, N, prob)``, and
        ``configs[name]`` for every variant, in order, with ``label``, ``avg_nees`` (K,) (mean over
        runs), ``frac_inside``, ``frac_below``, ``frac_above`` (fractions of scans; a non-finite
        average counts as outside, in neither side) and ``time_avg`` (mean over scans of
        ``avg_nees``; 3 for a consistent filter).
    """
    if not 0.0 < prob < 1.0:
        raise InputError(f"prob: expected a probability in (0, 1), got {prob!r}")
    dof = 3
    n = None
    out: dict = {"prob": prob, "dof": dof, "configs": {}}
    for name, label in variant_labels(res).items():
        a = _array(res, name, "nees")
        if n is not None and a.shape[0] != n:
            raise InputError(f"res[{name!r}]['nees']: expected {n} runs, got {a.shape[0]}")
        n = a.shape[0]
        avg = a.mean(axis=0)
        lo, hi = chi2_band(dof, n, prob)
        fin = np.isfinite(avg)
        out["configs"][name] = {
            "label": label, "avg_nees": avg, "initial_error": initial_error_of(res, name),
            "frac_inside": float(np.mean(fin & (avg >= lo) & (avg <= hi))),
            "frac_below": float(np.mean(fin & (avg < lo))),
            "frac_above": float(np.mean(fin & (avg > hi))),
            "time_avg": _nan_stat(np.mean, avg),
        }
        out["band"] = [lo, hi]
    out["n_runs"] = int(n)
    return out


def nis_summary(res: dict, prob: float = 0.95) -> dict:
    """Normalised innovation squared of the EKF updates (2 dof each) per scan, pooled over trials.

    At scan k the mean NIS of the ``n_k`` updates of all trials is compared with the two-sided
    ``prob`` band of the mean of ``n_k`` chi-square(2) variables, ``chi2(2 n_k) / n_k``.

    Returns
    -------
    dict
        ``prob``, ``dof`` (2) and ``configs[name]`` for every variant whose trials stored the NIS:
        ``label``, ``mean_nis`` (K,) (NaN where no update), ``count`` (K,), ``band_low``/``band_high``
        (K,), ``frac_inside`` (fraction of scans with updates inside their band), ``overall`` (the
        mean NIS of every update of the run; 2 for a consistent filter).
    """
    from scipy.stats import chi2

    if not 0.0 < prob < 1.0:
        raise InputError(f"prob: expected a probability in (0, 1), got {prob!r}")
    dof, a = 2, (1.0 - prob) / 2.0
    out: dict = {"prob": prob, "dof": dof, "configs": {}}
    for name, label in variant_labels(res).items():
        block = _block(res, name)
        if "nis_sum" not in block or "nis_count" not in block:
            continue  # a run stored before the NIS was recorded
        total = np.asarray(block["nis_sum"], dtype=float).sum(axis=0)
        n = np.asarray(block["nis_count"], dtype=float).sum(axis=0)
        has = n > 0
        mean = np.full(n.shape, np.nan)
        mean[has] = total[has] / n[has]
        lo, hi = np.full(n.shape, np.nan), np.full(n.shape, np.nan)
        lo[has] = chi2.ppf(a, dof * n[has]) / n[has]
        hi[has] = chi2.ppf(1.0 - a, dof * n[has]) / n[has]
        inside = has & (mean >= lo) & (mean <= hi)
        out["configs"][name] = {
            "label": label, "mean_nis": mean, "count": n, "band_low": lo, "band_high": hi,
            "frac_inside": float(inside.sum() / has.sum()) if has.any() else float("nan"),
            "overall": float(total.sum() / n.sum()) if n.sum() > 0 else float("nan"),
        }
    return out


# --------------------------------------------------------------------------------------------------
# the paper's claims


def claims(t1: dict, gwd: dict[str, dict], paper_table1: dict | None = None) -> list[dict]:
    """Whether this run reproduces each of the seed paper's claims, with the numbers.

    Claims: (1) Table 1 direction: for every non-baseline variant, the paired 95% CI of the change
    against the baseline lies below zero, for position and for heading; (2) Table 1 size: the
    With-extent avg. RMSE is at most the paper's (1.09 m, 3.24 deg); (3) Fig. 3: the RMA GWD curve is
    below EFA's at every scan k >= 10 and (4) flatter (lower standard deviation over k >= 10), per
    variant and ground-truth convention.

    Returns
    -------
    list of dict
        ``claim``, ``variant``, ``holds`` (bool, or None when undefined) and ``evidence`` (a sentence).
    """
    from radarslam.montecarlo.report.paper import PAPER_TABLE1

    paper = paper_table1 or PAPER_TABLE1
    base = t1["baseline"]
    out: list[dict] = []
    units = {"position_avg_rmse_m": ("position", "m", 3), "heading_avg_rmse_deg": ("heading", "deg", 2)}
    for name in t1["variants"]:
        if name == base:
            continue
        for metric, (what, unit, nd) in units.items():
            ch = t1[metric]["change_pct"][name]
            lo, hi = ch["ci"]
            holds = bool(hi < 0) if math.isfinite(hi) else None
            out.append({"claim": f"Table 1 direction ({what})", "variant": name, "holds": holds,
                        "evidence": f"change {ch['estimate']:+.1f}% [{lo:+.1f}, {hi:+.1f}] against {t1['labels'][base]}"})
            if name == "ext":
                est, ref = t1[metric][name]["estimate"], paper[metric]["ext"]
                out.append({"claim": f"Table 1 size ({what} <= paper)", "variant": name, "holds": bool(est <= ref),
                            "evidence": f"{est:.{nd}f} {unit} against the paper's {ref:.{nd}f} {unit}"})
    for conv, curves in gwd.items():
        for name, c in curves["configs"].items():
            r, e = c["rma"], c["efa"]
            frac = c["frac_rma_below_efa_k10"]
            out.append({"claim": f"Fig. 3 RMA below EFA at every k >= {GWD_SETTLED_FROM} ({conv})", "variant": name,
                        "holds": None if not math.isfinite(frac) else bool(frac == 1.0),
                        "evidence": f"RMA below EFA at {100 * frac:.0f}% of the scans k >= {GWD_SETTLED_FROM}"
                        if math.isfinite(frac) else "no scan with both curves defined"})
            rs, es = r["std_k10"], e["std_k10"]
            defined = rs is not None and es is not None and math.isfinite(rs) and math.isfinite(es)
            out.append({"claim": f"Fig. 3 RMA flatter than EFA ({conv})", "variant": name,
                        "holds": bool(rs < es) if defined else None,
                        "evidence": f"std over k >= {GWD_SETTLED_FROM}: RMA {rs:.3f} m, EFA {es:.3f} m"
                        if defined else "undefined"})
    return out

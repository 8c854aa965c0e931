"""``write_report``: compute every table of a Monte Carlo directory and write ``DIR/report/``."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from radarslam.core.errors import InputError, RadarSlamError
from radarslam.montecarlo.trials import load_results
from radarslam.montecarlo.report.paper import PAPER_FIG3
from radarslam.montecarlo.report.render import (gwd_csv, nees_csv, nis_csv, report_markdown, table1_csv, table1_markdown,
                                                 table2_csv, table2_markdown, trial_ranges)
from radarslam.montecarlo.report.tables import (REPORT_CONVENTIONS, gwd_curves, landmark_table, nees_summary,
                                                 claims, nis_summary, table1,
                                                 variant_labels)
from radarslam.config.variants import Variant, variants_to_json

#: The variant that seed Fig. 2 shows (re-run from trial 1's seed) when the run has it.
FIG2_VARIANT = "ext"


def write_report(out_dir: str | Path, n_boot: int = 2000, *, rng_seed: int = 0, figures: bool = True) -> dict:
    """Compute the whole report of a Monte Carlo directory and write it to ``out_dir/report/``.

    Every table, CSV and figure covers every variant of the run, in the run's order.

    Parameters
    ----------
    out_dir : str or Path
        A directory written by :func:`~radarslam.montecarlo.trials.run_montecarlo`.
    n_boot : int
        Bootstrap resamples for the Table 1 intervals.
    rng_seed : int
        Seed of the bootstrap.
    figures : bool
        Draw the figures (when matplotlib is installed).

    Returns
    -------
    dict
        What went into ``report.json`` (``meta`` with the ``variants``, ``table1``, ``gwd`` per
        convention, ``landmarks``, ``nees``, ``fig2`` or None, ``files``: the names written under
        ``report/``). Fig. 2 re-runs trial 1 in variant ``"ext"`` if the run has it, else in its last variant.

    Raises
    ------
    InputError
        ``out_dir`` is missing, is not a Monte Carlo directory, holds no valid trial, or ``report/``
        cannot be written.
    """
    from radarslam.io.results import atomic_write_text, write_json

    root = Path(out_dir)
    if not root.is_dir():
        raise InputError(f"DIR: {root} is not a directory")
    try:
        res = load_results(root)
    except RadarSlamError:
        raise
    except (OSError, ValueError, KeyError, TypeError) as exc:  # unreadable manifest
        raise InputError(f"DIR: cannot read the Monte Carlo results in {root} ({type(exc).__name__}: {exc})") from None
    rdir = root / "report"
    try:
        rdir.mkdir(exist_ok=True)
    except OSError as exc:
        raise InputError(f"DIR: cannot create {rdir} ({exc.strerror})") from None

    labels = variant_labels(res)
    variants: tuple[Variant, ...] = tuple(res["variants"])
    trials = [int(t) for t in res["trials"]]
    K = int(res["true_poses"].shape[1])
    rep: dict = {"meta": {
        "dir": str(root), "seed": res["seed"], "profile": res["config"].profile, "n_trials": len(trials),
        "trials": trials, "trial_range": trial_ranges(trials),
        "n_steps": K, "corrupt": {int(t): why for t, why in res["corrupt"].items()},
        "trial_seconds": float(np.sum(res["seconds"])),
        "variants": variants_to_json(variants), "labels": labels, "baseline": next(iter(labels))}}
    rep["table1"] = table1(res, n_boot=n_boot, rng_seed=rng_seed)
    rep["gwd"] = {conv: gwd_curves(res, conv) for conv in REPORT_CONVENTIONS}
    rep["landmarks"] = landmark_table(res)
    rep["nees"] = nees_summary(res)
    rep["nis"] = nis_summary(res)
    rep["claims"] = claims(rep["table1"], rep["gwd"])
    rep["fig2"] = None

    files: list[str] = []

    def put(name: str, text: str) -> None:
        atomic_write_text(rdir / name, text)
        files.append(name)

    try:
        put("table1.md", table1_markdown(rep["table1"]) + "\n")
        put("table1.csv", table1_csv(rep["table1"]))
        put("table2_landmarks.md", table2_markdown(rep["landmarks"]) + "\n")
        put("table2_landmarks.csv", table2_csv(rep["landmarks"]))
        for conv in REPORT_CONVENTIONS:
            put(f"fig3_gwd_{conv}.csv", gwd_csv(rep["gwd"][conv]))
        put("nees.csv", nees_csv(rep["nees"]))
        if rep["nis"]["configs"]:
            put("nis.csv", nis_csv(rep["nis"]))

        from radarslam.viz import have_matplotlib

        if figures and have_matplotlib():
            files += _write_figures(rdir, rep, res, variants, trials)
        files += ["report.json", "report.md"]
        rep["files"] = files
        write_json(rdir / "report.json", rep)
        atomic_write_text(rdir / "report.md", report_markdown(rep))
    except OSError as exc:
        raise InputError(f"DIR: cannot write {rdir} ({exc.strerror or exc})") from None
    return rep


def _write_figures(rdir: Path, rep: dict, res: dict, variants: tuple[Variant, ...], trials: list[int]) -> list[str]:
    """The figures of :func:`write_report` (Fig. 3 per convention, NEES, NIS, Fig. 2 of trial 1
    with ``rep["fig2"]`` set); returns the names written."""
    from radarslam.viz import report as vr

    files: list[str] = []
    for conv in REPORT_CONVENTIONS:
        vr.plot_gwd_curves(rdir / f"fig3_gwd_{conv}.png", rep["gwd"][conv], conv,
                           reference=PAPER_FIG3 if conv == "full" else None)
        files.append(f"fig3_gwd_{conv}.png")
    vr.plot_nees(rdir / "nees.png", rep["nees"])
    files.append("nees.png")
    if rep["nis"]["configs"]:
        vr.plot_nis(rdir / "nis.png", rep["nis"])
        files.append("nis.png")
    if 1 in trials:
        from radarslam.montecarlo.trials import trial_seed
        from radarslam.simulation.trial import run_trial
        from radarslam.config.variants import apply_variant
        from radarslam.compiling.policy import Plan

        v = next((x for x in variants if x.name == FIG2_VARIANT), variants[-1])
        # the form of the engine that ran the stored trial (a first run's trials may have used its steps
        # form or the Python reference whole, compiling/warmup.py), so that the figure's run is that trial
        # bit for bit (the simulation's reference draws the same scans as its compiled form)
        stored_engine = res["engines"][v.name][trials.index(1)]
        engine = stored_engine if stored_engine in ("fused-steps", "fused-python") else "auto"
        reference = Plan("python", simulation_compiled=False, matching_compiled=False) if (
            stored_engine == "python") else None            # nothing compiled: the run the trial was
        tr = run_trial(apply_variant(res["config"], v), trial_seed(res["seed"], 1), engine=engine,
                       first_run=reference)
        vr.plot_fig2(rdir / "fig2_trial1.png", tr, label=v.label)
        stored = res[v.name]["poses"][trials.index(1)]
        rep["fig2"] = {"trial": 1, "variant": v.name, "label": v.label,
                       "matches_stored": bool(np.array_equal(tr.record.poses, stored))}
        files.append("fig2_trial1.png")
    return files

"""The figure of ``radarslam evaluate``: each scene's ratio to dead reckoning (docs/datasets.md "A
whole dataset: radarslam evaluate").

Everything drawn is given as arrays; nothing here evaluates anything.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from radarslam.core.errors import InputError


def plot_ratios(path: str | Path, names: list[str], position: np.ndarray, heading: np.ndarray, *,
                notes: list[str] | None = None, title: str = "ratio to dead reckoning per scene") -> None:
    """Save a bar chart: per scene the position and the heading RMSE's ratio to dead reckoning's
    (NaN: no bar, the scene's ``notes`` entry written in its place, default "no truth"), a line at 1
    (as good as dead reckoning; below 1, better).

    Parameters
    ----------
    names : list of str
        The scenes, in the order drawn.
    position, heading : ndarray (S,)
        The ratios (NaN where the scene has none).
    """
    position = np.asarray(position, dtype=float).reshape(-1)
    heading = np.asarray(heading, dtype=float).reshape(-1)
    if position.size != len(names) or heading.size != len(names) or (notes is not None and len(notes) != len(names)):
        raise InputError(f"position, heading, notes: expected {len(names)} of each (one per scene), got {position.size}, "
                         f"{heading.size} and {len(notes) if notes is not None else 'none'}")
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    x = np.arange(len(names))
    fig, ax = plt.subplots(figsize=(max(6.0, 0.6 * len(names) + 2.0), 4.5))
    w = 0.38
    ax.bar(x - w / 2, np.nan_to_num(position, nan=0.0), w, color="tab:blue", label="position RMSE")
    ax.bar(x + w / 2, np.nan_to_num(heading, nan=0.0), w, color="tab:orange", label="heading RMSE")
    ax.axhline(1.0, color="k", ls="--", lw=0.9, label="dead reckoning (ratio 1)")
    for i in np.flatnonzero(~np.isfinite(position) & ~np.isfinite(heading)):
        ax.text(x[i], 0.02, notes[i] if notes else "no truth", rotation=90, ha="center", va="bottom", fontsize=8, color="0.4")
    ax.set_xticks(x)
    ax.set_xticklabels(names, rotation=45 if len(names) > 4 else 0, ha="right" if len(names) > 4 else "center")
    ax.set_ylabel("RMSE / dead reckoning's RMSE")
    ax.set_title(title)
    ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=8)
    ax.grid(axis="y", alpha=0.3)
    fig.tight_layout()
    fig.savefig(path, dpi=120, bbox_inches="tight")  # keep the outside legend
    plt.close(fig)

"""Figures draw what they are given: the dataset map takes the GPS evaluation, it does not recompute it."""

from __future__ import annotations


import numpy as np
import pytest

from radarslam.core.errors import InputError
from radarslam.metrics.alignment import error_against_fixes, gps_speed_outliers

from conftest import require


def _track():
    """A 60 s drive at 2 m/s along a gentle arc, fixes at 1 Hz with two GPS jumps."""
    t = np.linspace(0.0, 60.0, 121)
    th = 0.01 * t
    poses = np.column_stack([20 * np.sin(th), 20 * (1 - np.cos(th)), th])
    fix_t = np.arange(-5.0, 66.0)
    s = np.clip(fix_t, 0, 60) * 0.01
    fix_xy = np.column_stack([20 * np.sin(s), 20 * (1 - np.cos(s))]) + [100.0, -50.0]
    fix_xy[30] += [40.0, 0.0]
    fix_xy[50] += [0.0, -25.0]
    return t, poses, fix_t, fix_xy


def test_error_against_fixes_carries_the_span_fixes_and_jumps():
    t, poses, fix_t, fix_xy = _track()
    ev = error_against_fixes(t, poses[:, :2], fix_t, fix_xy, max_speed=8.0)
    inside = (fix_t >= 0) & (fix_t <= 60)
    np.testing.assert_array_equal(ev["span_xy"], fix_xy[inside])
    np.testing.assert_array_equal(ev["span_jumps"], gps_speed_outliers(fix_t[inside], fix_xy[inside], 8.0))
    assert ev["span_jumps"].sum() == 2 and ev["n_gps_jumps_removed"] == 2 and ev["max_speed"] == 8.0
    assert ev["rmse_m"] < 1e-9  # a pure translation once the jumps are out
    no = error_against_fixes(t, poses[:, :2], fix_t, fix_xy)
    assert not no["span_jumps"].any() and no["max_speed"] is None


def _captured_figure(monkeypatch):
    """Record the axes of every figure saved."""
    require("matplotlib")
    import matplotlib

    matplotlib.use("Agg")
    from matplotlib.figure import Figure

    saved = []
    real = Figure.savefig

    def savefig(self, *a, **k):
        saved.append([[(ln.get_label(), np.asarray(ln.get_xydata())) for ln in ax.get_lines()] for ax in self.axes])
        return real(self, *a, **k)

    monkeypatch.setattr(Figure, "savefig", savefig)
    return saved


def test_dataset_map_draws_the_given_jumps_and_alignment(tmp_path, monkeypatch):
    from radarslam.viz.dataset import plot_dataset_map

    saved = _captured_figure(monkeypatch)
    t, poses, fix_t, fix_xy = _track()
    ev = error_against_fixes(t, poses[:, :2], fix_t, fix_xy, max_speed=8.0)
    # Flag a fix the speed test would keep: the figure must show the given flags, not its own.
    ev = dict(ev, span_jumps=ev["span_jumps"].copy())
    ev["span_jumps"][3] = True
    landmarks = np.array([[5.0, 1.0], [10.0, 2.0]])
    extents = np.array([np.diag([1.0, 0.25]), np.full((2, 2), np.nan)])
    plot_dataset_map(tmp_path / "m.png", poses, landmarks, extents, ev, name="arc")
    lines = dict(saved[0][0])
    np.testing.assert_array_equal(lines["GPS jumps (> 8 m/s, left out)"], ev["span_xy"][ev["span_jumps"]])
    np.testing.assert_array_equal(lines["GPS fixes"], ev["span_xy"][~ev["span_jumps"]])
    np.testing.assert_allclose(lines["estimated laser path"], poses[:, :2] @ ev["R"].T + ev["translation_m"])
    np.testing.assert_allclose(lines["landmarks (2)"], landmarks @ ev["R"].T + ev["translation_m"])
    ell = lines["RMA extent"]  # only the finite extent is drawn: a 1 x 0.5 ellipse about landmark 0
    c = landmarks[0] @ ev["R"].T + ev["translation_m"]
    q = ev["R"] @ np.diag([1.0, 4.0]) @ ev["R"].T  # X^-1 rotated into the GPS frame
    d = ell - c
    np.testing.assert_allclose(np.einsum("ni,ij,nj->n", d, q, d), 1.0, rtol=1e-9)
    assert (tmp_path / "m.png").stat().st_size > 0


def test_dataset_map_refuses_an_evaluation_without_the_fixes(tmp_path):
    from radarslam.viz.dataset import plot_dataset_map

    t, poses, fix_t, fix_xy = _track()
    ev = error_against_fixes(t, poses[:, :2], fix_t, fix_xy, max_speed=8.0)
    old = {k: v for k, v in ev.items() if not k.startswith("span_")}
    with pytest.raises(InputError, match="gps_eval: expected the dict of metrics.alignment.error_against_fixes"):
        plot_dataset_map(tmp_path / "m.png", poses, np.zeros((0, 2)), np.zeros((0, 2, 2)), old)
    with pytest.raises(InputError, match="extents: expected 1 matrices"):
        plot_dataset_map(tmp_path / "m.png", poses, np.zeros((1, 2)), np.zeros((0, 2, 2)), ev)

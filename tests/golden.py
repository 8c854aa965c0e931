"""Golden regression runs: fixed seeds, both backends, every value the redesign must not change.

``python tests/golden.py`` (re)writes ``tests/data/golden.npz``; do that only when a change of
results is intended and explained in the commit message. ``tests/test_golden.py`` recomputes every
run and asserts equality: to the last bit for the Python backend, to 1e-12 for numba (whose sums
run in another order).

Each run records, through the public API only (``EkfSlam.process``, ``ScanReport``,
``EkfSlam.snapshot``): the pose after every scan, the per-step position error (car park), the
landmark count after every scan, every association ``(scan, detection, landmark id)``, and the
final map's ids, centroids and RMA/EFA extents.
"""

from __future__ import annotations

import sys
from dataclasses import replace
from pathlib import Path

import numpy as np

GOLDEN = Path(__file__).resolve().parent / "data" / "golden.npz"
VICTORIA_PARK = Path(__file__).resolve().parents[2] / "shared" / "data" / "victoria_park"

#: (name, profile, seed, with extent) of the 120-scan car-park runs.
CARPARK_RUNS = [("apsipa-s1-noext", "apsipa", 1, False), ("apsipa-s1-ext", "apsipa", 1, True),
                ("apsipa-s2-ext", "apsipa", 2, True), ("reference-s3-ext", "reference", 3, True)]
BACKENDS = ("python", "numba")
VP_SCANS = 500


def _record(slam, events) -> dict[str, np.ndarray]:
    poses, nlm, assoc = [], [], []
    for ev in events:
        rep = slam.process(ev)
        if rep is None:
            continue
        poses.append(slam.pose)
        nlm.append(len(slam.snapshot().ids))
        for lid, dets in sorted(rep.associations.items()):
            for d in dets:
                assoc.append((rep.index, int(d), int(lid)))
    snap = slam.snapshot()
    return {"poses": np.array(poses), "n_landmarks": np.array(nlm), "associations": np.array(assoc, dtype=np.int64),
            "ids": snap.ids.astype(np.int64), "positions": snap.positions, "rma": snap.rma, "efa": snap.efa}


def carpark_run(profile: str, seed: int, extent: bool, backend: str) -> dict[str, np.ndarray]:
    from radarslam.config import profile_config
    from radarslam.simulation.scenario import generate_scenario
    from radarslam.slam import EkfSlam

    cfg = profile_config(profile)
    # Pinned to the configuration of the recording: later defaults (measurement-contour sifting)
    # must not change what these runs compare.
    cfg = replace(cfg, filter=replace(cfg.filter, backend=backend),
                  extent=replace(cfg.extent, use_in_slam=extent, sifting_mode="literal"))
    scenario = generate_scenario(cfg, np.random.default_rng(np.random.SeedSequence(seed)))
    out = _record(EkfSlam(cfg), scenario.events)
    out["position_error"] = np.hypot(*(out["poses"][:, :2] - scenario.truth.poses[:, :2]).T)
    return out


def victoria_park_run(backend: str, path: Path = VICTORIA_PARK) -> dict[str, np.ndarray]:
    from radarslam.config import profile_config
    from radarslam.io.datasets import get_dataset
    from radarslam.slam import EkfSlam

    cfg = profile_config("victoria-park")
    # Pinned to the recording's extent estimator and associator (the profile now reports
    # visible-arc circles and updates per landmark).
    cfg = replace(cfg, filter=replace(cfg.filter, backend=backend), extent=replace(cfg.extent, estimator="rma-efa"),
                  landmarks=replace(cfg.landmarks, associator="nearest-neighbour"))
    data = get_dataset("victoria-park")(path, n_scans=VP_SCANS)
    return _record(EkfSlam(cfg), data.events)


def all_runs(with_victoria_park: bool = True):
    """Yield ``(key, values)`` of every golden run."""
    for backend in BACKENDS:
        for name, profile, seed, extent in CARPARK_RUNS:
            yield f"{backend}/{name}", carpark_run(profile, seed, extent, backend)
        if with_victoria_park:
            yield f"{backend}/victoria-park-{VP_SCANS}", victoria_park_run(backend)


def main() -> int:
    flat = {}
    for key, values in all_runs(VICTORIA_PARK.is_dir()):
        for k, v in values.items():
            flat[f"{key}/{k}"] = v
        print(key, {k: v.shape for k, v in values.items()}, file=sys.stderr)
    GOLDEN.parent.mkdir(exist_ok=True)
    np.savez_compressed(GOLDEN, **flat)
    print(f"wrote {GOLDEN}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())

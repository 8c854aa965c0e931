"""Wall time of the filter alone in each way the package can run it, on the same events, warm (numba's
cache built; run once first if it is not): the fused engine compiled, its steps as Python over the
compiled kernels (``engine="fused-steps"``), all of it as Python (``"fused-python"``; slam/fused/engine.py
``form``), and the compiled engine fed one event at a time (``fused-events``: slam/fused/online.py;
docs/speed.md "The engine's three forms").
Workloads: one car-park trial (the apsipa profile, seed 1), the nuScenes scene-0061 and RadarScenes
sequence 105 under ``--profile automotive`` (their events as ``radarslam run --recording`` builds them).
Prints the median of ``--repeat`` runs (one run for a form that takes over 20 s).

    python benchmarks/bench_forms.py [--repeat 3] [--workloads carpark,nuscenes,radarscenes] [--forms ...]
"""

from __future__ import annotations

import argparse
import dataclasses
import statistics
import time
from pathlib import Path

import _common  # noqa: F401  (single-threaded BLAS)
import numpy as np

DATA = Path(__file__).resolve().parents[2] / "shared" / "data"
RECORDINGS = {"nuscenes": DATA / "nuscenes_radar" / "scene-0061", "radarscenes": DATA / "radarscenes" / "sequence_105"}
#: name: (drive's engine, filter.backend)
FORMS = {"fused": ("auto", "numba"), "fused-steps": ("fused-steps", "numba"), "fused-python": ("fused-python", "numba"),
         "fused-events": ("events", "numba")}


def carpark_events():
    from radarslam.config import profile_config
    from radarslam.simulation.scenario import generate_scenario

    cfg = profile_config()
    return cfg, generate_scenario(cfg, np.random.default_rng(1)).events


def recording_events(path: Path):
    """The configuration and events ``radarslam run --recording PATH --profile automotive`` gives its filter."""
    from radarslam.config import profile_config
    from radarslam.io.recording import read_recording
    from radarslam.runs.recording import run_recording

    run = run_recording(read_recording(path), profile_config("automotive"))
    return run.filter_config, run.events


def _events_one_by_one(cfg, events) -> None:
    """The compiled fused engine fed one event at a time (slam/fused/online.py ``Online``)."""
    from radarslam.slam.filter import EkfSlam
    from radarslam.slam.fused.online import Online

    online = Online(EkfSlam(cfg))
    for ev in events:
        online.process(ev)


def seconds(config, events, engine: str, backend: str, repeat: int) -> float:
    from radarslam.slam.driver import run_filter

    cfg = dataclasses.replace(config, filter=dataclasses.replace(config.filter, backend=backend))
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        if engine == "events":
            _events_one_by_one(cfg, events)
        else:
            run_filter(cfg, events, engine=engine)
        times.append(time.perf_counter() - t0)
        if times[-1] > 20.0:
            break
    return statistics.median(times)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--workloads", default="carpark,nuscenes,radarscenes")
    ap.add_argument("--forms", default=",".join(FORMS))
    args = ap.parse_args()
    forms = args.forms.split(",")
    print("| workload | scans | " + " | ".join(forms) + " |")
    print("|---|---|" + "---|" * len(forms))
    for name in args.workloads.split(","):
        config, events = carpark_events() if name == "carpark" else recording_events(RECORDINGS[name])
        scans = sum(1 for e in events if hasattr(e, "polar"))
        row = []
        for form in forms:
            engine, backend = FORMS[form]
            seconds(config, events, engine, backend, 1)               # warm: the first call compiles or loads
            row.append(f"{seconds(config, events, engine, backend, args.repeat):.3f} s")
        print(f"| {name} | {scans} | " + " | ".join(row) + " |", flush=True)


if __name__ == "__main__":
    main()

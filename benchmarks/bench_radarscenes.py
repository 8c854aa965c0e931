"""Wall time of a whole RadarScenes sequence through ``radarslam run`` (sequence 105, 1.07 M
detections of 4 radars over 121.8 s, target <= 12 s warm on one core, reading <= 3 s), by phase: reading
the CSV, the rig's ego-motion fit (docs/method.md c.12.4), the stream's preparation (the Doppler gate's
per-scan classification, c.10.4), the compiled filter, the output files (tables, figures) and the whole
command, imports included. Each run is a fresh process (``--child``), warm (numba's cache built: run once
before timing if it is not); prints the median (and min) of ``--repeat`` runs.

    python benchmarks/bench_radarscenes.py [/path/to/radarscenes/sequence_105] [--repeat 3] [--profile automotive]
"""

from __future__ import annotations

import argparse
import functools
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

DEFAULT = Path(__file__).resolve().parents[2] / "shared" / "data" / "radarscenes" / "sequence_105"
PHASES = ("read", "rig fit", "stream preparation", "filter", "tables", "figures", "outputs", "total")


def _timed(times: dict, name: str, f):
    @functools.wraps(f)
    def wrapper(*a, **k):
        t0 = time.perf_counter()
        try:
            return f(*a, **k)
        finally:
            times[name] = times.get(name, 0.0) + time.perf_counter() - t0
    return wrapper


def child(path: str, profile: str, out: str) -> dict:
    """One ``radarslam run`` in this process with each phase's function wrapped by a timer."""
    t0 = time.perf_counter()
    times: dict = {}
    import radarslam.runs.recording as rec_mod
    import radarslam.runs.recording_outputs as outs
    import radarslam.io.recording as io_rec
    import radarslam.slam.fused.plan as plan
    from radarslam.cli.main import main

    io_rec.read_recording = _timed(times, "read", io_rec.read_recording)
    outs.rig_velocity_of = _timed(times, "rig fit", outs.rig_velocity_of)
    plan._stream_arrays = _timed(times, "stream preparation", plan._stream_arrays)
    engine = plan.form                        # the fused engine's run of the family (slam/fused/plan.py)
    plan.form = lambda family, how="compiled", replace=(): _timed(times, "filter", engine(family, how, replace))
    outs.write_run_tables = _timed(times, "tables", outs.write_run_tables)
    outs.write_run_figures = _timed(times, "figures", outs.write_run_figures)
    rec_mod.write_recording_outputs = _timed(times, "outputs", rec_mod.write_recording_outputs)
    code = main(["run", "--recording", path, "--profile", profile, "--out", out])
    times["total"] = time.perf_counter() - t0        # from this process's first radarslam import
    times["exit"] = code
    return times


def main(argv=None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("path", nargs="?", default=str(DEFAULT))
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--profile", default="automotive")
    ap.add_argument("--keep", metavar="DIR", help="write each run's outputs to DIR/runN (default: a temporary directory)")
    ap.add_argument("--child", metavar="OUT", help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    if args.child:
        print("PHASES " + json.dumps(child(args.path, args.profile, args.child)))
        return {}
    if not (Path(args.path) / "detections.csv").is_file():
        print(f"skipped: no RadarScenes sequence at {args.path} (detections.csv)")
        return {}
    runs, walls = [], []
    env = dict(os.environ, OMP_NUM_THREADS="1", OPENBLAS_NUM_THREADS="1", MKL_NUM_THREADS="1")
    for i in range(args.repeat):
        with tempfile.TemporaryDirectory() as tmp:
            out_dir = Path(args.keep) / f"run{i + 1}" if args.keep else Path(tmp) / "out"
            t0 = time.perf_counter()
            p = subprocess.run([sys.executable, __file__, args.path, "--profile", args.profile, "--child",
                                str(out_dir)], capture_output=True, text=True, env=env)
            walls.append(time.perf_counter() - t0)
        line = [x for x in p.stdout.splitlines() if x.startswith("PHASES ")]
        if p.returncode or not line:
            print(p.stdout[-2000:], p.stderr[-2000:], sep="\n")
            raise SystemExit(f"run {i + 1} failed (exit {p.returncode})")
        runs.append(json.loads(line[0][7:]))
        print(f"run {i + 1}: " + ", ".join(f"{k} {runs[-1].get(k, 0.0):.2f}" for k in PHASES) + f", wall {walls[-1]:.2f}",
              flush=True)
    out = {k: statistics.median(r.get(k, 0.0) for r in runs) for k in PHASES}
    out["process wall"] = statistics.median(walls)
    print(f"{Path(args.path).name}, median of {args.repeat} runs (s; 'outputs' includes 'tables' and 'figures', "
          f"'total' from the first import, 'process wall' the interpreter's start included):")
    for k, v in out.items():
        print(f"  {k:20s} {v:7.2f}   (min {min(r.get(k, 0.0) for r in runs) if k in PHASES else min(walls):.2f})")
    return out


if __name__ == "__main__":
    main()

"""What compiling and running cost on this kind of machine (2 cores): the one set of measured
constants that every first-run decision reads (docs/speed.md "First run"), and the choices made
from them. Each constant says how it was measured."""

from __future__ import annotations


#: Costs on two cores of this kind of machine (``python benchmarks/bench_compile.py``, quiet machine:
#: 10.5 and 43.2 ms per variant and trial warm; 198.3 s and 34.3 s to compile on one core, the
#: simulation and the evaluation's ~20 s included, which the warm-up compiles beside on the second
#: core): seconds per variant and trial with a warm cache, fused engine and orchestrator; wall
#: seconds to fill a cold cache for each.
FUSED_S, STEPS_S = 0.0105, 0.0432


#: FUSED_COMPILE_S: the default family's engine alone since the fused steps compile once as functions
#: without entry points (``NUMBA_CACHE_DIR=$(mktemp -d) python benchmarks/compile_table.py
#: --cases carpark``: 130.4-146.5 s of CPU in four runs, mean 138).
FUSED_COMPILE_S, STEPS_COMPILE_S = 140.0, 20.0


#: A short Monte Carlo's warm-up (:func:`warm_up`), wall seconds on two cores: the default variants'
#: orchestrator kernels, the simulation and the evaluation, split over two processes
#: (:func:`_short_side`). Measured (``radarslam reproduce --trials 200`` from an empty cache, the
#: first line to the first trial): 27.2 s, and 26.3 / 26.4 s for the two processes alone.
STEPS_WARM_UP_S = 27.0


def first_run_engine(n_trials: int, n_variants: int, jobs: int) -> str:
    """The engine that ends a run of ``n_trials`` trials of ``n_variants`` variants on ``jobs``
    workers sooner from a cold cache: ``"auto"`` (compile the fused engine first) or
    ``"steps"`` (the engine's steps form over its compiled kernels)."""
    par = max(1, min(int(jobs), int(n_trials)))
    work = n_trials * n_variants / par
    fused = FUSED_COMPILE_S + work * FUSED_S
    steps = STEPS_WARM_UP_S + work * STEPS_S
    return "steps" if steps < fused else "auto"


#: Seconds per scan of a real recording, orchestrator and fused engine (``python
#: benchmarks/bench_dataset.py``: Victoria Park's raw laser, the slower mode, over the whole run;
#: the orchestrator's figure is its first 1,000 scans' 1.5 ms, doubled for the larger map later).
STEPS_SCAN_S, FUSED_SCAN_S = 0.003, 0.0011


def first_run_engine_scans(n_scans: int) -> str:
    """:func:`first_run_engine` for one run of ``n_scans`` scans of a recording, on one core:
    ``"steps"`` up to tens of thousands of scans with the constants above."""
    fused = FUSED_COMPILE_S + n_scans * FUSED_SCAN_S
    steps = STEPS_COMPILE_S + n_scans * STEPS_SCAN_S
    return "steps" if steps < fused else "auto"


#: The first run of ``run --dataset`` on a machine whose numba cache is empty (measured on this
#: 2-core machine, Victoria Park's raw laser, its 7,230 scans; load 1-3 from other jobs):
#: the Python reference (``filter.backend = "python"``) costs 16.8 ms a scan over the first 2,000
#: scans (13.5 s for 1,000, 33.6 s for 2,000; the whole park 629 s, as the map grows to hundreds of
#: landmarks), the orchestrator's kernels 26.2 s to compile in one process (7.6 s within the first
#: scan, 19.0 s within the second: the association, 10 s, and the extent step), of which the
#: extent and clustering steps compile in a second process beside (:func:`_compile_beside`) so that
#: this process pays STEPS_COMPILE_S; the run itself then costs warmup.STEPS_SCAN_S
#: a scan (25.5 s for the whole park warm, 3.5 ms a scan). The reference ends sooner up to about
#: 1,400 scans (``--scans``): a first short run starts at once.
PYTHON_SCAN_S = 0.0168


#: While numba compiles in the foreground, a line every this many seconds: under the 10 s of silence a first
#: run may keep (at 10 s the line came at 10.1 s, bench_first_run --from-docs).
HEARTBEAT_S = 8.0


#: A recorded stream through the Python reference, per detection and per scan of the stream (the
#: association looks at every landmark, and the landmarks grow with the drive, so a detection late
#: in a long drive costs more): measured from an empty cache on this 2-core machine, nuScenes
#: scene-0061 with the automotive profile (the Doppler gate through its reference too), 126,749
#: detections in 1,263 scans, the filter 20.6 s: 1.3e-7 (the issue's RadarScenes 105 cold run, 395 s for
#: 1,071,716 detections in 6,478 scans with the gate compiled, reads 5.7e-8).
PYTHON_DETECTION_SCAN_S = 1.3e-7

"""What compiling and running cost on this kind of machine (2 cores): the one set of measured
constants that every first-run decision reads (docs/speed.md "First run"), and the choices made
from them. Each constant says how it was measured."""

from __future__ import annotations


#: Seconds per variant and trial with a warm cache, the fused engine compiled and its steps form
#: (``python benchmarks/bench_compile.py``, quiet machine: 10.5 ms; the steps form's filter takes a
#: car-park trial in 0.047 s, ``benchmarks/bench_forms.py``, the figure below with the simulation and
#: the evaluation compiled).
FUSED_S, STEPS_S = 0.0105, 0.0432


#: CPU seconds to compile, one process: FUSED_COMPILE_S the default family's whole engine
#: (``NUMBA_CACHE_DIR=$(mktemp -d) python benchmarks/compile_table.py --cases carpark``: 130.4-146.5 s
#: in four runs, mean 138); STEPS_COMPILE_S the kernels the steps form calls on a car park of the
#: default family (an empty ``NUMBA_CACHE_DIR``, ``NUMBA_OPT=1``, ``run_filter(..., engine="fused-steps")``
#: on the No-extent variant: 49.8 s; the With-extent variant then 1.3 s more, the consistent one 11.5 s).
FUSED_COMPILE_S, STEPS_COMPILE_S = 140.0, 50.0


#: A short Monte Carlo's warm-up (:func:`warm_up`), wall seconds on two cores: the kernels the default
#: variants' steps form calls, the simulation and the evaluation, split over two processes
#: (:func:`_short_side`): the first two variants' kernels (51.1 s of CPU, above) and the evaluation in
#: this process, the consistent variant's (11.5 s) and the simulation (about 16 s) in the other.
STEPS_WARM_UP_S = 57.0


#: Seconds per variant and trial through the Python reference whole (the scan simulation, the engine's
#: Python form and the evaluation's matching, nothing compiled) from an empty numba cache, one core:
#: a car-park trial's three default variants in 2.56 s (median of 6; the first, with the imports, 2.73 s;
#: ``NUMBA_CACHE_DIR=$(mktemp -d) python benchmarks/bench_trial.py --reference --variants default
#: --trials 6``), about 0.85 s each. A Monte Carlo of up to about 70 variant-trials per worker
#: ends sooner so than waiting for the steps form's warm-up.
PYTHON_TRIAL_S = 0.85


def first_run_engine(n_trials: int, n_variants: int, jobs: int) -> str:
    """The engine that ends a run of ``n_trials`` trials of ``n_variants`` variants on ``jobs``
    workers soonest from a cold cache: ``"auto"`` (compile the fused engine first), ``"steps"``
    (the engine's steps form over its compiled kernels) or ``"python"`` (the reference whole, at
    once)."""
    par = max(1, min(int(jobs), int(n_trials)))
    work = n_trials * n_variants / par
    costs = {"auto": FUSED_COMPILE_S + work * FUSED_S, "steps": STEPS_WARM_UP_S + work * STEPS_S,
             "python": work * PYTHON_TRIAL_S}
    return min(costs, key=costs.get)


#: Seconds per scan of a real recording, the steps form and the fused engine compiled (the steps
#: form: RadarScenes 105's 6,470 scans in 18.7 s, ``python benchmarks/bench_forms.py``; the compiled
#: engine: Victoria Park's raw laser over the whole run, ``python benchmarks/bench_dataset.py``).
STEPS_SCAN_S, FUSED_SCAN_S = 0.003, 0.0011


def first_run_engine_scans(n_scans: int) -> str:
    """:func:`first_run_engine` for one run of ``n_scans`` scans of a recording, on one core:
    ``"steps"`` up to tens of thousands of scans with the constants above."""
    fused = FUSED_COMPILE_S + n_scans * FUSED_SCAN_S
    steps = STEPS_COMPILE_S + n_scans * STEPS_SCAN_S
    return "steps" if steps < fused else "auto"


#: A scan of ``run --dataset`` through the Python form on a machine whose numba cache is empty,
#: Victoria Park's raw laser over its first 2,000 scans: 16.8 ms measured for the per-event Python
#: reference this form replaces, times 1.3, the Python form's measured cost against it on nuScenes
#: scene-0061 and RadarScenes 105 (21.2 s against 16.6 s, 238 s against 180 s). The Python form ends
#: sooner than compiling the steps form's kernels up to about 2,600 scans: a first short run starts
#: at once.
PYTHON_SCAN_S = 0.022


#: While numba compiles in the foreground, a line every this many seconds: under the 10 s of silence a first
#: run may keep (at 10 s the line came at 10.1 s, bench_first_run --from-docs).
HEARTBEAT_S = 8.0


#: A recorded stream through the Python reference, per detection and per scan of the stream (the
#: association looks at every landmark, and the landmarks grow with the drive, so a detection late
#: in a long drive costs more): measured from an empty cache on this 2-core machine, nuScenes
#: scene-0061 with the automotive profile, 126,749 detections in 1,257 scans, the Python form's
#: filter 21.2 s (``benchmarks/bench_forms.py --forms fused-python``): 1.3e-7.
PYTHON_DETECTION_SCAN_S = 1.3e-7

"""Ahead-of-time compilation of the fused engine, measured (the alternative to numba's
compile at first use; docs/architecture.md "Where the compile time goes").

Builds the default family's engine (slam/fused/engine.py ``engine(DEFAULT)``) into a Python extension
with ``numba.pycc`` (pending deprecation in numba, still shipped), for the signature the car-park
runs call it with, then runs ``--trials`` car-park trials of the three default variants through both
the JIT engine and the built one and compares every output array. Prints the build's CPU seconds,
the import time of the built module, the two engines' seconds and how many runs were identical.

    NUMBA_CACHE_DIR=$(mktemp -d) python benchmarks/aot_probe.py     # from an empty cache: the whole cost
    python benchmarks/aot_probe.py --trials 20                       # callees cached: the engine's own part

The build compiles the engine's callees through their dispatchers (JIT, into numba's cache) and
links them into one module for the generic CPU of the platform, so from an empty cache it pays for
them too; with the cache warm it pays only for the engine's own body.
"""

from __future__ import annotations

import argparse
import copy
import importlib
import sys
import tempfile
import time
import warnings

import numpy as np


def _signature():
    """The argument types of the engine's call in a car-park run, without compiling it."""
    import numba

    from radarslam.config import profile_config
    from radarslam.slam.driver import run_filter
    from radarslam.compiling.warmup import _tiny_stream
    from radarslam.slam.fused import plan

    captured, real = {}, plan.form

    class _Captured(Exception):
        pass

    def spy(family, how="compiled", replace=()):
        def call(*args):
            captured["args"] = args
            raise _Captured
        return call

    plan.form = spy
    try:
        run_filter(profile_config(), _tiny_stream())
    except _Captured:
        pass
    finally:
        plan.form = real
    return tuple(numba.typeof(a) for a in captured["args"])


def build(out_dir: str) -> float:
    """Build ``fused_aot`` into ``out_dir``; its CPU seconds."""
    from numba.pycc import CC

    from radarslam.slam.fused.engine import DEFAULT, engine

    sig = _signature()
    cc = CC("fused_aot")
    cc.output_dir = out_dir
    cc.export("run_stream", sig)(engine(DEFAULT).py_func)
    t0 = time.process_time()
    cc.compile()
    return time.process_time() - t0


def _equal(a, b) -> bool:
    if isinstance(a, tuple):
        return len(a) == len(b) and all(_equal(x, y) for x, y in zip(a, b))
    if isinstance(a, np.ndarray):
        return a.shape == b.shape and np.array_equal(a, b, equal_nan=a.dtype.kind == "f")
    return a == b


def compare(module, n_trials: int) -> tuple[int, int, float, float]:
    """Trials ``1..n_trials`` of the three default variants through both engines: (runs, identical
    runs, JIT seconds, AOT seconds). Each scan's wall time (``seconds``) is left out of the comparison."""
    from radarslam.config import profile_config
    from radarslam.simulation.trial import run_trial
    from radarslam.config.variants import DEFAULT_VARIANTS, apply_variant
    from radarslam.slam.fused import plan

    runs, real = [], plan.form

    def both(family, how="compiled", replace=()):
        jit = real(family, how, replace)

        def call(*args):
            again = copy.deepcopy(args)            # the engine changes the filter's state it is given in place
            t0 = time.perf_counter()
            r = jit(*args)
            t1 = time.perf_counter()
            r2 = module.run_stream(*again)
            runs.append((t1 - t0, time.perf_counter() - t1, r, r2))
            return r
        return call

    plan.form = both
    try:
        for seed in range(1, n_trials + 1):
            for v in DEFAULT_VARIANTS:
                run_trial(apply_variant(profile_config(), v), seed)
    finally:
        plan.form = real
    same = 0
    for _, _, (st, n, (rec, maps), ar, c, out), (st2, n2, (rec2, maps2), ar2, c2, out2) in runs:
        rec, rec2 = rec._replace(seconds=rec.seconds * 0), rec2._replace(seconds=rec2.seconds * 0)
        same += _equal((st, n, rec, maps, ar, tuple(c), tuple(out)), (st2, n2, rec2, maps2, ar2, tuple(c2), tuple(out2)))
    return len(runs), same, sum(r[0] for r in runs), sum(r[1] for r in runs)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--trials", type=int, default=20, help="car-park trials compared (default 20)")
    args = ap.parse_args()
    warnings.simplefilter("ignore")                    # numba.pycc's pending deprecation, numba's cache notes
    with tempfile.TemporaryDirectory() as out:
        cpu = build(out)
        sys.path.insert(0, out)
        t0 = time.perf_counter()
        module = importlib.import_module("fused_aot")
        imported = time.perf_counter() - t0
        n, same, jit_s, aot_s = compare(module, args.trials)
    print(f"AOT build of the default family's engine: {cpu:.1f} s CPU; import {1e3 * imported:.1f} ms")
    print(f"{n} car-park runs ({args.trials} trials x 3 variants): {same} identical to the JIT engine's in every "
          f"array; engine seconds JIT {jit_s:.3f}, AOT {aot_s:.3f}")
    return 0 if same == n else 1


if __name__ == "__main__":
    raise SystemExit(main())

"""Where numba's compile time goes (docs/architecture.md "Where the compile time
goes"): compile what the README's commands run, case by case, in this process with a listener on
numba's compiler events; print each case's CPU seconds and compilations (what it adds to the cases
before it: callees compiled once are not compiled again), the families of the fused engine it
compiled (slam/fused/engine.py ``Family``), the total, and each function's compilations, type
signatures and inclusive CPU seconds (a callee's compile happens inside its first caller's).

    NUMBA_CACHE_DIR=$(mktemp -d) python benchmarks/compile_table.py [--cases carpark,simulation,...] [--top 25]

Cases (the README's commands): ``carpark``, the fused engine of ``radarslam reproduce``'s three
variants and ``run --seed 1`` (the warm-up's tiny stream); ``simulation``, the scan simulation and
the evaluation's matching those two commands compile beside it (a trial with the Python filter);
``automotive``, ``run --recording .../nuscenes_radar/scene-0061 --profile automotive`` (its first
60 scans); ``victoria-park``, ``run --dataset victoria-park`` (its first 300 scans). And beyond the
README, one family each: ``view`` (the partial view, a.12), ``jcbb`` (c.4.1), ``bias`` (the
odometry-bias states, c.11); ``steps``, the kernels of the engine's steps form that a
short first ``reproduce`` compiles and runs its trials with (``warmup._steps_trial``). Run it with an empty cache (else nothing compiles) on a quiet machine.
"""

from __future__ import annotations

import argparse
import collections
import time
from pathlib import Path

from numba.core import event

DATA = Path("/work/shared/data")
README_CASES = ("carpark", "simulation", "automotive", "victoria-park")
OTHER_CASES = {
    "view": {"extent": {"use_in_slam": True, "spread_model": "visible-faces"}},
    "jcbb": {"landmarks": {"associator": "jcbb"}},
    "bias": {"filter": {"odometry_bias": "states"}},
    "steps": None,            # what a short first reproduce compiles of the steps form's kernels (warmup._steps_trial)
}


class CompileTimes(event.Listener):
    """Each finished compilation as ``(function, signature, inclusive CPU s, self CPU s)``: self
    without the compilations that ran inside it (its callees')."""

    def __init__(self) -> None:
        self.open: list = []                     # the compilations under way, innermost last
        self.records: list[tuple[str, tuple[str, ...], float, float]] = []   # argument types one by one

    def on_start(self, ev) -> None:
        self.open.append([time.process_time(), 0.0])

    def on_end(self, ev) -> None:
        t0, inner = self.open.pop()
        dt = time.process_time() - t0
        if self.open:
            self.open[-1][1] += dt
        f = ev.data["dispatcher"].py_func
        self.records.append((f"{f.__module__}.{f.__qualname__}", tuple(str(a) for a in ev.data["args"]), dt, dt - inner))


def run_case(name: str) -> None:
    """Run case ``name`` (module docstring) as its command would on a machine whose code is ready."""
    from radarslam.config import profile_config
    from radarslam.config.variants import DEFAULT_VARIANTS, Variant
    from radarslam.compiling.warmup import compile_fused

    if name == "carpark":
        compile_fused(profile_config(), DEFAULT_VARIANTS)
    elif name == "simulation":
        from radarslam.config import to_dict
        from radarslam.compiling.warmup import _side

        _side(to_dict(profile_config()), {})
    elif name == "automotive":
        from radarslam.runs.recording import run_recording
        from radarslam.io.recording import read_recording

        rec = read_recording(DATA / "nuscenes_radar" / "scene-0061")
        run_recording(rec, profile_config("automotive"))
    elif name == "victoria-park":
        from radarslam.compiling import policy
        from radarslam.runs.dataset import run_dataset, victoria_park_options

        policy._fused_ready = lambda *families: True      # as on a machine whose code is ready
        cfg = profile_config("victoria-park")
        run_dataset("victoria-park", DATA / "victoria_park", cfg, n_scans=300, progress=False,
                    loader_options=victoria_park_options(cfg))
    elif name == "steps":
        from radarslam.compiling.warmup import _steps_trial

        _steps_trial(profile_config(), DEFAULT_VARIANTS)
    else:
        compile_fused(profile_config(), (Variant(name, name, OTHER_CASES[name]),))


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cases", default=",".join(README_CASES),
                    help=f"comma-separated, in order (default {','.join(README_CASES)}; also {','.join(OTHER_CASES)})")
    ap.add_argument("--top", type=int, default=25, help="rows to print (default 25)")
    args = ap.parse_args()
    listener = CompileTimes()
    event.register("numba:compile", listener)
    c0, w0 = time.process_time(), time.perf_counter()
    rows = []
    for name in args.cases.split(","):
        n0, c1 = len(listener.records), time.process_time()
        before = _compiled_families()
        run_case(name)
        fams = sorted(_compiled_families() - before)
        rows.append((name, time.process_time() - c1, len(listener.records) - n0, fams))
    cpu, wall = time.process_time() - c0, time.perf_counter() - w0
    print("| case | CPU s | compilations | engine families compiled (view, jcbb, bias) |\n|---|---|---|---|")
    for name, s, n, fams in rows:
        print(f"| {name} | {s:.1f} | {n} | {', '.join(str(tuple(int(b) for b in f)) for f in fams) or '-'} |")
    per: dict = collections.defaultdict(lambda: [0, 0.0, set(), 0.0])
    for name, sig, dt, own in listener.records:
        p = per[name]
        p[0] += 1
        p[1] = max(p[1], dt)
        p[2].add(sig)
        p[3] += own
    print(f"\n{cpu:.1f} s CPU ({wall:.1f} s wall, imports included), {len(listener.records)} compilations of "
          f"{len(per)} functions")
    print("| function | compilations | signatures | inclusive CPU s | self CPU s |\n|---|---|---|---|---|")
    for name, (n, longest, sigs, own) in sorted(per.items(), key=lambda kv: -kv[1][1])[:args.top]:
        print(f"| {name} | {n} | {len(sigs)} | {longest:.1f} | {own:.1f} |")
    _several_signatures(listener)
    for fam in sorted(_compiled_families()):
        _passes(fam)
    return 0


def _several_signatures(listener: CompileTimes) -> None:
    """Each function compiled for more than one signature, with the arguments in which they differ
    (a literal constant against its type, a layout, a read-only array: each is a whole compile)."""
    by_function: dict[str, list[tuple[str, ...]]] = {}
    for name, sig, _, _ in listener.records:
        by_function.setdefault(name, []).append(sig)
    rows = []
    for name, sigs in sorted(by_function.items()):
        distinct = list(dict.fromkeys(sigs))
        if len(distinct) > 1:
            diff = {i for a in distinct[1:] for i, (x, y) in enumerate(zip(distinct[0], a)) if x != y}
            what = "; ".join(f"arg {i}: " + " / ".join(sorted({sig[i][:60] for sig in distinct})) for i in sorted(diff))
            rows.append(f"| {name} | {len(distinct)} | {what or 'arity'} |")
    print(f"\nfunctions compiled for several signatures: {len(rows)}")
    if rows:
        print("| function | signatures | arguments that differ |\n|---|---|---|\n" + "\n".join(rows))


def _compiled_families() -> set:
    """The families of the fused engine compiled in this process so far."""
    from radarslam.slam.fused.engine import Family, engine

    every = (Family(v, j, b) for v in (False, True) for j in (False, True) for b in (False, True))
    return {f for f in every if engine(f).signatures}


def _passes(family, top: int = 6) -> None:
    """The compiler passes of ``family``'s engine that took longest (numba's pipeline times; type
    inference includes the callees compiled inside it, lowering includes LLVM's optimisation)."""
    from radarslam.slam.fused.engine import engine

    d = engine(family)
    times = d.get_metadata(d.signatures[0])["pipeline_times"]["nopython"]
    rows = sorted(((k.split("_", 1)[-1], v.init + v.run + v.finalize) for k, v in times.items()), key=lambda r: -r[1])
    print(f"engine {tuple(int(b) for b in family)} passes (wall s): "
          + ", ".join(f"{name} {t:.1f}" for name, t in rows[:top]))


if __name__ == "__main__":
    raise SystemExit(main())

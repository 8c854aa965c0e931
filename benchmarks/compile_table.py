"""Where numba's compile time goes (issue 34 item 2; docs/architecture.md "Where the compile time
goes"): compile the default variants' fused engine in this process with a listener on numba's
compiler events, and print each function's compilations, type signatures and inclusive seconds
(a callee's compile happens inside its first caller's).

    NUMBA_CACHE_DIR=$(mktemp -d) python benchmarks/compile_table.py [--top 25]

Run it with an empty cache (else nothing compiles) on a quiet machine.
"""

from __future__ import annotations

import argparse
import collections
import time

from numba.core import event


class CompileTimes(event.Listener):
    """Each finished compilation as ``(function, signature, seconds)``."""

    def __init__(self) -> None:
        self.open: dict = {}
        self.records: list[tuple[str, str, float]] = []

    @staticmethod
    def _key(ev) -> tuple:
        return id(ev.data["dispatcher"]), str(ev.data["args"])

    def on_start(self, ev) -> None:
        self.open[self._key(ev)] = time.perf_counter()

    def on_end(self, ev) -> None:
        t0 = self.open.pop(self._key(ev), None)
        if t0 is not None:
            f = ev.data["dispatcher"].py_func
            self.records.append((f"{f.__module__}.{f.__qualname__}", str(ev.data["args"]), time.perf_counter() - t0))


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--top", type=int, default=25, help="rows to print (default 25)")
    args = ap.parse_args()
    listener = CompileTimes()
    event.register("numba:compile", listener)
    t0 = time.perf_counter()
    from radarslam.config import profile_config
    from radarslam.experiments.single import run_filter
    from radarslam.experiments.variants import DEFAULT_VARIANTS, apply_variant
    from radarslam.experiments.warmup import _tiny_stream

    config = profile_config()
    for v in DEFAULT_VARIANTS:
        run_filter(apply_variant(config, v), _tiny_stream())
    total = time.perf_counter() - t0
    per: dict = collections.defaultdict(lambda: [0, 0.0, set()])
    for name, sig, dt in listener.records:
        p = per[name]
        p[0] += 1
        p[1] = max(p[1], dt)
        p[2].add(sig)
    print(f"{total:.1f} s wall, {len(listener.records)} compilations of {len(per)} functions")
    print("| function | compilations | signatures | inclusive s |\n|---|---|---|---|")
    for name, (n, longest, sigs) in sorted(per.items(), key=lambda kv: -kv[1][1])[:args.top]:
        print(f"| {name} | {n} | {len(sigs)} | {longest:.1f} |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

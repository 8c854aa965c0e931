"""What the default family's fused engine's compiled library holds (docs/architecture.md "What the
final module holds"): compile it (run it on the warm-up's tiny stream), then count the lines of
LLVM IR of each function defined in its final module, the callees numba linked in included, and
the calls to the reference-count helpers.

    NUMBA_CACHE_DIR=$(mktemp -d) python benchmarks/engine_ir.py [--top 15]

With a warm cache numba loads machine code and keeps no IR: run it with an empty cache (about
two minutes of CPU on a 2-core machine of this kind).
"""

from __future__ import annotations

import argparse
import re
import time


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--top", type=int, default=15, help="functions to list (default 15)")
    args = ap.parse_args()
    from radarslam.config import profile_config
    from radarslam.slam.driver import run_filter
    from radarslam.compiling.warmup import _tiny_stream
    from radarslam.slam import _fused

    t0 = time.process_time()
    run_filter(profile_config(), _tiny_stream())
    d = _fused.engine(_fused.DEFAULT)
    if d.stats.cache_hits:
        print("engine_ir: the engine was loaded from the cache and has no IR; use an empty NUMBA_CACHE_DIR")
        return 2
    ir = d.inspect_llvm(d.signatures[0])
    sizes, name, n = [], None, 0
    for line in ir.splitlines():
        if line.startswith("define"):
            name, n = re.search(r'@("[^"]+"|[\w.$]+)', line).group(1), 0
        n += 1
        if line == "}" and name is not None:
            sizes.append((n, name))
            name = None
    print(f"compile {time.process_time() - t0:.1f} s of CPU; {ir.count(chr(10))} lines of IR, {len(sizes)} functions "
          f"defined, {ir.count('@NRT_decref(')} NRT_decref and {ir.count('@NRT_incref(')} NRT_incref calls")
    print("| lines | function (mangled, cut) |\n|---|---|")
    for n, name in sorted(sizes, reverse=True)[:args.top]:
        print(f"| {n} | {name[:110]} |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

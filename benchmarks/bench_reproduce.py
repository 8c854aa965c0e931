"""Wall time of ``radarslam reproduce --trials N`` (Monte Carlo + report) in a fresh directory."""

import argparse
import subprocess
import sys
import tempfile
import time


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--trials", type=int, default=1000)
    ap.add_argument("--keep", metavar="DIR", help="write into DIR instead of a temporary directory")
    ap.add_argument("--backend", choices=("python", "numba"), default="numba",
                    help="filter.backend (default numba, the configuration's)")
    a = ap.parse_args()
    with tempfile.TemporaryDirectory() as d:
        out = a.keep or f"{d}/reproduce"
        t0 = time.perf_counter()
        subprocess.run([sys.executable, "-m", "radarslam", "reproduce", "--trials", str(a.trials), "--out", out,
                        "--quiet", "--backend", a.backend], check=True, stdout=subprocess.DEVNULL)
        wall = time.perf_counter() - t0
    print(f"radarslam reproduce --trials {a.trials} --backend {a.backend}: {wall:.1f} s wall ({wall / 60:.2f} min), "
          f"{a.trials / wall:.2f} trials/s including the report")


if __name__ == "__main__":
    main()

"""What a new user waits for: the first commands, cold and warm.

Each command runs as a new user runs it, ``python -m radarslam ...`` in a fresh output directory:

* cold: a new, empty numba cache (``NUMBA_CACHE_DIR``) per command, and
  ``RADARSLAM_BACKGROUND_COMPILE=0`` so that no background compile shares the CPU with the
  command being timed (a user's first run starts one; here it would only blur the figure);
* warm: the same cache once everything the command uses is compiled into it (the cold run's
  cache, filled by one full compile in a separate process first), the command run again.

For each run: the whole process's wall time (interpreter start included), the time to its first
line of output, and the longest silence between two lines (stdout and stderr read line by line,
each line time-stamped as it arrives; a progress bar on a pipe writes whole lines). The slowest of
``--repeat`` runs is kept for the silence and the median for the times.

    python benchmarks/bench_first_run.py                       # the four first commands, cold and warm
    python benchmarks/bench_first_run.py --commands seed,dataset --repeat 1 --cold-only
    python benchmarks/bench_first_run.py --from-docs          # every radarslam command README.md and usage.md show

``--from-docs`` takes the commands from the README's and docs/usage.md's own ``bash`` blocks (so a
new command cannot be missed; tests/test_readme.py checks the list against the files), in their
order, in one working directory beside a ``shared`` link (their ``../shared`` paths and the outputs
one command leaves for the next work as the docs say); warm is the same sequence again, in a new
directory, on the cache the cold runs filled.
"""

from __future__ import annotations

import argparse
import os
import re
import shlex
import shutil
import statistics
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
DATA = ROOT.parent / "shared" / "data"
COMMANDS = {
    "seed": ["run", "--seed", "1", "--no-plot"],
    "recording": ["run", "--recording", str(DATA / "nuscenes_radar" / "scene-0061")],
    "dataset": ["run", "--dataset", "victoria-park", str(DATA / "victoria_park")],
    "reproduce": ["reproduce", "--trials", "200"],
}
SHOWN = {
    "seed": "radarslam run --seed 1",
    "recording": "radarslam run --recording ../shared/data/nuscenes_radar/scene-0061",
    "dataset": "radarslam run --dataset victoria-park ../shared/data/victoria_park",
    "reproduce": "radarslam reproduce --trials 200",
}
DOCS = (ROOT / "README.md", ROOT / "docs" / "usage.md")


def doc_commands(paths=DOCS) -> list[str]:
    """Every ``radarslam ...`` command line of the ``bash`` blocks of ``paths``, in order, continuation
    lines joined and comments dropped (a command the docs show, as a user would type it)."""
    out = []
    for path in paths:
        block = False
        pending = ""
        for line in Path(path).read_text(encoding="utf-8").splitlines():
            if line.startswith("```"):
                block = line.strip() == "```bash" and not block
                pending = ""
                continue
            if not block:
                continue
            s = pending + line.strip()
            if s.endswith("\\"):
                pending = s[:-1].rstrip() + " "
                continue
            pending = ""
            s = re.sub(r"\s+#.*$", "", s).strip()
            out += [part.strip() for part in s.split("&&") if part.strip().startswith("radarslam ")]
    return out


#: A doc command with one of these is a template (a placeholder to fill in), not a command to time.
TEMPLATE = re.compile(r"\.\.\.|\[|\bDIR\b|HOST|FILE|\bP\b")


def runnable(cmds: list[str]) -> list[str]:
    """The doc commands that run as they are written: no placeholder (:data:`TEMPLATE`), and no input
    that only a template's ``--out`` would have made (``report runs/mc`` after ``montecarlo ... --out runs/mc``)."""
    out, made_by_templates = [], set()
    for c in cmds:
        if TEMPLATE.search(c):
            made_by_templates.update(re.findall(r"--out\s+(\S+)", c))
        elif not any(re.search(rf"(?<![\w/]){re.escape(o)}(?![\w/])", c) for o in made_by_templates):
            out.append(c)
    return out


#: What fills a cache with everything the commands use: the background compile a user's first run
#: leaves running (compiling/background.py: the fused engine for the Monte Carlo's variants, the
#: scan simulation, the evaluation's matching), here in the foreground; then each command once
#: more, so that its own kernels are cached too.
FILL = ("import json, tempfile\n"
        "from radarslam.config import profile_config, to_dict\n"
        "from radarslam.compiling import background_job\n"
        "from radarslam.config.variants import DEFAULT_VARIANTS, variants_to_json\n"
        "job = tempfile.NamedTemporaryFile('w', suffix='.json', delete=False)\n"
        "json.dump({'config': to_dict(profile_config()), 'variants': variants_to_json(DEFAULT_VARIANTS)}, job)\n"
        "job.close()\n"
        "background_job.main(job.name)\n")


def timed(argv: list[str], env: dict, cwd: Path) -> dict:
    """Run ``python -m radarslam argv``; wall time, first line and longest silence (s), exit code."""
    t0 = time.perf_counter()
    p = subprocess.Popen([sys.executable, "-u", "-m", "radarslam", *argv], cwd=cwd, env=env, stdout=subprocess.PIPE,
                         stderr=subprocess.PIPE, text=True, bufsize=1)
    stamps: list[float] = []
    lines: list[str] = []
    out: list[str] = []
    lock = threading.Lock()

    def read(stream) -> None:
        for line in stream:
            with lock:
                stamps.append(time.perf_counter() - t0)
                lines.append(line.rstrip("\n"))
                if stream is p.stdout:
                    out.append(line)

    readers = [threading.Thread(target=read, args=(s,), daemon=True) for s in (p.stdout, p.stderr)]
    for r in readers:
        r.start()
    rc = p.wait()
    for r in readers:
        r.join()
    wall = time.perf_counter() - t0
    ts = sorted(stamps)
    gaps = [b - a for a, b in zip([0.0, *ts], [*ts, wall])]
    return {"wall": wall, "first": ts[0] if ts else float("nan"), "silence": max(gaps), "rc": rc,
            "head": lines[0] if lines else "", "stdout": "".join(out)}


def fill_cache(env: dict, cwd: Path) -> None:
    """A full compile of the background's set into the cache (the warm state's precondition)."""
    subprocess.run([sys.executable, "-c", FILL], cwd=cwd, env=env, check=False, capture_output=True)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--commands", default=",".join(COMMANDS),
                    help=f"comma-separated subset of {', '.join(COMMANDS)} (default: all)")
    ap.add_argument("--repeat", type=int, default=1, help="runs per command and state (default 1)")
    ap.add_argument("--cold-only", action="store_true", help="skip the warm column (no full compile)")
    ap.add_argument("--warm-only", action="store_true", help="skip the cold column (the warm cache is still filled)")
    ap.add_argument("--from-docs", action="store_true", help="every radarslam command of README.md and docs/usage.md")
    args = ap.parse_args()
    if args.from_docs:
        return from_docs(args)
    names = [c.strip() for c in args.commands.split(",") if c.strip()]
    bad = [c for c in names if c not in COMMANDS]
    if bad:
        ap.error(f"--commands: expected names from {list(COMMANDS)}, got {bad}")
    print(f"# bench_first_run: {os.cpu_count()} cores, load {os.getloadavg()[0]:.2f}; cold = a new empty "
          "NUMBA_CACHE_DIR per command and RADARSLAM_BACKGROUND_COMPILE=0 (no background compile sharing the "
          "CPU); warm = the same cache after a full compile; times in s (median of --repeat, silence the longest)",
          flush=True)
    rows = []
    for name in names:
        cache = tempfile.mkdtemp(prefix="radarslam-numba-cache-")
        work = Path(tempfile.mkdtemp(prefix="radarslam-first-run-"))
        env = dict(os.environ, NUMBA_CACHE_DIR=cache, RADARSLAM_BACKGROUND_COMPILE="0")
        env.pop("CI", None)
        res: dict[str, list[dict]] = {"cold": [], "warm": []}
        try:
            states = ([] if args.warm_only else ["cold"]) + ([] if args.cold_only else ["warm"])
            for state in states:
                for i in range(args.repeat):
                    if state == "cold" and i:                    # every cold run from an empty cache
                        shutil.rmtree(cache, ignore_errors=True)
                        os.makedirs(cache)
                    if state == "warm" and i == 0:
                        fill_cache(env, work)
                        timed([*COMMANDS[name], "--out", str(work / "fill")], env, work)   # its own kernels
                    out = work / f"{state}{i}"
                    r = timed([*COMMANDS[name], "--out", str(out)], env, work)
                    res[state].append(r)
                    print(f"#   {SHOWN[name]} [{state} {i + 1}]: wall {r['wall']:.1f}, first line {r['first']:.1f}, "
                          f"longest silence {r['silence']:.1f}, exit {r['rc']}; first line: {r['head'][:160]}",
                          flush=True)
        finally:
            shutil.rmtree(cache, ignore_errors=True)
            shutil.rmtree(work, ignore_errors=True)
        rows.append((name, res))
    print("\n| command | cold: wall | cold: first line | cold: longest silence | warm: wall | warm: first line "
          "| warm: longest silence |")
    print("|---|---|---|---|---|---|---|")
    for name, res in rows:
        cells = []
        for state in ("cold", "warm"):
            rs = res[state]
            if not rs:
                cells += ["-"] * 3
                continue
            cells += [f"{statistics.median(r['wall'] for r in rs):.1f} s",
                      f"{statistics.median(r['first'] for r in rs):.1f} s",
                      f"{max(r['silence'] for r in rs):.1f} s"]
        print(f"| `{SHOWN[name]}` | " + " | ".join(cells) + " |")


def from_docs(args) -> None:
    """The docs' commands (:func:`doc_commands`), each cold on a new empty cache, then the whole
    sequence again warm on the cache they filled (module docstring)."""
    every = doc_commands()
    cmds = runnable(every)
    for c in every:
        if c not in cmds:
            print(f"# skipped, a template: {c}", flush=True)
    root = Path(tempfile.mkdtemp(prefix="radarslam-docs-"))
    (root / "shared").symlink_to(DATA.parent)
    cache = root / "cache"
    env = dict(os.environ, NUMBA_CACHE_DIR=str(cache), RADARSLAM_BACKGROUND_COMPILE="0")
    env.pop("CI", None)
    print(f"# bench_first_run --from-docs: {len(cmds)} commands, {os.cpu_count()} cores, load "
          f"{os.getloadavg()[0]:.2f}; cold = an empty NUMBA_CACHE_DIR before each command", flush=True)
    rows = []
    try:
        for state in ([] if args.warm_only else ["cold"]) + ([] if args.cold_only else ["warm"]):
            work = root / state
            work.mkdir()
            for c in cmds:
                if state == "cold":
                    shutil.rmtree(cache, ignore_errors=True)
                    cache.mkdir()
                argv, _, into = c.partition(" > ")
                r = timed(shlex.split(argv)[1:], env, work)
                if into:                                  # "radarslam dump-config > my.toml": the output kept
                    (work / into.strip()).write_text(r["stdout"])
                rows.append((c, state, r))
                print(f"#   {c} [{state}]: wall {r['wall']:.1f}, first line {r['first']:.1f}, longest silence "
                      f"{r['silence']:.1f}, exit {r['rc']}", flush=True)
    finally:
        shutil.rmtree(root, ignore_errors=True)
    print("\n| command | state | wall | first line | longest silence | exit |\n|---|---|---|---|---|---|")
    for c, state, r in rows:
        print(f"| `{c}` | {state} | {r['wall']:.1f} s | {r['first']:.1f} s | {r['silence']:.1f} s | {r['rc']} |")


if __name__ == "__main__":
    main()

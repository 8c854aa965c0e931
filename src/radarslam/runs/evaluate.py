"""``radarslam evaluate``: every scene of a dataset (or a list of recordings) run as ``radarslam run``
runs one, on local worker processes or a Dask cluster, resumably, into one table
(docs/datasets.md "A whole dataset: radarslam evaluate").

Layout of ``OUT``::

    evaluation.json          the command, its arguments, the configuration, the package version, the seeds
    scenes/<name>/           everything ``radarslam run`` writes for the scene (run.json last)
    rows/<name>.json         the scene's row, written atomically as the scene ends (ok or error)
    logs/<name>.txt          what the scene's run said (stdout and stderr; a failure's traceback)
    evaluation.csv, evaluation.md, summary.json, ratios.png     (:mod:`.evaluate_table`)

A scene whose ``scenes/<name>/run.json`` exists is finished and never run again; any other (never
started, cut short, or failed) is run at the next invocation. The scene is run by ``runner``, which
takes the ``radarslam run`` command line of the scene (the CLI passes the ``run`` command itself),
so that its files are those of ``radarslam run``.
"""

from __future__ import annotations

import hashlib
import json
import sys
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path

from radarslam import __version__
from radarslam.config import Config, to_dict, to_toml
from radarslam.core.errors import InputError, RadarSlamError
from radarslam.io.results import DirectoryLock, make_dir, write_json
from radarslam.runs.evaluate_table import BOOTSTRAP, error_row, row_from_outputs, write_table
from radarslam.runs.evaluate_scenes import Scene
from radarslam.runs.progress import Progress
from radarslam.runs.workers import run_dask, run_pool, sigterm_as_interrupt

#: How long a Dask client waits for its scheduler before the evaluation is refused (s).
CONNECT_TIMEOUT_S = 20.0
#: evaluation.json's format.
FORMAT = 1
#: Options of ``radarslam run`` left out of the identity: what the configuration already holds
#: (``--profile``, ``--config``), and what changes no result (the engine, the figures).
_NOT_IDENTITY = {"--profile": 1, "--config": 1, "--backend": 1, "--no-plot": 0}


def identity(config: Config, options: Sequence[str]) -> str:
    """SHA-256 of what makes two evaluations' scenes comparable: the configuration (but for its
    ``filter.backend``: every engine gives the same results, docs/architecture.md "Backends"), the other
    ``radarslam run`` options and the contents of a ``--calibration`` file."""
    opts, calibration, i = [], None, 0
    while i < len(options):
        o = options[i]
        if o in _NOT_IDENTITY:
            i += 1 + _NOT_IDENTITY[o]
            continue
        if o == "--calibration" and i + 1 < len(options):
            try:
                calibration = hashlib.sha256(Path(options[i + 1]).read_bytes()).hexdigest()
            except OSError:
                calibration = options[i + 1]
        opts.append(o)
        i += 1
    cfg = to_dict(config)
    cfg.get("filter", {}).pop("backend", None)
    text = json.dumps({"config": cfg, "options": opts, "calibration": calibration}, sort_keys=True,
                      separators=(",", ":"), default=str)
    return hashlib.sha256(text.encode()).hexdigest()


class EvaluationStore:
    """An evaluation's directory (the layout above), bound to one :func:`identity`."""

    def __init__(self, root: Path):
        self.root = Path(root)

    def scene_dir(self, name: str) -> Path:
        return self.root / "scenes" / name

    def row_path(self, name: str) -> Path:
        return self.root / "rows" / f"{name}.json"

    def log_path(self, name: str) -> Path:
        return self.root / "logs" / f"{name}.txt"

    def finished(self, name: str) -> bool:
        """Whether the scene's run wrote its last file, ``run.json``."""
        return (self.scene_dir(name) / "run.json").is_file()

    @classmethod
    def open(cls, root: str | Path, ident: str, record: dict) -> "EvaluationStore":
        """Create ``root`` or reopen it; refuse one that holds an evaluation of another identity.
        ``record`` (the command, its arguments, the configuration) is written to evaluation.json."""
        root = make_dir(root)
        path = root / "evaluation.json"
        if path.exists():
            try:
                held = json.loads(path.read_text(encoding="utf-8")).get("identity")
            except (OSError, ValueError, AttributeError) as exc:
                raise InputError(f"--out: {path} is not a readable evaluation.json ({exc})") from None
            if held != ident:
                raise InputError(f"--out: {root} holds an evaluation with another configuration or other run options "
                                 f"(see {path}); use another directory")
        for sub in ("scenes", "rows", "logs"):
            (root / sub).mkdir(exist_ok=True)
        write_json(path, {"format": FORMAT, "identity": ident, "version": __version__, **record})
        return cls(root)

    def lock(self) -> DirectoryLock:
        """An exclusive lock on the directory (a second evaluation on it is refused at once)."""
        return DirectoryLock(self.root)

    def save_row(self, row: dict) -> None:
        write_json(self.row_path(row["scene"]), row)

    def row(self, name: str) -> dict:
        """The row of a finished scene: the stored one, else (an evaluation ended between the scene's
        run.json and its row) read again from the scene's files and stored."""
        try:
            row = json.loads(self.row_path(name).read_text(encoding="utf-8"))
            if isinstance(row, dict) and row.get("scene") == name and row.get("status") == "ok":
                return row
        except (OSError, ValueError):
            pass
        row = read_row(name, self.scene_dir(name))
        self.save_row(row)
        return row


def read_row(name: str, scene_dir: Path) -> dict:
    """The row of the scene whose ``radarslam run`` outputs are in ``scene_dir``; an error row when
    its metrics.json or run.json cannot be read."""
    got = {}
    for file in ("metrics.json", "run.json"):
        path = scene_dir / file
        try:
            got[file] = json.loads(path.read_text(encoding="utf-8"))
        except (OSError, ValueError) as exc:
            return error_row(name, f"{path}: expected the run's {file}, got {type(exc).__name__}: {exc}")
    return row_from_outputs(name, got["metrics.json"], got["run.json"])


def _one_line(exc: BaseException) -> str:
    if isinstance(exc, RadarSlamError):
        return str(exc)
    if isinstance(exc, SystemExit):
        return f"radarslam run refused its arguments (exit {exc.code})"
    return f"{type(exc).__name__}: {exc}"


def scene_task(runner: Callable[[list[str]], object], argv: list[str], name: str, scene_dir: str,
               log_path: str) -> bytes:
    """One scene, in a worker: ``runner(argv)`` (``radarslam run`` of the scene into ``scene_dir``),
    what it says written to ``log_path``, and its row as JSON bytes; a failure is an error row with
    its one line (its traceback in the log), never an exception."""
    import contextlib
    import traceback

    t0 = time.perf_counter()
    with open(log_path, "w", encoding="utf-8") as fh:
        try:
            with contextlib.redirect_stdout(fh), contextlib.redirect_stderr(fh):
                runner(argv)
            row = read_row(name, Path(scene_dir)) if (Path(scene_dir) / "run.json").is_file() else \
                error_row(name, f"{scene_dir}: radarslam run ended without writing run.json", time.perf_counter() - t0)
        except KeyboardInterrupt:
            raise
        except BaseException as exc:          # argparse's SystemExit too: a row, never the end of the evaluation
            if isinstance(exc, RadarSlamError):   # a known error: its one line, as radarslam run says it
                print(f"radarslam run: error: {exc}", file=fh)
            else:
                traceback.print_exc(file=fh)
            row = error_row(name, _one_line(exc), time.perf_counter() - t0)
    return json.dumps(row).encode()


@dataclass
class Evaluation:
    """What :func:`evaluate` did: the rows in the scenes' order, how many scenes ran now and how many
    were finished before, the files of the table, and the wall time."""

    out: Path
    rows: list[dict]
    computed: int
    resumed: int
    files: list[str] = field(default_factory=list)
    seconds: float = 0.0

    @property
    def failed(self) -> list[str]:
        return [r["scene"] for r in self.rows if r["status"] != "ok"]


def evaluate(scenes: Sequence[Scene], out: str | Path, runner: Callable[[list[str]], object], *, config: Config,
             options: Sequence[str] = (), record: dict | None = None, workers: int = 1, scheduler: str | None = None,
             dask_local: int | None = None, progress: bool = True,
             log: Callable[[str], None] | None = None) -> Evaluation:
    """Run (or resume) every scene of ``scenes`` into ``out`` and write the table.

    Parameters
    ----------
    runner : callable
        Takes a ``radarslam run`` command line (without the program name) and runs it; a picklable
        top-level function (it runs in the workers).
    config : Config
        The effective configuration (evaluation.json, the identity).
    options : sequence of str
        The ``radarslam run`` options every scene is run with (``--profile``, ``--config``, ...).
    workers, scheduler, dask_local
        Local worker processes (1: in this process), or the Dask scheduler at ``tcp://HOST:PORT``,
        or a local Dask cluster of this many processes.
    """
    log = log or (lambda s: print(s, file=sys.stderr))
    if workers < 1:
        raise InputError(f"--workers: expected an integer >= 1, got {workers}")
    if scheduler is not None and dask_local is not None:
        raise InputError("--scheduler and --dask-local: give one or the other")
    if not scenes:
        raise InputError("--recordings/--scenes: expected at least one scene, got none")
    options = list(options)
    rec = {**(record or {}), "config": to_dict(config), "config_toml": to_toml(config), "run_options": options,
           "scenes": [s.name for s in scenes],
           "seeds": {"rig_fit": "runs/recording_outputs.py EGO_SEED (0): the rig fit's RANSAC draws",
                     "bootstrap": BOOTSTRAP}}
    store = EvaluationStore.open(out, identity(config, options), rec)
    with store.lock(), sigterm_as_interrupt():
        return _run_locked(store, list(scenes), runner, options, workers, scheduler, dask_local, progress, log,
                           rec.get("command", "radarslam evaluate"))


def _run_locked(store, scenes, runner, options, workers, scheduler, dask_local, progress, log, command):
    t0 = time.perf_counter()
    done = [s for s in scenes if store.finished(s.name)]
    todo = [s for s in scenes if not store.finished(s.name)]
    if done:
        log(f"evaluate: resuming {store.root}: {len(done)} of {len(scenes)} scenes already finished")
    rows = {s.name: store.row(s.name) for s in done}
    bar = Progress(len(scenes), len(done), unit="scenes", enabled=progress)

    def finish(name: str, data: bytes) -> None:
        row = json.loads(data)
        store.save_row(row)
        rows[name] = row
        bar.update()
        if row["status"] != "ok":
            log(f"evaluate: {name}: {row['status']} (log {store.log_path(name)})")

    calls = {s.name: (scene_task, (runner, ["run", *s.run_args, *options, "--out", str(store.scene_dir(s.name))],
                                   s.name, str(store.scene_dir(s.name)), str(store.log_path(s.name))))
             for s in todo}
    if scheduler is not None or dask_local is not None:
        if calls:
            # a task's name holds its --out (two evaluations on one scheduler never share a task); a local
            # cluster's workers may start the run's own helper process (compiling/stream_plan.py)
            where = hashlib.sha256(str(store.root.resolve()).encode()).hexdigest()[:12]
            run_dask({n: (fn, args, f"radarslam-scene-{where}-{n}") for n, (fn, args) in calls.items()}, finish,
                     scheduler, dask_local, timeout_s=CONNECT_TIMEOUT_S, worker_daemon=False)
    elif min(workers, len(calls)) == 1:
        for name, (fn, args) in calls.items():
            finish(name, fn(*args))
    elif calls:
        run_pool(calls, finish, min(workers, len(calls)), unit="scene")
    ordered = [rows[s.name] for s in scenes]
    files = write_table(store.root, ordered, command)
    return Evaluation(store.root, ordered, len(todo), len(done), files, time.perf_counter() - t0)

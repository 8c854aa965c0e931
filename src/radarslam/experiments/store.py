"""The Monte Carlo result directory: a manifest and one checksummed file per finished trial.

Layout of ``DIR``::

    manifest.json            seed, configuration (and its hash), package version, format
    trials/trial_000001.npz  trial 1 (spawn index 0), written atomically when it finishes
    ...

A trial file is an uncompressed ``.npz`` whose ``__meta__`` entry is UTF-8 JSON holding the trial
number, its seed stream and a SHA-256 over every other array (name, dtype, shape, bytes). A file
that fails to open, lacks an entry, or whose checksum or identity does not match is *corrupt*: it
is reported and recomputed, never read.
"""

from __future__ import annotations

import hashlib
import io
import json
import tomllib
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from radarslam import __version__
from radarslam.config import Config, from_dict, to_dict, to_toml
from radarslam.core.errors import InputError, RadarSlamError
from radarslam.io.results import atomic_write_bytes, atomic_write_text, make_dir, to_jsonable, write_json

FORMAT = 1


class CorruptTrial(RadarSlamError):
    """A trial file that cannot be trusted."""


def config_hash(config: Config) -> str:
    """SHA-256 of the canonical JSON of the configuration."""
    # json writes inf as Infinity, so an infinite threshold and a missing one never collide.
    text = json.dumps(to_dict(config), sort_keys=True, separators=(",", ":"))
    return hashlib.sha256(text.encode()).hexdigest()


def _digest(arrays: dict[str, np.ndarray]) -> str:
    h = hashlib.sha256()
    for name in sorted(arrays):
        a = np.ascontiguousarray(arrays[name])
        h.update(name.encode())
        h.update(a.dtype.str.encode())
        h.update(repr(a.shape).encode())
        h.update(a.tobytes())
    return h.hexdigest()


def encode_trial(arrays: dict[str, np.ndarray], meta: dict) -> bytes:
    """Serialise one trial (arrays + meta with checksum) to ``.npz`` bytes."""
    meta = dict(meta, sha256=_digest(arrays), format=FORMAT)
    buf = io.BytesIO()
    np.savez(buf, __meta__=np.frombuffer(json.dumps(to_jsonable(meta)).encode(), dtype=np.uint8), **arrays)
    return buf.getvalue()


def decode_trial(data: bytes | Path, expect_trial: int | None = None) -> tuple[dict[str, np.ndarray], dict]:
    """Inverse of :func:`encode_trial`; raises :class:`CorruptTrial` on any inconsistency."""
    try:
        # Read the bytes first: np.load on a path leaks its handle when the zip is damaged.
        raw = data if isinstance(data, bytes) else Path(data).read_bytes()
        with np.load(io.BytesIO(raw), allow_pickle=False) as z:
            arrays = {k: z[k] for k in z.files}
        meta = json.loads(arrays.pop("__meta__").tobytes().decode())
    except Exception as exc:  # zipfile, CRC, JSON, missing key: all mean "do not trust"
        raise CorruptTrial(f"unreadable ({type(exc).__name__}: {exc})") from None
    if meta.get("format") != FORMAT or _digest(arrays) != meta.get("sha256"):
        raise CorruptTrial("checksum mismatch")
    if expect_trial is not None and meta.get("trial") != expect_trial:
        raise CorruptTrial(f"holds trial {meta.get('trial')}, expected {expect_trial}")
    return arrays, meta


@dataclass
class TrialStore:
    """A Monte Carlo result directory bound to one configuration and seed."""

    root: Path
    config: Config
    seed: int

    @property
    def trials_dir(self) -> Path:
        return self.root / "trials"

    def path(self, trial: int) -> Path:
        """File of trial number ``trial`` (1-based)."""
        return self.trials_dir / f"trial_{trial:06d}.npz"

    @classmethod
    def open(cls, root: str | Path, config: Config, seed: int) -> "TrialStore":
        """Create ``root`` or reopen it; refuse a directory made with another config or seed."""
        root = Path(root)
        make_dir(root)
        man = root / "manifest.json"
        if man.exists():
            try:
                m = json.loads(man.read_text())
            except (OSError, json.JSONDecodeError) as exc:
                raise InputError(f"--out: {man} is not a readable manifest ({exc})") from None
            if m.get("seed") != seed:
                raise InputError(f"--out: {root} holds a Monte Carlo with seed {m.get('seed')}, not {seed}; "
                                 "use another directory")
            if m.get("config_hash") != config_hash(config):
                raise InputError(f"--out: {root} holds a Monte Carlo with a different configuration "
                                 f"(see {man}); use another directory")
        else:
            write_json(man, {"format": FORMAT, "seed": seed, "config_hash": config_hash(config),
                             "version": __version__, "config_toml": to_toml(config), "config": to_dict(config)})
            atomic_write_text(root / "config.toml", to_toml(config))
        (root / "trials").mkdir(exist_ok=True)
        return cls(root, config, seed)

    @classmethod
    def read(cls, root: str | Path) -> "TrialStore":
        """Open an existing directory for reading (the report)."""
        root = Path(root)
        man = root / "manifest.json"
        if not man.is_file():
            raise InputError(f"DIR: {root} has no manifest.json; is it a montecarlo output directory?")
        m = json.loads(man.read_text())
        return cls(root, from_dict(tomllib.loads(m["config_toml"])), int(m["seed"]))

    def save(self, trial: int, data: bytes) -> None:
        atomic_write_bytes(self.path(trial), data)

    def load(self, trial: int) -> tuple[dict[str, np.ndarray], dict]:
        return decode_trial(self.path(trial), expect_trial=trial)

    def inventory(self, n_trials: int) -> tuple[list[int], dict[int, str]]:
        """Trials 1..n that are stored and valid, and the corrupt ones with the reason."""
        good, bad = [], {}
        for t in range(1, n_trials + 1):
            p = self.path(t)
            if not p.exists():
                continue
            try:
                self.load(t)
            except CorruptTrial as exc:
                bad[t] = str(exc)
            else:
                good.append(t)
        return good, bad

    def stored(self) -> list[int]:
        """Numbers of all trial files present (valid or not)."""
        return sorted(int(p.stem.split("_")[1]) for p in self.trials_dir.glob("trial_*.npz"))

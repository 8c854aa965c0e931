"""The Monte Carlo result directory: a manifest and one checksummed file per finished trial.

Layout of ``DIR``::

    manifest.json            seed, configuration, variants (the hash covers both), package version, format
    trials/trial_000001.npz  trial 1 (spawn index 0), written atomically when it finishes
    ...

A trial file is an uncompressed ``.npz`` whose ``__meta__`` entry is UTF-8 JSON holding the trial
number, its seed stream, the names of the variants it holds (in order) and a SHA-256 over every
other array (name, dtype, shape, bytes). Each variant's arrays are stored as ``"{variant}/{key}"``.
A file that fails to open, lacks an entry, whose checksum or identity does not match, or that does
not hold every variant of the manifest is *corrupt*: it is reported and recomputed, never read.
"""

from __future__ import annotations

import hashlib
import io
import json
import re
import struct
import tomllib
import zipfile
import zlib
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from radarslam import __version__
from radarslam.config import Config, SensorConfig, from_dict, to_dict, to_toml
from radarslam.core.errors import InputError, RadarSlamError
from radarslam.config.variants import (DEFAULT_VARIANTS, PAPER_VARIANTS, Variant, check_variants, variant_hash_data, variants_from_json, variants_to_json)
from radarslam.io.results import (DirectoryLock, atomic_write_bytes, atomic_write_text, make_dir,  # noqa: F401
                                  to_jsonable, write_json)

FORMAT = 1


class CorruptTrial(RadarSlamError):
    """A trial file that cannot be trusted."""


class ForeignTrial(InputError):
    """A sound trial file of another run (seed, configuration or variants): never used, never deleted."""


#: Trial file names; anything else in ``trials/`` is a stray file (ignored with a warning).
TRIAL_NAME = re.compile(r"trial_(\d{6})\.npz")


#: Arrays every variant of a trial file holds (``"{variant}/{key}"``).
VARIANT_KEYS = ("poses", "n_landmarks", "scalars")


#: Filter keys added after runs were stored, with their defaults: left out of the hash at the default
#: so the identity of older directories holds (docs/method.md b.5, c.2.1).
LATER_FILTER_KEYS = {"initial_error": "fixed", "jacobians": "standard"}


def config_hash(config: Config, variants: tuple[Variant, ...] | None = None) -> str:
    """SHA-256 of the canonical JSON of the configuration and the variants (names, labels, overlays).

    ``variants=None`` gives the hash of the configuration alone, the identity of directories written
    before variants existed (they ran :data:`~.variants.PAPER_VARIANTS`).
    """
    # json writes inf as Infinity, so an infinite threshold and a missing one never collide.
    cfg = to_dict(config)
    if cfg.get("sensor") == to_dict(SensorConfig()):
        del cfg["sensor"]   # the recordings' section (added later): at its default, the hash of older runs holds
    for key, default in LATER_FILTER_KEYS.items():   # filter keys added later: at their default, the same
        if cfg.get("filter", {}).get(key) == default:
            del cfg["filter"][key]
    data = cfg if variants is None else {"config": cfg, "variants": variant_hash_data(variants)}
    text = json.dumps(data, sort_keys=True, separators=(",", ":"))
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


#: The header of an ``.npy`` member as ``np.savez`` writes it (format 1.0, NEP 1): a dict literal
#: with the dtype, the order and the shape. Anything else is read by ``np.load``.
_NPY_HEADER = re.compile(rb"\{'descr': '([<>|][a-zA-Z]\d+)', 'fortran_order': False, 'shape': \(([0-9, ]*)\), \}\s*")
_LOCAL_HEADER = struct.Struct("<4s2B4HL2L2H")          # a ZIP local file header (APPNOTE 4.3.7)


def _read_npz_stored(raw: bytes) -> dict[str, np.ndarray] | None:
    """The arrays of an uncompressed ``.npz`` (what :func:`encode_trial` writes) read straight
    from the bytes: each member located through the ZIP directory, its CRC-32 checked, its
    ``.npy`` header parsed by :data:`_NPY_HEADER`. About 10x faster than ``np.load`` for a trial's
    ~80 small arrays. None when the file is not of that simple form (then ``np.load`` reads it)."""
    out = {}
    with zipfile.ZipFile(io.BytesIO(raw)) as zf:
        for info in zf.infolist():
            if info.compress_type != zipfile.ZIP_STORED or not info.filename.endswith(".npy"):
                return None
            head = _LOCAL_HEADER.unpack_from(raw, info.header_offset)
            if head[0] != b"PK\x03\x04":
                return None
            start = info.header_offset + _LOCAL_HEADER.size + head[10] + head[11]
            member = raw[start:start + info.file_size]
            if len(member) != info.file_size or zlib.crc32(member) != info.CRC:
                raise zipfile.BadZipFile(f"bad CRC-32 or size of {info.filename}")
            if member[:8] != b"\x93NUMPY\x01\x00":
                return None
            hlen = int.from_bytes(member[8:10], "little")
            m = _NPY_HEADER.fullmatch(member[10:10 + hlen])
            if m is None:
                return None
            shape = tuple(int(v) for v in m.group(2).split(b",") if v.strip())
            dtype = np.dtype(m.group(1).decode())
            count = int(np.prod(shape, dtype=np.int64)) if shape else 1
            body = member[10 + hlen:]
            if len(body) != count * dtype.itemsize:
                raise ValueError(f"{info.filename}: {len(body)} bytes for shape {shape} of {dtype}")
            out[info.filename[:-4]] = np.frombuffer(body, dtype=dtype, count=count).reshape(shape).copy()
    return out


def decode_trial(data: bytes | Path, expect_trial: int | None = None,
                 expect_variants: tuple[str, ...] | list[str] | None = None) -> tuple[dict[str, np.ndarray], dict]:
    """Inverse of :func:`encode_trial`; raises :class:`CorruptTrial` on any inconsistency.

    With ``expect_variants`` (names in order) the file must hold exactly those variants, each with
    its :data:`VARIANT_KEYS` arrays. A file written before variants existed lists none in its meta;
    its variants are then the ones it holds arrays of.
    """
    try:
        # Read the bytes first: np.load on a path leaks its handle when the zip is damaged.
        raw = data if isinstance(data, bytes) else Path(data).read_bytes()
        arrays = _read_npz_stored(raw)
        if arrays is None:
            with np.load(io.BytesIO(raw), allow_pickle=False) as z:
                arrays = {k: z[k] for k in z.files}
        meta = json.loads(arrays.pop("__meta__").tobytes().decode())
    except Exception as exc:  # zipfile, CRC, JSON, missing key: all mean "do not trust"
        raise CorruptTrial(f"unreadable ({type(exc).__name__}: {exc})") from None
    if meta.get("format") != FORMAT or _digest(arrays) != meta.get("sha256"):
        raise CorruptTrial("checksum mismatch")
    if expect_trial is not None and meta.get("trial") != expect_trial:
        raise CorruptTrial(f"holds trial {meta.get('trial')}, expected {expect_trial}")
    if expect_variants is not None:
        expect = list(expect_variants)
        held = meta.get("variants")
        if held is None:  # format of the two fixed configurations: infer from the arrays
            held = [n for n in expect if f"{n}/scalars" in arrays]
        if list(held) != expect:
            missing = [n for n in expect if n not in held]
            raise CorruptTrial(f"holds variants {list(held)}, expected {expect}"
                               + (f" (missing {missing[0]!r})" if missing else ""))
        for n in expect:
            for key in VARIANT_KEYS:
                if f"{n}/{key}" not in arrays:
                    raise CorruptTrial(f"variant {n!r} lacks its {key!r} array")
        meta = dict(meta, variants=expect)
    return arrays, meta


def _check_orphans(root: Path, seed: int, chash: str) -> None:
    """A directory with trial files but no manifest: its manifest may be rebuilt only when every
    readable trial is of this very run (seed and configuration hash); otherwise refuse, never relabel."""
    trials = root / "trials"
    if not trials.is_dir():
        return
    for p in sorted(trials.glob("trial_*.npz")):
        try:
            _, meta = decode_trial(p)
        except CorruptTrial:
            continue  # recomputed later like any corrupt file
        if meta.get("seed") != seed or meta.get("config_hash") != chash:
            raise InputError(f"--out: {root} has no manifest.json, and {p.name} is a trial of another run (seed "
                             f"{meta.get('seed')}, or another configuration); refusing to relabel it: use another "
                             "directory")


def check_identity(path: Path, meta: dict, seed: int, chash: str) -> None:
    """Refuse a trial whose recorded identity (seed, configuration hash) is not the run's."""
    if meta.get("seed") != seed:
        raise ForeignTrial(f"{path}: a trial of seed {meta.get('seed')}, not this run's {seed}; refusing to use it "
                           "(move it away, or use another directory)")
    if "config_hash" in meta and chash and meta["config_hash"] != chash:
        raise ForeignTrial(f"{path}: a trial of another configuration (hash {str(meta['config_hash'])[:12]}..., this "
                           f"run {chash[:12]}...); refusing to use it (move it away, or use another directory)")


@dataclass
class TrialStore:
    """A Monte Carlo result directory bound to one configuration, seed and list of variants."""

    root: Path
    config: Config
    seed: int
    variants: tuple[Variant, ...] = DEFAULT_VARIANTS
    chash: str = ""  # the manifest's configuration hash, which every trial file must carry

    @property
    def variant_names(self) -> tuple[str, ...]:
        return tuple(v.name for v in self.variants)

    @property
    def trials_dir(self) -> Path:
        return self.root / "trials"

    def path(self, trial: int) -> Path:
        """File of trial number ``trial`` (1-based)."""
        return self.trials_dir / f"trial_{trial:06d}.npz"

    @classmethod
    def open(cls, root: str | Path, config: Config, seed: int,
             variants: tuple[Variant, ...] = DEFAULT_VARIANTS) -> "TrialStore":
        """Create ``root`` or reopen it; refuse a directory made with another config, seed or variants."""
        root = Path(root)
        variants = check_variants(variants)
        make_dir(root)
        man = root / "manifest.json"
        chash = config_hash(config, variants)
        if man.exists():
            try:
                m = json.loads(man.read_text())
            except (OSError, json.JSONDecodeError) as exc:
                raise InputError(f"--out: {man} is not a readable manifest ({exc})") from None
            if m.get("seed") != seed:
                raise InputError(f"--out: {root} holds a Monte Carlo with seed {m.get('seed')}, not {seed}; "
                                 "use another directory")
            if "variants" in m:
                listed = m["variants"] if isinstance(m["variants"], list) else []
                stored = [v.get("name") if isinstance(v, dict) else v for v in listed]
                same = m.get("config_hash") == config_hash(config, variants)
            else:  # written before variants existed: it ran the default two
                stored = [v.name for v in PAPER_VARIANTS]
                same = variants == PAPER_VARIANTS and m.get("config_hash") == config_hash(config)
            if not same:
                names = [v.name for v in variants]
                what = (f"variants {stored}, not {names}" if stored != names
                        else "a different configuration or variant overlays")
                raise InputError(f"--out: {root} holds a Monte Carlo with {what} (see {man}); use another directory")
            chash = m.get("config_hash", chash)
        else:
            _check_orphans(root, seed, chash)   # trials without a manifest: rebuild only if they are this run's
            write_json(man, {"format": FORMAT, "seed": seed, "config_hash": chash,
                             "version": __version__, "config_toml": to_toml(config), "config": to_dict(config),
                             "variants": variants_to_json(variants)})
            atomic_write_text(root / "config.toml", to_toml(config))
        (root / "trials").mkdir(exist_ok=True)
        return cls(root, config, seed, variants, chash)

    @classmethod
    def read(cls, root: str | Path) -> "TrialStore":
        """Open an existing directory for reading (the report)."""
        root = Path(root)
        man = root / "manifest.json"
        if not man.is_file():
            raise InputError(f"DIR: {root} has no manifest.json; is it a montecarlo output directory?")
        m = json.loads(man.read_text())
        try:
            variants = variants_from_json(m["variants"]) if "variants" in m else PAPER_VARIANTS
        except InputError as exc:
            raise InputError(f"DIR: {man} lists unreadable variants ({exc})") from None
        return cls(root, from_dict(tomllib.loads(m["config_toml"])), int(m["seed"]), variants,
                   str(m.get("config_hash", "")))

    def save(self, trial: int, data: bytes) -> None:
        atomic_write_bytes(self.path(trial), data)

    def load(self, trial: int) -> tuple[dict[str, np.ndarray], dict]:
        """Arrays and meta of trial ``trial``.

        Raises
        ------
        CorruptTrial
            Unreadable, checksum mismatch, or a variant missing (recompute it).
        ForeignTrial
            A sound file of another run: another seed or configuration hash than the manifest's
            (the file is named; it is never used nor deleted).
        """
        arrays, meta = decode_trial(self.path(trial), expect_trial=trial, expect_variants=self.variant_names)
        check_identity(self.path(trial), meta, self.seed, self.chash)
        return arrays, meta

    def strays(self) -> list[Path]:
        """Files in ``trials/`` that are not trial files (ignored)."""
        if not self.trials_dir.is_dir():
            return []
        return sorted(p for p in self.trials_dir.iterdir()
                      if not TRIAL_NAME.fullmatch(p.name) and not p.name.startswith("."))

    def lock(self):
        """An exclusive lock on the directory for one run (a second run on it is refused at once)."""
        return DirectoryLock(self.root)

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
        """Numbers of all trial files present (valid or not); stray names are not trials."""
        return sorted(int(m[1]) for p in self.trials_dir.glob("trial_*.npz") if (m := TRIAL_NAME.fullmatch(p.name)))

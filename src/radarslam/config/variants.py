"""Named configuration variants: what a Monte Carlo runs on every trial's simulated data.

A :class:`Variant` is a name, a label and an *overlay*: a nested dict in the configuration's TOML
shape (``{"extent": {"use_in_slam": True}}``). :func:`apply_variant` deep-merges the overlay over
the run's configuration and rebuilds it with :func:`radarslam.config.from_dict`, so every key is
type- and range-checked. Every variant of a run estimates from the *same* simulated data, so an
overlay may not touch the sections that drive the simulation (:data:`SIMULATION_SECTIONS`).

On the command line a variant is ``NAME=FILE.toml`` (:func:`parse_variant_arg`); the file is the
overlay, with an optional top-level ``label = "..."``.
"""

from __future__ import annotations

import copy
import json
import math
import re
import tomllib
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field

from radarslam.config import Config, from_dict, merge_tables, read_toml, to_dict
from radarslam.core.errors import ConfigError, InputError

#: Configuration sections that define the simulated data, shared by every variant of a run (``sensor``:
#: the radar's mounting, from which the simulator measures, docs/method.md b.4.3).
SIMULATION_SECTIONS = ("profile", "trajectory", "odometer", "radar", "world", "sensor")

#: Keys of the Monte Carlo results (:func:`~.montecarlo.load_results`), of the report's tables and
#: of its CSV headers that sit beside the per-variant entries; a variant cannot take these names...
RESERVED_NAMES = frozenset({"config", "configs", "seed", "trials", "corrupt", "seconds", "true_poses", "variants",
                            "change_pct", "baseline", "label", "labels", "n_runs", "n_boot", "level", "rng_seed",
                            "scalars", "meta", "metric", "k"})
#: ... nor start with these (CSV columns such as ``change_pct_NAME``, ``paper_ext``, ``band_low``).
RESERVED_PREFIXES = ("change_pct", "paper_", "band_")

NAME_PATTERN = re.compile(r"[a-z0-9][a-z0-9_-]*")


@dataclass(frozen=True)
class Variant:
    """One named configuration overlay.

    Attributes
    ----------
    name : str
        ``[a-z0-9][a-z0-9_-]*``, unique within a run; prefixes the variant's arrays (``"{name}/{key}"``).
    label : str
        Human-readable name for tables and legends.
    overlay : dict
        Nested dict in the configuration's TOML shape; may not touch :data:`SIMULATION_SECTIONS`.
    """

    name: str
    label: str
    overlay: dict = field(default_factory=dict, hash=False)

    def __post_init__(self) -> None:
        if not isinstance(self.name, str) or not NAME_PATTERN.fullmatch(self.name):
            raise InputError(f"variant name: expected [a-z0-9][a-z0-9_-]*, got {self.name!r}")
        if self.name in RESERVED_NAMES or self.name.startswith(RESERVED_PREFIXES):
            raise InputError(f"variant name: expected a name other than {sorted(RESERVED_NAMES)} and not starting "
                             f"with {list(RESERVED_PREFIXES)}, got {self.name!r}")
        if not isinstance(self.label, str) or not self.label.strip() or "\n" in self.label:
            raise InputError(f"variant {self.name!r} label: expected a non-empty one-line string, got {self.label!r}")
        if not isinstance(self.overlay, Mapping):
            raise InputError(f"variant {self.name!r} overlay: expected a table (dict), got {type(self.overlay).__name__}")
        touched = [k for k in self.overlay if k in SIMULATION_SECTIONS]
        if touched:
            raise InputError(f"variant {self.name!r} overlay: expected no change to the simulated data "
                             f"({', '.join(SIMULATION_SECTIONS)}; every variant runs on the same data), "
                             f"got key {touched[0]!r}")
        object.__setattr__(self, "overlay", copy.deepcopy(dict(self.overlay)))


#: The two configurations of seed Table 1; the first is the baseline of the relative changes.
PAPER_VARIANTS: tuple[Variant, ...] = (
    Variant("noext", "No extent", {"extent": {"use_in_slam": False}}),
    Variant("ext", "With extent", {"extent": {"use_in_slam": True}}),
)

#: Beyond the paper (docs/method.md a.7.3): the extent in SLAM with a filter that knows its error.
#: Its parts, each switchable and ablated by ``scripts/ablation_consistent.py``: the detection
#: spread of a circular prior extent (radius 2 m) before the extent exists, landmarks born at their
#: cluster's mean with the mean's noise and that prior spread, and one batch update per landmark
#: per scan, all of a scan's landmarks stacked into one update (``batch-joint``, docs/method.md
#: a.7.4: equal to the per-landmark ``batch`` on training seeds 1000-1002 in accuracy, NEES and
#: NIS, one pass over the covariance per scan instead of one per landmark).
#: Chosen on training seeds 1000-1002, never on the reporting seed 1.
CONSISTENT = Variant("consistent", "Consistent (beyond the paper)", {
    "extent": {"use_in_slam": True, "pre_init_spread": "prior", "prior_extent_radius_m": 2.0},
    "landmarks": {"init": "cluster", "associator": "batch-joint"},
})

#: What a Monte Carlo runs unless told otherwise: the paper's two columns and the consistent one.
DEFAULT_VARIANTS: tuple[Variant, ...] = PAPER_VARIANTS + (CONSISTENT,)


def apply_variant(config: Config, variant: Variant) -> Config:
    """The configuration ``config`` with ``variant``'s overlay applied (every key validated).

    Raises
    ------
    ConfigError
        ``variant NAME: <dotted.key>: expected ..., got ...`` for an unknown or ill-typed key.
    """
    if not isinstance(variant, Variant):
        raise InputError(f"variant: expected a Variant, got {type(variant).__name__}")
    try:
        return from_dict(merge_tables(to_dict(config), variant.overlay))
    except ConfigError as exc:
        raise ConfigError(f"variant {variant.name!r}: {exc}") from None


def check_variants(variants: Iterable[Variant], what: str = "variants") -> tuple[Variant, ...]:
    """``variants`` as a tuple, refusing an empty list, a non-Variant or a name used twice."""
    vs = tuple(variants)
    if not vs:
        raise InputError(f"{what}: expected at least one variant, got none")
    for v in vs:
        if not isinstance(v, Variant):
            raise InputError(f"{what}: expected Variant objects, got {type(v).__name__}")
    names = [v.name for v in vs]
    dup = next((n for n in names if names.count(n) > 1), None)
    if dup is not None:
        raise InputError(f"{what}: expected unique names, got {dup!r} twice (names: {', '.join(names)})")
    return vs


def parse_variant_arg(text: str) -> Variant:
    """A :class:`Variant` from the command-line form ``NAME=FILE.toml``.

    The TOML file is the overlay; an optional top-level ``label = "..."`` gives the label (default
    the name). Errors name ``--variant``.
    """
    if not isinstance(text, str) or "=" not in text:
        raise InputError(f"--variant: expected NAME=FILE.toml, got {text!r}")
    name, path = text.split("=", 1)
    if not NAME_PATTERN.fullmatch(name):
        raise InputError(f"--variant: expected a NAME matching [a-z0-9][a-z0-9_-]*, got {name!r}")
    data = read_toml(path, f"--variant {name}: overlay file", InputError)
    label = data.pop("label", name)
    if not isinstance(label, str):
        raise InputError(f"--variant {name}: label: expected a string, got {label!r}")
    try:
        return Variant(name, label, data)
    except InputError as exc:
        raise InputError(f"--variant {name}: {exc}") from None


# ------------------------------------------------------------------------------------------------
# manifest form: JSON has no inf/nan, so each overlay is also kept as exact TOML text


_BARE_KEY = re.compile(r"[A-Za-z0-9_-]+")


def _toml_key(k: str) -> str:
    return k if _BARE_KEY.fullmatch(k) else json.dumps(k)


def _toml_value(v) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        if math.isnan(v):
            return "nan"
        if math.isinf(v):
            return "inf" if v > 0 else "-inf"
        return repr(v)
    if isinstance(v, str):
        return json.dumps(v)
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(_toml_value(x) for x in v) + "]"
    if isinstance(v, Mapping):
        return "{" + ", ".join(f"{_toml_key(str(k))} = {_toml_value(x)}" for k, x in v.items()) + "}"
    raise InputError(f"overlay: expected TOML values (bool, int, float, str, list, table), got {type(v).__name__}")


def overlay_to_toml(overlay: Mapping, _prefix: str = "") -> str:
    """TOML text of a nested overlay dict (``tomllib.loads`` gives it back exactly)."""
    scalars = [(k, v) for k, v in overlay.items() if not isinstance(v, Mapping)]
    tables = [(k, v) for k, v in overlay.items() if isinstance(v, Mapping)]
    lines = [f"{_toml_key(str(k))} = {_toml_value(v)}" for k, v in scalars]
    for k, v in tables:
        name = f"{_prefix}{_toml_key(str(k))}"
        lines += ["", f"[{name}]", overlay_to_toml(v, name + ".")]
    return "\n".join(lines).strip("\n") + ("\n" if not _prefix else "")


def variants_to_json(variants: Sequence[Variant]) -> list[dict]:
    """Manifest form: ``[{"name", "label", "overlay", "overlay_toml"}, ...]`` in order.

    ``overlay`` is for reading (JSON; a non-finite number in it becomes null); ``overlay_toml`` is
    exact and is what :func:`variants_from_json` reads back.
    """
    return [{"name": v.name, "label": v.label, "overlay": v.overlay, "overlay_toml": overlay_to_toml(v.overlay)}
            for v in check_variants(variants)]


def variants_from_json(data) -> tuple[Variant, ...]:
    """Inverse of :func:`variants_to_json` (``overlay_toml`` preferred, else ``overlay``)."""
    if not isinstance(data, list):
        raise InputError(f"variants: expected a list of {{name, label, overlay}}, got {type(data).__name__}")
    out = []
    for i, d in enumerate(data):
        if not isinstance(d, Mapping) or not isinstance(d.get("name"), str):
            raise InputError(f"variants[{i}]: expected a table with a name, got {d!r}")
        if isinstance(d.get("overlay_toml"), str):
            try:
                overlay = tomllib.loads(d["overlay_toml"])
            except tomllib.TOMLDecodeError as exc:
                raise InputError(f"variants[{i}].overlay_toml: not valid TOML ({exc})") from None
        else:
            overlay = d.get("overlay", {})
        out.append(Variant(d["name"], d.get("label", d["name"]), overlay))
    return check_variants(out)


def variant_hash_data(variants: Sequence[Variant]) -> list[dict]:
    """What the directory identity hashes of the variants: names, labels and overlays, in order."""
    return [{"name": v.name, "label": v.label, "overlay": v.overlay} for v in variants]

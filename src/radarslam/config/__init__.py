"""Typed, validated configuration: nested dataclasses loaded from TOML.

Every parameter of docs/method.md has a field here with its unit in the name (``_m``, ``_deg``, ...);
the algorithms read SI/radian values through the ``*_rad`` / covariance properties. Profiles are
TOML overlays shipped in ``radarslam/profiles/`` whose comments give the reason for each value
(docs/method.md Decision 1): ``apsipa`` (default, APSIPA Table I), ``reference`` (the authors'
published implementation; they differ only in ``beta``, ``gamma_a`` and the merge rule) and
``victoria-park`` (the real laser data).

Each section has one owner: ``trajectory``, ``odometer``, ``radar`` and ``world`` the simulator;
``filter``, ``landmarks`` and ``extent`` the estimator (:class:`EstimatorConfig`); ``metrics`` the
evaluation. Component choices (``filter.motion_model``, ``filter.measurement_model``,
``landmarks.associator``, ``extent.estimator``) are names in :mod:`radarslam.core.registry`.

Fields marked [PROP] in their doc are assumptions where the papers are silent (docs/method.md tags).

The package: :mod:`.sections` (the dataclasses and their fields), :mod:`.loading` (checking,
TOML in and out); the profiles and the entry points (:func:`profile_config`, :func:`from_dict`,
:func:`load_config`) are here, and every public name is importable from ``radarslam.config``.
"""

from __future__ import annotations

import copy
import tomllib
from collections.abc import Mapping
from importlib import resources
from pathlib import Path

from radarslam.config.loading import (  # noqa: F401 - the private helpers too, by their former path
    _apply,
    _check_value,
    _field_type,
    _toml_value,
    _type_hints,
    read_toml,
    to_dict,
    to_toml,
    validate,
)
from radarslam.config.sections import (
    CARPARK_VEHICLES,
    MAX_DETECTIONS_PER_SCAN,
    MAX_STEPS,
    MAX_VEHICLES,
    PARTIAL_VIEW_SPREAD_MODELS,
    RIG_REQUIRED,
    SPREAD_FACTORS,
    Config,
    EstimatorConfig,
    ExtentConfig,
    FilterConfig,
    LandmarkConfig,
    MetricsConfig,
    OdometerConfig,
    RadarConfig,
    RigSensorConfig,
    SensorConfig,
    TrajectoryConfig,
    WorldConfig,
    param,
)
from radarslam.config.profile_files import PROFILE_DIR, list_profiles
from radarslam.core.errors import ConfigError


def profile_overlay(name: str, _seen: tuple[str, ...] = ()) -> dict:
    """The overrides of profile ``name`` as a nested dict: its TOML file's content, laid over the
    overrides of the profile it names in ``extends = "..."`` (if any; tables merge key by key)."""
    if name not in list_profiles():
        key = f"profile {_seen[-1]!r}: extends" if _seen else "profile"
        raise ConfigError(f"{key}: expected one of {list_profiles()}, got {name!r}")
    if name in _seen:
        raise ConfigError(f"profile {_seen[-1]!r}: extends: expected no cycle, got {' -> '.join(_seen + (name,))}")
    own = _read_profile(name)
    base = own.pop("extends", None)
    return merge_tables(profile_overlay(base, _seen + (name,)), own) if base is not None else own


def _read_profile(name: str) -> dict:
    """The TOML file of profile ``name`` as a dict."""
    with resources.files("radarslam").joinpath(PROFILE_DIR, f"{name}.toml").open("rb") as fh:
        return tomllib.load(fh)


def merge_tables(base: dict, overlay: Mapping) -> dict:
    """``base`` with ``overlay`` laid over it (a new dict): tables merge key by key, any other value
    replaces (copied). Profiles extending others and variant overlays both merge this way."""
    out = dict(base)
    for k, v in overlay.items():
        out[k] = merge_tables(out[k], v) if isinstance(v, Mapping) and isinstance(out.get(k), dict) else copy.deepcopy(v)
    return out


def profile_config(name: str = "apsipa") -> Config:
    """The default :class:`Config` of profile ``name`` (the defaults overlaid by its TOML file)."""
    overlay = profile_overlay(name)
    cfg = Config(profile=name)
    _apply(cfg, overlay, "")
    return cfg


def from_dict(data: dict, profile: str | None = None) -> Config:
    """Build a config: the profile's defaults (``data['profile']`` or ``profile``) overlaid with ``data``."""
    data = dict(data)
    name = profile or data.get("profile", "apsipa")
    if not isinstance(name, str):
        raise ConfigError(f"profile: expected a string, got {name!r}")
    cfg = profile_config(name)
    data["profile"] = name
    _apply(cfg, data, "")
    return validate(cfg)


def load_config(path: str | Path, profile: str | None = None) -> Config:
    """Load a TOML file over the defaults of ``profile`` (or the file's own ``profile`` key)."""
    return from_dict(read_toml(path), profile)


__all__ = [
    "CARPARK_VEHICLES", "MAX_DETECTIONS_PER_SCAN", "MAX_STEPS", "MAX_VEHICLES", "PARTIAL_VIEW_SPREAD_MODELS",
    "PROFILE_DIR", "RIG_REQUIRED", "SPREAD_FACTORS", "Config", "EstimatorConfig", "ExtentConfig", "FilterConfig",
    "LandmarkConfig", "MetricsConfig", "OdometerConfig", "RadarConfig", "RigSensorConfig", "SensorConfig",
    "TrajectoryConfig", "WorldConfig", "from_dict", "list_profiles", "load_config", "merge_tables", "param",
    "profile_config", "profile_overlay", "read_toml", "to_dict", "to_toml", "validate",
]

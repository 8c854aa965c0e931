"""One configuration field: its default, documentation, unit and admissible range, checked by
:func:`radarslam.config.validate` (the sections of :mod:`radarslam.config.sections` and
:mod:`radarslam.config.simulation` are made of them)."""

from __future__ import annotations

from dataclasses import field
from typing import Any

from radarslam.core.registry import Registry


def param(default: Any, doc: str, *, low: float | None = None, high: float | None = None,
          low_open: bool = False, choices: tuple[str, ...] | None = None, length: int | None = None,
          registry: Registry | None = None, profiles: bool = False, allow_inf: bool = False) -> Any:
    """A config field with its documentation and admissible range (checked by :func:`validate`).

    ``registry``: the value names a component of that registry (checked against its names at
    validation time, so a component registered by any code is accepted).
    """
    meta = {"doc": doc, "low": low, "high": high, "low_open": low_open, "choices": choices, "length": length,
            "registry": registry, "profiles": profiles, "allow_inf": allow_inf}
    if isinstance(default, list):
        return field(default_factory=lambda d=default: list(d), metadata=meta)
    return field(default=default, metadata=meta)

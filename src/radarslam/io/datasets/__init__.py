"""Dataset loaders, one module each, selectable by name.

A loader is a callable ``loader(path, **options)`` returning an object whose ``events`` attribute is
the time-ordered list of :class:`~radarslam.core.types.Odometry` and
:class:`~radarslam.core.types.Scan` events. Built-in loaders are registered by a ``"module:attr"``
reference and imported on first use, so importing this package stays cheap (no scipy, no
matplotlib). :mod:`.nuscenes` and :mod:`.radarscenes` read those datasets in their official layouts
into the :class:`~radarslam.io.recording.stream.Recording` of a recording run instead (``radarslam run
--dataset nuscenes|radarscenes``, docs/datasets.md); they are not loaders of this registry.

>>> from radarslam.io.datasets import get_dataset, list_datasets
>>> "victoria-park" in list_datasets()
True
"""

from __future__ import annotations

import importlib
from collections.abc import Callable
from typing import Any

from radarslam.core.errors import InputError

Loader = Callable[..., Any]

# name -> loader, or "package.module:function" resolved (and cached) by get_dataset.
_DATASETS: dict[str, Loader | str] = {
    "victoria-park": "radarslam.io.datasets.victoria_park:load_victoria_park",
}


def register_dataset(name: str, loader: Loader | str) -> None:
    """Make ``loader`` selectable as ``name``; a later registration replaces an earlier one.

    Parameters
    ----------
    name : str
        Non-empty dataset name, e.g. ``"victoria-park"``.
    loader : callable or str
        ``loader(path, **options)``, or a ``"package.module:function"`` reference imported lazily.
    """
    if not isinstance(name, str) or not name:
        raise InputError(f"dataset name: expected a non-empty string, got {name!r}")
    if isinstance(loader, str):
        if loader.count(":") != 1:
            raise InputError(f"dataset loader: expected 'package.module:function', got {loader!r}")
    elif not callable(loader):
        raise InputError(f"dataset loader: expected a callable or 'package.module:function', got {type(loader).__name__}")
    _DATASETS[name] = loader


def get_dataset(name: str) -> Loader:
    """The loader registered as ``name`` (importing its module on first use)."""
    try:
        loader = _DATASETS[name]
    except (KeyError, TypeError):
        raise InputError(f"dataset: expected one of {list_datasets()}, got {name!r}") from None
    if isinstance(loader, str):
        module, attr = loader.split(":")
        loader = getattr(importlib.import_module(module), attr)
        _DATASETS[name] = loader
    return loader


def list_datasets() -> list[str]:
    """Registered dataset names, sorted."""
    return sorted(_DATASETS)


__all__ = ["get_dataset", "list_datasets", "register_dataset"]

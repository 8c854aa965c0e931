"""Named component registries: how configuration selects an implementation by name.

Every injectable part of the estimator (motion model, measurement model, associator, extent
estimator) has a :class:`Registry`. An implementation registers a *factory* under a name and a
backend (``"python"`` unless said otherwise); the factory receives the configuration section that
owns the component and returns the component. The built-in implementations are all registered in one
table (:data:`BUILT_INS`, by module and attribute, imported on first use), so listing the names
imports nothing heavy, and code outside the package adds
its own with :meth:`Registry.register` before building a filter::

    from radarslam.core.registry import ASSOCIATORS

    @ASSOCIATORS.register("my-associator")
    def make(config):            # config: the EstimatorConfig (filter, landmarks, extent)
        return MyAssociator(config.landmarks.beta)

then ``landmarks.associator = "my-associator"`` in a TOML file selects it
(``docs/architecture.md`` has the complete example). For the command line, a plug-in module is
imported before any name is looked up when it is named in the environment variable
``RADARSLAM_PLUGINS`` (comma-separated module names) or declared by an installed package as an
entry point of the group ``radarslam.plugins``.
"""

from __future__ import annotations

import importlib
import os
from collections.abc import Callable
from typing import Any

from radarslam.core.errors import ConfigError

DEFAULT_BACKEND = "python"
PLUGIN_ENV = "RADARSLAM_PLUGINS"
PLUGIN_GROUP = "radarslam.plugins"
_plugins_loaded = False


def load_plugins() -> None:
    """Import the plug-in modules of ``RADARSLAM_PLUGINS`` and of the ``radarslam.plugins`` entry
    points (once); each registers its components when imported."""
    global _plugins_loaded
    if _plugins_loaded:
        return
    _plugins_loaded = True
    from importlib.metadata import entry_points

    for name in filter(None, (m.strip() for m in os.environ.get(PLUGIN_ENV, "").split(","))):
        try:
            importlib.import_module(name)
        except ImportError as exc:
            raise ConfigError(f"{PLUGIN_ENV}: cannot import plug-in module {name!r} ({exc})") from None
    for ep in entry_points(group=PLUGIN_GROUP):
        ep.load()


class Registry:
    """Factories by ``(name, backend)``.

    Parameters
    ----------
    kind : str
        What is registered ("associator", ...), for messages.
    key : str
        The config key that selects it (``"landmarks.associator"``), for messages.
    """

    def __init__(self, kind: str, key: str):
        self.kind = kind
        self.key = key
        self._factories: dict[tuple[str, str], Callable[..., Any]] = {}
        self._lazy: dict[tuple[str, str], str] = {}   # (name, backend) -> "module:attribute"

    def register(self, name: str, factory: Callable[..., Any] | None = None, *, backend: str = DEFAULT_BACKEND,
                 replace: bool = False):
        """Register ``factory`` under ``name`` (usable as a decorator when ``factory`` is omitted).

        A name already taken by another factory is refused unless ``replace=True``.
        """
        if not isinstance(name, str) or not name:
            raise ConfigError(f"{self.kind} name: expected a non-empty string, got {name!r}")

        def add(f: Callable[..., Any]) -> Callable[..., Any]:
            key = (name, backend)
            if not replace and self._factories.get(key, f) is not f:
                raise ConfigError(f"{self.key}: {self.kind} {name!r} ({backend}) is already registered; "
                                  "pass replace=True to override it")
            self._factories[key] = f
            self._lazy.pop(key, None)
            return f

        return add if factory is None else add(factory)

    def register_lazy(self, name: str, target: str, *, backend: str = DEFAULT_BACKEND) -> None:
        """Declare the built-in ``name``: its factory is ``attribute`` of ``module`` (``target`` as
        ``"module:attribute"``, the attribute dotted for a class method), imported on first use."""
        if ":" not in target:
            raise ConfigError(f"{self.key}: {self.kind} {name!r}: expected 'module:attribute', got {target!r}")
        if (name, backend) not in self._factories:
            self._lazy[(name, backend)] = target

    def unregister(self, name: str, *, backend: str = DEFAULT_BACKEND) -> None:
        """Remove ``name`` (tests and plug-ins that clean up after themselves)."""
        self._factories.pop((name, backend), None)
        self._lazy.pop((name, backend), None)

    def names(self) -> list[str]:
        """Every registered name (any backend), sorted."""
        load_plugins()
        return sorted({n for n, _ in self._factories} | {n for n, _ in self._lazy})

    def backends(self, name: str) -> list[str]:
        """The backends that implement ``name``."""
        return sorted({b for n, b in self._factories if n == name} | {b for n, b in self._lazy if n == name})

    def factory(self, name: str, backend: str = DEFAULT_BACKEND) -> Callable[..., Any]:
        """The factory of ``(name, backend)``; a :class:`ConfigError` naming the key otherwise.

        A component registered only for the reference backend (``"python"``, e.g. one of your
        own) serves every backend: the backend chooses the compiled implementation where there is
        one, it does not exclude components that have none.
        """
        load_plugins()
        for key in ((name, backend), (name, DEFAULT_BACKEND)):
            if key not in self._factories and key in self._lazy:
                module, attribute = self._lazy.pop(key).split(":")
                f = importlib.import_module(module)
                for part in attribute.split("."):
                    f = getattr(f, part)
                self._factories[key] = f
            if key in self._factories:
                return self._factories[key]
        if name not in self.names():
            raise ConfigError(f"{self.key}: expected one of {self.names()}, got {name!r}")
        raise ConfigError(f"{self.key}: {self.kind} {name!r} has no {backend!r} implementation "
                          f"(filter.backend; it has {self.backends(name)})")

    def create(self, name: str, *args: Any, backend: str = DEFAULT_BACKEND, **kwargs: Any) -> Any:
        """Build the component: ``factory(name, backend)(*args, **kwargs)``."""
        return self.factory(name, backend)(*args, **kwargs)


MOTION_MODELS = Registry("motion model", "filter.motion_model")
ASSOCIATORS = Registry("associator", "landmarks.associator")
EXTENT_ESTIMATORS = Registry("extent estimator", "extent.estimator")

#: Every built-in component, the one place they are registered: (registry, name, backend, factory as
#: "module:attribute"); the module is imported when the component is first asked for.
BUILT_INS = (
    (MOTION_MODELS, "unicycle", "python", "radarslam.models.motion:make_unicycle"),
    (MOTION_MODELS, "ackermann", "python", "radarslam.models.ackermann:make_ackermann"),
    (MOTION_MODELS, "body-velocity", "python", "radarslam.models.body_velocity:make_body_velocity"),
    (ASSOCIATORS, "nearest-neighbour", "python", "radarslam.slam.association:make_nearest_neighbour"),
    (ASSOCIATORS, "nearest-neighbour", "numba", "radarslam.slam.association:make_compiled_nearest_neighbour"),
    (ASSOCIATORS, "batch", "python", "radarslam.slam.association:make_batch"),
    (ASSOCIATORS, "batch", "numba", "radarslam.slam.association:make_compiled_batch"),
    (ASSOCIATORS, "batch-joint", "python", "radarslam.slam.association:make_batch_joint"),
    (ASSOCIATORS, "batch-joint", "numba", "radarslam.slam.association:make_compiled_batch_joint"),
    (ASSOCIATORS, "jcbb", "python", "radarslam.slam.jcbb:make_jcbb"),
    (ASSOCIATORS, "jcbb", "numba", "radarslam.slam.jcbb:make_compiled_jcbb"),
    (EXTENT_ESTIMATORS, "rma-efa", "python", "radarslam.extent.estimator:RmaEfaEstimator.from_config"),
    (EXTENT_ESTIMATORS, "visible-arc", "python", "radarslam.extent.visible_arc:VisibleArcEstimator.from_config"),
    (EXTENT_ESTIMATORS, "mem-ekf", "python", "radarslam.extent.mem_ekf:MemEkfEstimator.from_config"),
    (EXTENT_ESTIMATORS, "partial-view", "python", "radarslam.extent.view_estimator:PartialViewEstimator.from_config"),
)
for _registry, _name, _backend, _target in BUILT_INS:
    _registry.register_lazy(_name, _target, backend=_backend)

#: Every backend some built-in implements (``filter.backend``).
BACKENDS = ("python", "numba")

"""Old public names kept importable after a rename, each with a :class:`DeprecationWarning` naming the new one."""

from __future__ import annotations

import warnings


def renamed(module: str, old: dict):
    """A module ``__getattr__`` (PEP 562) for ``module`` that hands over ``old[name] = (object, new name)``
    with a :class:`DeprecationWarning` naming the new name; any other name is an :class:`AttributeError`."""

    def __getattr__(name: str):
        if name in old:
            obj, new = old[name]
            warnings.warn(f"{module}.{name} is deprecated: use {new}", DeprecationWarning, stacklevel=2)
            return obj
        raise AttributeError(f"module {module!r} has no attribute {name!r}")

    return __getattr__

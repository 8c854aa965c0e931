"""Compiling the package's plain-Python kernels with numba (docs/architecture.md "Backends").

A *kernel* is a function in the subset of Python and numpy that numba compiles as it is (plain
floats, loops, small arrays). The reference backend calls it as Python; the compiled backend calls
the same code compiled by :func:`compile_kernels`, so the two backends share their arithmetic and
differ only in the loops written for numba around it. Importing this module needs numba.
"""

from __future__ import annotations

import math
import types

import numpy as np
from numba import njit
from numba.extending import overload


@overload(math.fmod)
def _fmod(a, b):  # pragma: no cover - compiled
    """numba has no ``math.fmod``; ``np.fmod`` is the same exact IEEE remainder."""
    def impl(a, b):
        return np.fmod(a, b)
    return impl


#: Modules whose functions :func:`compile_kernels` compiled (their files must be in
#: :data:`radarslam.core.numba_cache.COMPILED_SOURCES`; tests/test_layering.py).
COMPILED_MODULES: set[str] = set()


def compile_kernels(*funcs, replace=None):
    """Compile the plain-Python kernels ``funcs`` with numba, each calling the others' compiled form.

    Each function is rebuilt from its own code object over a copy of its module's globals in which
    every kernel name refers to the compiled kernel, so a kernel that calls another (``update``
    calls ``wrap_2pi_scalar``) runs compiled throughout. ``replace`` maps a kernel name to a
    loop form written for numba that the compiled kernels call instead (the Joseph update and its
    n x n pass have one each, :mod:`radarslam.slam._numba`). Returns ``{name: dispatcher}``.
    """
    COMPILED_MODULES.update(f.__module__ for f in (*funcs, *(replace or {}).values()))
    compiled, spaces = {name: njit(cache=True)(f) for name, f in (replace or {}).items()}, []
    for f in funcs:
        g = dict(f.__globals__)
        spaces.append(g)
        clone = types.FunctionType(f.__code__, g, f.__name__, f.__defaults__, f.__closure__)
        clone.__qualname__ = f.__qualname__
        compiled[f.__name__] = njit(cache=True)(clone)
    for g in spaces:
        g.update(compiled)
    return compiled

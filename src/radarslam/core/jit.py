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
from numba.core.registry import CPUDispatcher
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


class CompiledOnly(CPUDispatcher):
    """A numba dispatcher for a function that only compiled code calls (:func:`compiled_only`):
    called from Python it refuses in one line instead of jumping to an entry point that was never
    built."""

    def __call__(self, *args, **kwargs):
        raise TypeError(f"{self.py_func.__module__}.{self.py_func.__qualname__} is compiled without a Python "
                        "entry point (core.jit.compiled_only): call it from compiled code")


def compiled_only(func):
    """``njit(cache=True)`` for a function that only other compiled functions call: its machine code
    without the two entry points numba builds for every compiled function, the one Python calls (it
    unboxes each argument from a Python object: for the fused engine's configuration and landmark
    tuples, dozens of fields) and the C one (a first-class function pointer). Neither is ever used
    by a callee. The fused engine's steps compiled this way, once each instead of inlined into its
    loop, with the loop's counters typed int64, took 10-18% off the default family's compile
    (docs/architecture.md "Where the compile time goes"). Numerically the same code.

    The cache keys a function by its file and qualified name, not by these options, so the same
    function must never also be compiled with the entry points (:class:`CompiledOnly` refuses a
    Python call rather than compiling one)."""
    disp = CompiledOnly(py_func=func, locals={},
                        targetoptions={"nopython": True, "no_cpython_wrapper": True, "no_cfunc_wrapper": True})
    disp.enable_caching()
    return disp


def _global_names(code) -> set[str]:
    """The global names ``code`` and the code objects nested in it (comprehensions, inner functions) read."""
    names = set(code.co_names)
    for const in code.co_consts:
        if isinstance(const, types.CodeType):
            names |= _global_names(const)
    return names


def _contents(cell):
    """What a closure cell holds, None for an empty one (a name the function assigns later)."""
    try:
        return cell.cell_contents
    except ValueError:
        return None


def uncompiled(fn, keep=None, replace=None):
    """``fn`` (a numba dispatcher) as Python: the same code object over a copy of its globals and
    closure in which every compiled function it calls is itself uncompiled, recursively, so that
    the whole call graph runs in the interpreter on the same arithmetic (the reference the
    compiled code is checked against; docs/architecture.md "Backends").

    ``keep(dispatcher)`` True leaves that callee compiled (called through numba's Python entry
    point); ``fn`` itself, and a :func:`compiled_only` function (which has none), are always
    uncompiled. Default: nothing is kept. ``replace`` maps a global name to what every cloned function
    that reads it calls instead (a Python function: a component of the user's own in the place of
    a built-in kernel). Each function is cloned once per call of ``uncompiled``."""
    memo: dict[int, types.FunctionType] = {}

    def python_form(disp, root=False):
        if not root and keep is not None and not isinstance(disp, CompiledOnly) and keep(disp):
            return disp
        f = disp.py_func
        if id(f) in memo:
            return memo[id(f)]
        g = dict(f.__globals__)
        cells = f.__closure__
        if cells:
            cells = tuple(types.CellType(python_form(_contents(c))) if isinstance(_contents(c), CPUDispatcher)
                          else c for c in cells)
        clone = types.FunctionType(f.__code__, g, f.__name__, f.__defaults__, cells)
        clone.__qualname__, clone.__module__, clone.__doc__ = f.__qualname__, f.__module__, f.__doc__
        memo[id(f)] = clone
        for name in _global_names(f.__code__) & g.keys():
            if replace is not None and name in replace:
                g[name] = replace[name]
            elif isinstance(g[name], CPUDispatcher):
                g[name] = python_form(g[name])
        return clone

    return python_form(fn, root=True)

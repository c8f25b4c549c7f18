"""Two rules for numba kernels, so a kernel's numbers do not depend on where or after what it was compiled.

What a kernel computed once depended on the history of numba's on-disk cache: the same source gave other
bits in a process that loaded a kernel from the cache than in the process that had compiled it, and
other bits again when one of its callees had been cached by an earlier process (seen on the robust
Madgwick, Mahony, EKF, complementary and UKF kernels in a full test run; a tuning whose workers load
from the cache while the parent compiled could then score the same candidate twice differently).

1. **Strict IEEE arithmetic**: no kernel uses ``fastmath``. Under its flags (reassociation, contraction,
   reciprocals) LLVM may round differently each time it optimises a function: once in its own module,
   again as a linked copy inside a caller's module, again after inlining. Without them every
   optimisation keeps each rounded result, so the bits are the same whichever copy runs. Measured on
   300 s at 200 Hz: Madgwick, Mahony and the complementary filters as fast as before (within noise),
   the UKF 18 % slower.
2. **No cached callee**: a jitted function called by another jitted function is either inlined by
   numba (``inline="always"``) or not cached, so its caller is compiled from its IR and the caller's
   own cache entry holds the whole call tree. A kernel also called from Python keeps its cache and gives
   the kernels that call it an uncached twin (:func:`uncached`).

:func:`rule_violations` finds every breach in a set of modules; a test runs it over both packages.
"""

from __future__ import annotations

import importlib
import pkgutil
import types
from collections.abc import Iterable

from numba import njit
from numba.core.registry import CPUDispatcher

__all__ = ["uncached", "rule_violations", "package_modules"]


def uncached(dispatcher: CPUDispatcher) -> CPUDispatcher:
    """A second dispatcher of the same Python function with the same options but no on-disk cache.

    Kernels call the twin; Python calls the cached original. Both compile the same source with the same
    options, so they compute the same bits.
    """
    options = {k: v for k, v in dispatcher.targetoptions.items() if k not in ("cache", "nopython")}
    return njit(**options)(dispatcher.py_func)


def _is_cached(d: CPUDispatcher) -> bool:
    return type(d._cache).__name__ != "NullCache"


def _names(code: types.CodeType) -> set[str]:
    names = set(code.co_names)
    for const in code.co_consts:
        if isinstance(const, types.CodeType):
            names |= _names(const)
    return names


def _callees(d: CPUDispatcher) -> set[CPUDispatcher]:
    """The jitted functions ``d`` names (as module globals or as attributes of a module global)."""
    glob = d.py_func.__globals__
    names = _names(d.py_func.__code__)
    found = set()
    for name in names:
        value = glob.get(name)
        if isinstance(value, CPUDispatcher):
            found.add(value)
        elif isinstance(value, types.ModuleType):
            found.update(w for a in names if isinstance(w := getattr(value, a, None), CPUDispatcher))
    return found


def package_modules(*packages: str) -> list[types.ModuleType]:
    """Every module of the given packages, imported (``__main__`` modules, which would run, are left out)."""
    mods = []
    for name in packages:
        pkg = importlib.import_module(name)
        mods.append(pkg)
        mods.extend(importlib.import_module(m.name) for m in pkgutil.walk_packages(pkg.__path__, name + ".")
                    if not m.name.endswith(".__main__"))
    return mods


def rule_violations(modules: Iterable[types.ModuleType]) -> list[str]:
    """Every breach of the two rules: ``"module.kernel uses fastmath"`` and ``"module.callee <- caller, ..."``
    (a cached, not-inlined function another kernel calls)."""
    kernels = {id(v): v for m in modules for v in vars(m).values()
               if isinstance(v, CPUDispatcher) and v.py_func.__module__ == m.__name__}
    fast = sorted(f"{k.py_func.__module__}.{k.py_func.__name__} uses fastmath" for k in kernels.values()
                  if k.targetoptions.get("fastmath"))
    bad: dict[str, set[str]] = {}
    for caller in kernels.values():
        for callee in _callees(caller):
            if callee.targetoptions.get("inline", "never") != "always" and _is_cached(callee):
                key = f"{callee.py_func.__module__}.{callee.py_func.__name__}"
                bad.setdefault(key, set()).add(caller.py_func.__name__)
    return fast + [f"{k} <- {', '.join(sorted(v))}" for k, v in sorted(bad.items())]

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
   the kernels that call it an uncached twin (:func:`uncached`). A twin is a second compile of the same
   body on a cold cache, so the largest kernels (the UKF, Madgwick, Mahony) do it the other way round:
   their body is the uncached function the other kernels call, and Python calls a cached one-line
   wrapper of it; a process compiles the body once (the UKF's 12 s CPU, twice before). Numba-level
   inlining types the callee's IR again at every call site (most of the UKF's compile time), but an
   uncached call in a per-sample path costs run time (LLVM does not inline numba's calls there: the QUKF
   2-4 % slower with its per-sample helpers as calls, the robust Madgwick 15 % with its prologue), so the
   kernels keep their helpers inlined. Most of a call's cost is the atomic reference count numba keeps of
   each array argument: a callee that takes and returns scalars only (``robust.acc_lp_step``) costs 2-4 % as a
   call, is compiled once per process for every kernel that calls it, and keeps those kernels' cold compile
   down (the robust Madgwick and Mahony 5.2 and 4.9 s CPU with it inlined, 4.5 and 4.0-4.1 s as a call).
3. **The cache follows the package**: numba keys a cache entry on the caller's own source file only, so a
   cached kernel that calls a kernel of another module (compiled into it by rule 2) would keep running the
   old callee after an edit there. Importing this module (``objectives/__init__.py`` does, before any
   kernel is defined) puts the package's cache locators first: for a kernel of this package the entry is
   also keyed on a digest of every source file of the package (:func:`package_digest`), so any edit
   invalidates every entry and cross-module kernels (the population batches, the closed-loop drivers)
   are cached too. They compiled in every process before (15 s for the Madgwick batch), now once per
   machine. :data:`CACHE` is False when this numba has no locator list to extend; kernels that call
   other modules then stay uncached (``cache=CACHE``).

:func:`rule_violations` finds every breach of rules 1 and 2, and a cached kernel of the package outside rule 3's
locators, in a set of modules; a test runs it over both packages.
"""

from __future__ import annotations

import hashlib
import importlib
import pkgutil
import types
from collections.abc import Iterable
from functools import cache
from pathlib import Path

from numba import njit
from numba.core import caching
from numba.core.registry import CPUDispatcher

__all__ = ["CACHE", "uncached", "rule_violations", "package_modules", "package_digest", "install_locators"]

#: the package's source tree (rule 3 keys cache entries on all of it)
_ROOT = Path(__file__).resolve().parent


@cache
def package_digest(root: Path = _ROOT) -> str:
    """SHA-256 of every ``.py`` file under ``root`` (relative path and content), computed once per process."""
    h = hashlib.sha256()
    for path in sorted(root.rglob("*.py")):
        h.update(path.relative_to(root).as_posix().encode())
        h.update(b"\0")
        h.update(path.read_bytes())
    return h.hexdigest()


def _under(py_file: str, root: Path) -> bool:
    try:
        return Path(py_file).resolve().is_relative_to(root)
    except (OSError, ValueError):
        return False


def _package_locator(base: type, root: Path) -> type:
    """``base`` (one of numba's source-file locators) for the kernels under ``root``, the digest of ``root``'s
    sources added to the source stamp numba stores in each cache index and compares on load."""

    class PackageLocator(base):
        package_root = root

        @classmethod
        def from_function(cls, py_func, py_file):
            return super().from_function(py_func, py_file) if _under(py_file, root) else None

        def get_source_stamp(self):
            return super().get_source_stamp(), package_digest(root)

    PackageLocator.__name__ = PackageLocator.__qualname__ = f"Package{base.__name__.lstrip('_')}"
    return PackageLocator


def install_locators(root: Path = _ROOT) -> tuple[type, ...]:
    """Rule 3 for the sources under ``root``: locators in front of numba's own, once per process and root; ()
    when this numba has no locator list where they can go."""
    impl = getattr(caching, "CacheImpl", None) or getattr(caching, "_CacheImpl", None)
    names = ("UserProvidedCacheLocator", "InTreeCacheLocator", "UserWideCacheLocator")
    bases = [getattr(caching, n, None) or getattr(caching, "_" + n, None) for n in names]
    if impl is None or not isinstance(getattr(impl, "_locator_classes", None), list) or None in bases:
        return ()
    root = Path(root).resolve()
    present = tuple(c for c in impl._locator_classes if getattr(c, "package_root", None) == root)
    if present:
        return present
    ours = tuple(_package_locator(b, root) for b in bases)
    impl._locator_classes = [*ours, *impl._locator_classes]
    return ours


_LOCATORS = install_locators()

#: True when rule 3 holds in this process: kernels calling other modules' kernels may use the disk cache
CACHE: bool = bool(_LOCATORS)


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
    outside = sorted(f"{k.py_func.__module__}.{k.py_func.__name__} is cached outside the package's locators"
                     for k in kernels.values()
                     if CACHE and _is_cached(k) and _under(k.py_func.__code__.co_filename, _ROOT)
                     and not isinstance(k._cache._impl.locator, _LOCATORS))
    return fast + [f"{k} <- {', '.join(sorted(v))}" for k, v in sorted(bad.items())] + outside

"""Migration guard: filter outputs and short run histories are bit-identical to those computed before the
code moved into its present rooms (``pinned_digests.json``, see :mod:`tests.regression.digests`).

The digests once depended on what numba's on-disk cache held when a kernel was compiled or loaded;
:mod:`objectives.jit` states the two rules that remove the dependence, :func:`test_kernel_rules` holds
both packages to them and :func:`test_digests_do_not_depend_on_the_cache` checks the outcome. A refactoring
that changes one of these digests changed a result, not only where code lives. The digests are of float64
bytes from numba kernels, so they hold for the platform they were computed on (x86-64 Linux, the CI
machine); a change of numba or NumPy version that changes rounding shows up here too. The run histories
also go through OpenBLAS, whose kernels depend on the CPU; they are computed under its Haswell kernels.
The filters without ``fastmath`` (Madgwick, Mahony, complementary and UKF kernels, see objectives.jit) were
re-pinned then.
"""

from __future__ import annotations

import importlib
import json
import os
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

from objectives.jit import package_modules, rule_violations
from tests.regression.digests import FILTER_CASES, PINNED, filter_digests

EXPECTED = json.loads(PINNED.read_text())


def test_every_case_is_pinned():
    assert set(EXPECTED["filters"]) == {label for label, *_ in FILTER_CASES}


def test_filter_outputs_bit_identical():
    got = filter_digests()
    changed = {k: (EXPECTED["filters"][k], v) for k, v in got.items() if EXPECTED["filters"][k] != v}
    assert not changed, f"filter outputs changed (pinned, now): {changed}"


@pytest.mark.slow
def test_digests_do_not_depend_on_the_cache():
    """A child process that loads the kernels from the on-disk cache this suite filled (NUMBA_CACHE_DIR, as CI
    and the Makefile set it; compiling what is not there yet) gives the bits this process computed (before the
    rules of objectives.jit, five robust kernels did not)."""
    here = filter_digests()
    code = "import json; from tests.regression.digests import filter_digests; print(json.dumps(filter_digests()))"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=900,
                         cwd=PINNED.parents[2])
    assert out.returncode == 0, out.stderr
    assert json.loads(out.stdout.strip().splitlines()[-1]) == here == EXPECTED["filters"]


def test_kernel_rules():
    """No kernel uses fastmath and none calls a cached, not-inlined kernel (objectives.jit)."""
    assert rule_violations(package_modules("objectives", "tuner")) == []


def test_rules_find_their_breaches(tmp_path, monkeypatch):
    """The finder is not blind: fastmath and a cached function called by another kernel are reported."""
    (tmp_path / "cache_rule_probe.py").write_text(textwrap.dedent("""
        from numba import njit

        @njit(cache=True)
        def leaf(x):
            return x + 1.0

        @njit(inline="always")
        def inlined(x):
            return x * 2.0

        @njit(fastmath=True)
        def caller(x):
            return leaf(inlined(x))
    """))
    monkeypatch.syspath_prepend(str(tmp_path))
    mod = importlib.import_module("cache_rule_probe")
    assert rule_violations([mod]) == ["cache_rule_probe.caller uses fastmath", "cache_rule_probe.leaf <- caller"]


_STALE_PROBE = """
import sys
from pathlib import Path
if sys.argv[2] == "package":
    from objectives.jit import install_locators
    assert install_locators(Path(sys.argv[1]) / "pkg")
sys.path.insert(0, sys.argv[1])
from pkg.caller import g
print(g(1.0))
"""


@pytest.mark.parametrize("locators", ["numba", "package"])
@pytest.mark.slow
def test_an_edited_callee_reaches_its_cached_caller_under_the_package_locators(tmp_path, locators):
    """Rule 3: numba keys a cache entry on the caller's own file, so a cached kernel kept running the old body
    of a kernel it calls from another module (shown with numba's locators); under the package's locators
    the entry is keyed on every source of the package and the edit is seen."""
    pkg = tmp_path / "pkg"
    pkg.mkdir()
    (pkg / "__init__.py").write_text("")
    (pkg / "callee.py").write_text("from numba import njit\n\n@njit\ndef f(x):\n    return x + 1.0\n")
    (pkg / "caller.py").write_text("from numba import njit\nfrom pkg.callee import f\n\n"
                                   "@njit(cache=True)\ndef g(x):\n    return f(x)\n")
    env = {**os.environ, "NUMBA_CACHE_DIR": str(tmp_path / "cache")}

    def g_of_one() -> float:
        out = subprocess.run([sys.executable, "-c", _STALE_PROBE, str(tmp_path), locators], capture_output=True,
                             text=True, env=env, cwd=PINNED.parents[2], timeout=300)
        assert out.returncode == 0, out.stderr
        return float(out.stdout.split()[-1])

    assert g_of_one() == 2.0
    assert any((tmp_path / "cache").rglob("*.nbi"))  # the caller was cached
    (pkg / "callee.py").write_text("from numba import njit\n\n@njit\ndef f(x):\n    return x + 2.0\n")
    assert g_of_one() == (3.0 if locators == "package" else 2.0)


def test_the_package_kernels_are_cached_under_the_package_locators():
    """Every cached kernel of the package, the cross-module population and closed-loop kernels among them,
    uses rule 3's locators (a kernel module imported before them would not; rule_violations reports it)."""
    from objectives.attitude.filters.madgwick import population
    from objectives.control.plants.wmp import batch as control_batch
    from objectives.control.plants.wmp import model as wmp
    from objectives.jit import CACHE, package_digest

    assert CACHE
    for k in (population._population, control_batch._closed_loop_batch, wmp._simulate):
        stamp = k._cache._impl.locator.get_source_stamp()
        assert type(k._cache._impl.locator).__name__.startswith("Package") and stamp[1] == package_digest()


def _has_avx2() -> bool:
    try:
        return " avx2 " in Path("/proc/cpuinfo").read_text()
    except OSError:
        return False


@pytest.mark.slow
@pytest.mark.skipif(not _has_avx2(), reason="the pinned histories need OpenBLAS's Haswell kernels (x86-64 with AVX2)")
def test_run_histories_bit_identical(tmp_path):
    """Computed in a child with ``OPENBLAS_CORETYPE=Haswell``: OpenBLAS picks its kernels by CPU (SkylakeX on an
    AVX-512 Intel, Haswell on AVX2 and on AMD Zen), and the EKF's, CMA-ES's and the trust region's small
    solves round differently under each, so the same code gives other histories on another CPU family.
    Pinning the kernel family makes the guard about the code, not about the machine it runs on."""
    code = ("import json, sys; from pathlib import Path; from tests.regression.digests import run_digests; "
            "print(json.dumps(run_digests(Path(sys.argv[1]))))")
    env = {**os.environ, "OPENBLAS_CORETYPE": "Haswell"}
    out = subprocess.run([sys.executable, "-c", code, str(tmp_path)], capture_output=True, text=True,
                         timeout=900, cwd=PINNED.parents[2], env=env)
    assert out.returncode == 0, out.stderr
    got = json.loads(out.stdout.strip().splitlines()[-1])
    changed = {k: (EXPECTED["runs"][k], v) for k, v in got.items() if EXPECTED["runs"][k] != v}
    assert not changed, f"run histories changed (pinned, now): {changed}"

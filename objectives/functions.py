"""Standard test functions for the engine itself (vectorised numpy), selectable in YAML::

    objective: {kind: function, function: rosenbrock, dim: 10}

Each is defined on its usual box (the default search space ``x0 .. x{dim-1}``) with a known minimum
of 0. They let the demo and the tests exercise optimisers, parallel evaluation and resume without
any domain code.
"""

from __future__ import annotations

import math
import time
import zlib
from dataclasses import dataclass
from typing import Any

import numpy as np

from tuner.deployment import Deployment, build_deployment
from tuner.objective import Evaluation
from tuner.space import Real, Space

__all__ = ["FUNCTIONS", "FunctionObjective", "sphere", "rosenbrock", "rastrigin", "ackley"]


def sphere(x: np.ndarray) -> np.ndarray:
    """sum x_i^2; minimum 0 at 0. Works on (d,) or (n, d)."""
    x = np.asarray(x, float)
    return np.sum(x * x, axis=-1)


def rosenbrock(x: np.ndarray) -> np.ndarray:
    """sum 100 (x_{i+1} - x_i^2)^2 + (1 - x_i)^2; minimum 0 at 1."""
    x = np.asarray(x, float)
    return np.sum(100.0 * (x[..., 1:] - x[..., :-1] ** 2) ** 2 + (1.0 - x[..., :-1]) ** 2, axis=-1)


def rastrigin(x: np.ndarray) -> np.ndarray:
    """10 d + sum x_i^2 - 10 cos(2 pi x_i); minimum 0 at 0."""
    x = np.asarray(x, float)
    return 10.0 * x.shape[-1] + np.sum(x * x - 10.0 * np.cos(2.0 * math.pi * x), axis=-1)


def ackley(x: np.ndarray) -> np.ndarray:
    """-20 exp(-0.2 sqrt(mean x^2)) - exp(mean cos 2 pi x) + 20 + e; minimum 0 at 0."""
    x = np.asarray(x, float)
    a = -20.0 * np.exp(-0.2 * np.sqrt(np.mean(x * x, axis=-1)))
    b = -np.exp(np.mean(np.cos(2.0 * math.pi * x), axis=-1))
    return a + b + 20.0 + math.e


#: name -> (function, default box)
FUNCTIONS: dict[str, tuple[Any, tuple[float, float]]] = {
    "sphere": (sphere, (-5.12, 5.12)),
    "rosenbrock": (rosenbrock, (-5.0, 10.0)),
    "rastrigin": (rastrigin, (-5.12, 5.12)),
    "ackley": (ackley, (-32.768, 32.768)),
}


@dataclass(frozen=True)
class FunctionObjective:
    """A test function as an objective over parameters ``x0 .. x{dim-1}``.

    ``sleep_s`` adds a fixed delay per evaluation (to measure parallel speed-up); ``fail_every``
    makes every k-th point (by a hash of the point, so it is backend independent) raise, and
    ``nan_every`` return NaN — both to test that failures are recorded and the run goes on.
    """

    function: str = "sphere"
    dim: int = 2
    sleep_s: float = 0.0
    busy_s: float = 0.0
    fail_every: int = 0
    nan_every: int = 0

    @classmethod
    def from_config(cls, section: dict[str, Any], base_dir: Any = None) -> FunctionObjective:
        allowed = {"kind", "function", "dim", "sleep_s", "busy_s", "fail_every", "nan_every"}
        unknown = sorted(set(section) - allowed)
        if unknown:
            raise ValueError(f"objective.{unknown[0]}: unknown key; allowed: {sorted(allowed - {'kind'})}")
        fn = section.get("function", "sphere")
        if fn not in FUNCTIONS:
            raise ValueError(f"objective.function: unknown function {fn!r}; allowed: {sorted(FUNCTIONS)}")
        dim = section.get("dim", 2)
        if isinstance(dim, bool) or not isinstance(dim, int) or not 1 <= dim <= 10_000:
            raise ValueError(f"objective.dim: expected an integer in [1, 10000], got {dim!r}")
        return cls(fn, dim, float(section.get("sleep_s", 0.0)), float(section.get("busy_s", 0.0)),
                   int(section.get("fail_every", 0)), int(section.get("nan_every", 0)))

    @classmethod
    def catalog(cls) -> dict[str, list[str]]:
        """Names ``objective.function`` accepts (``tuner list functions``)."""
        return {"functions": sorted(FUNCTIONS)}

    @classmethod
    def explain(cls, name: str) -> dict[str, Any] | None:
        """``tuner describe NAME`` for a test function (its search box per coordinate)."""
        if name not in FUNCTIONS:
            return None
        fn, (lo, hi) = FUNCTIONS[name][0], FUNCTIONS[name][1]
        doc = (fn.__doc__ or "").strip().splitlines()
        return {"section": "functions", "name": name, "summary": doc[0] if doc else name,
                "usage": f"objective: {{kind: function, function: {name}, dim: 2}}",
                "params": [{"name": "x<i>", "default": None, "bounds": (float(lo), float(hi)), "scale": "linear",
                            "unit": "", "doc": "coordinate i of dim", "eq": ""}]}

    def parameter_names(self) -> list[str]:
        return [f"x{i}" for i in range(self.dim)]

    def describe(self) -> dict[str, Any]:
        """Provenance for ``tuner export``."""
        return {"objective": {"kind": "function", "function": self.function}, "data": None}

    def deployment(self, params: dict[str, Any]) -> Deployment:
        """The point itself: a test function has nothing else to deploy."""
        values = {f"x{i}": float(params[f"x{i}"]) for i in range(self.dim)}
        return build_deployment("function", self.function, values, searched=values, scoring={"dim": self.dim})

    def build(self, params: dict[str, Any]) -> np.ndarray:
        """The point as a (dim,) array."""
        return np.array([float(params[f"x{i}"]) for i in range(self.dim)])

    def default_space(self) -> Space:
        lo, hi = FUNCTIONS[self.function][1]
        return Space(Real(f"x{i}", lo, hi) for i in range(self.dim))

    def __call__(self, params: dict[str, Any]) -> Evaluation:
        x = np.array([params[f"x{i}"] for i in range(self.dim)], dtype=float)
        if self.sleep_s:
            time.sleep(self.sleep_s)
        if self.busy_s:  # burn CPU (a stand-in for a numerical kernel)
            t_end = time.perf_counter() + self.busy_s
            while time.perf_counter() < t_end:
                pass
        key = zlib.crc32(x.tobytes())  # stable across processes (unlike hash())
        if self.fail_every and key % self.fail_every == 0:
            raise RuntimeError(f"synthetic failure at x={x.round(3).tolist()}")
        if self.nan_every and key % self.nan_every == 1:
            return Evaluation(float("nan"), {})
        f = float(FUNCTIONS[self.function][0](x))
        return Evaluation(f, {"norm_x": float(np.linalg.norm(x))})

"""The constrained optimum of each PID benchmark problem (:mod:`benchmarks.pid_plants`), by an independent
dense global search; stored in ``benchmarks/results/pid_optimum.json`` with its method.

Independent of tuner's loop code (no kernel, no frequency response, no margin code of ``objectives``): the
plant is discretised with ``scipy.signal.cont2discrete`` (ZOH) as polynomials in ``z`` with the delay as
``z^-d``; the PID of the problem is the rational ``C(z) = K + ki / (z - 1) + bd (z - 1) / (z - ad)``
(``ki = K h / Ti``, ``ad = Td / (Td + N h)``, ``bd = K Td N / (Td + N h)``: forward-Euler integral,
backward-difference filtered derivative, the measurement's path); the load response is
``y = P / (1 + C P)`` of a unit step, computed with ``scipy.signal.lfilter`` over the problem's samples,
``IAE = h sum |y|``; stability is ``max |root| < 1`` of the closed-loop characteristic polynomial
(``numpy.roots``); ``Ms = max |1 / (1 + C P)|`` over a log grid.

Method, per plant:

1. **grid**: :data:`GRID` log-spaced values of each of K, Ti, Td over the box (``GRID^3`` controllers); Ms on
   :data:`N_COARSE` frequencies for all, IAE and stability where that Ms is below ``MS_MAX + 0.05``;
2. **local**: from the :data:`N_STARTS` best feasible grid controllers in distinct grid cells, SLSQP on
   ``log (K, Ti, Td)`` minimising the IAE subject to ``Ms <= MS_MAX`` on :data:`N_DENSE` frequencies, each
   result polished by the same solve from its own point;
3. **optimum**: the lowest IAE among the stable local results whose Ms (:data:`N_DENSE` frequencies up to
   Nyquist, each of the three highest peaks zoomed three times on 33 points) is at most ``MS_MAX + 1e-9``.

``python -m benchmarks.pid_optimum`` recomputes every plant (about a minute each on one core).
"""

from __future__ import annotations

import json
import math
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from benchmarks.pid_plants import MS_MAX, N_FILTER, PLANTS, box, continuous, scale

__all__ = ["Problem", "optimum", "load_optimum", "compute_all", "OPTIMUM_FILE", "GRID", "N_DENSE"]

OPTIMUM_FILE = Path(__file__).resolve().parent / "results" / "pid_optimum.json"
GRID = 36
N_COARSE = 1500
N_DENSE = 100_000
N_STARTS = 6


class Problem:
    """One plant's problem in polynomial form (module docstring)."""

    def __init__(self, name: str, ms_max: float = MS_MAX, plant: tuple | None = None):
        from scipy.signal import cont2discrete

        num, den, delay = plant or continuous(name)
        self.name, self.ms_max = name, ms_max
        self.h, dur = scale(name)
        self.n = int(round(dur / self.h))
        self.d = int(round(delay / self.h))
        numd, dend, _ = cont2discrete((np.asarray(num, float), np.asarray(den, float)), self.h, method="zoh")
        pn = np.trim_zeros(np.ravel(numd), "f")
        pn[np.abs(pn) < 1e-15 * np.max(np.abs(pn))] = 0.0
        self.pn = np.trim_zeros(pn, "f")
        self.pd = np.polymul(np.ravel(dend), np.r_[1.0, np.zeros(self.d)])  # z^d: the input delay
        self.box = box(name)
        wn = math.pi / self.h
        self.w_coarse = np.logspace(math.log10(1e-4 * wn), math.log10(wn), N_COARSE)
        self.w_dense = np.logspace(math.log10(1e-4 * wn), math.log10(wn), N_DENSE)
        self._p_coarse = self.plant_response(self.w_coarse)
        self._p_dense = self.plant_response(self.w_dense)

    def plant_response(self, w: np.ndarray) -> np.ndarray:
        z = np.exp(1j * w * self.h)
        return np.polyval(self.pn, z) / np.polyval(self.pd, z)

    def pid(self, p: np.ndarray) -> tuple[float, float, float]:
        """``(K, ki, ad, bd)`` of ``p = (K, Ti, Td)``."""
        K, Ti, Td = (float(x) for x in p)
        h, N = self.h, N_FILTER
        return K, K * h / Ti, Td / (Td + N * h), K * Td * N / (Td + N * h)

    def controller(self, p: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``C(z)`` as (numerator, denominator) polynomials in z."""
        K, ki, ad, bd = self.pid(p)
        cd = np.polymul([1.0, -1.0], [1.0, -ad])
        cn = np.polyadd(np.polyadd(K * cd, ki * np.array([1.0, -ad])), bd * np.array([1.0, -2.0, 1.0]))
        return cn, cd

    def _characteristic(self, p: np.ndarray) -> np.ndarray:
        cn, cd = self.controller(p)
        return np.polyadd(np.polymul(self.pd, cd), np.polymul(self.pn, cn))

    def stable(self, p: np.ndarray) -> bool:
        """Whether the closed loop of ``p`` is stable (every root of its characteristic polynomial inside the
        unit circle)."""
        return bool(np.max(np.abs(np.roots(self._characteristic(p)))) < 1.0)

    def iae(self, p: np.ndarray) -> float:
        """The IAE of the load step (inf for an unstable loop)."""
        from scipy.signal import lfilter

        cn, cd = self.controller(p)
        a = self._characteristic(p)
        if not self.stable(p):
            return math.inf
        b = np.polymul(self.pn, cd)
        b = np.r_[np.zeros(a.size - b.size), b]
        y = lfilter(b, a, np.ones(self.n))
        return float(self.h * np.sum(np.abs(y)))

    def _s(self, p: np.ndarray, pr: np.ndarray, w: np.ndarray) -> np.ndarray:
        K, ki, ad, bd = self.pid(p)
        z = np.exp(1j * w * self.h)
        return 1.0 / np.abs(1.0 + (K + ki / (z - 1.0) + bd * (z - 1.0) / (z - ad)) * pr)

    def ms_loop(self, p: np.ndarray) -> float:
        """:meth:`ms` of a stable loop, inf for an unstable one (whose sensitivity peak says nothing)."""
        return self.ms(p) if self.stable(p) else math.inf

    def ms(self, p: np.ndarray) -> float:
        """Ms on :data:`N_DENSE` frequencies, its three highest peaks zoomed (module docstring)."""
        s = self._s(p, self._p_dense, self.w_dense)
        peaks = np.flatnonzero((s[1:-1] >= s[:-2]) & (s[1:-1] >= s[2:])) + 1
        peaks = np.r_[peaks, s.size - 1][np.argsort(-np.r_[s[peaks], s[-1]])][:3]
        best = float(np.max(s))
        for i in peaks:
            lo, hi = self.w_dense[max(i - 1, 0)], self.w_dense[min(i + 1, s.size - 1)]
            for _ in range(3):
                w = np.geomspace(lo, hi, 33)
                v = self._s(p, self.plant_response(w), w)
                j = int(np.argmax(v))
                best = max(best, float(v[j]))
                lo, hi = w[max(j - 1, 0)], w[min(j + 1, 32)]
        return best

    def ms_coarse(self, P: np.ndarray) -> np.ndarray:
        """Ms on :data:`N_COARSE` frequencies of every row of ``P`` (n, 3), vectorised."""
        out = np.empty(P.shape[0])
        z = np.exp(1j * self.w_coarse * self.h)
        for i in range(0, P.shape[0], 1000):
            q = P[i:i + 1000]
            K, Ti, Td = q[:, :1], q[:, 1:2], q[:, 2:3]
            h, N = self.h, N_FILTER
            c = K + (K * h / Ti) / (z - 1.0) + (K * Td * N / (Td + N * h)) * (z - 1.0) / (z - Td / (Td + N * h))
            out[i:i + 1000] = np.max(1.0 / np.abs(1.0 + c * self._p_coarse), axis=1)
        return out

    def encode(self, p: np.ndarray) -> np.ndarray:
        lo = np.log([self.box[k][0] for k in ("K", "Ti_s", "Td_s")])
        hi = np.log([self.box[k][1] for k in ("K", "Ti_s", "Td_s")])
        return (np.log(p) - lo) / (hi - lo)

    def decode(self, u: np.ndarray) -> np.ndarray:
        lo = np.log([self.box[k][0] for k in ("K", "Ti_s", "Td_s")])
        hi = np.log([self.box[k][1] for k in ("K", "Ti_s", "Td_s")])
        return np.exp(lo + np.clip(u, 0.0, 1.0) * (hi - lo))


def _grid(pb: Problem) -> list[tuple[float, np.ndarray, tuple[int, int, int]]]:
    """Step 1: the feasible grid controllers ``(iae, p, cell)``, best first."""
    axes = np.linspace(0.0, 1.0, GRID)
    U = np.stack(np.meshgrid(axes, axes, axes, indexing="ij"), axis=-1).reshape(-1, 3)
    P = pb.decode(U)
    ms = pb.ms_coarse(P)
    out = []
    for i in np.flatnonzero(ms <= pb.ms_max + 0.05):
        f = pb.iae(P[i])
        if math.isfinite(f) and ms[i] <= pb.ms_max:
            out.append((f, P[i], tuple(int(x) for x in np.unravel_index(i, (GRID,) * 3))))
    out.sort(key=lambda t: t[0])
    return out


def _slsqp(pb: Problem, p0: np.ndarray) -> np.ndarray:
    from scipy.optimize import minimize

    def f(u):
        v = pb.iae(pb.decode(u))
        return v if math.isfinite(v) else 1e6

    cons = {"type": "ineq", "fun": lambda u: pb.ms_max - pb.ms(pb.decode(u))}
    r = minimize(f, pb.encode(p0), method="SLSQP", bounds=[(0.0, 1.0)] * 3, constraints=[cons],
                 options={"maxiter": 200, "ftol": 1e-12, "eps": 1e-7})
    return pb.decode(r.x)


@dataclass(frozen=True)
class Optimum:
    name: str
    K: float
    Ti_s: float
    Td_s: float
    iae: float
    ms: float
    grid_best_iae: float
    seconds: float

    def params(self) -> dict[str, float]:
        return {"K": self.K, "Ti_s": self.Ti_s, "Td_s": self.Td_s}


def optimum(name: str, ms_max: float = MS_MAX) -> Optimum:
    """Steps 1-3 of the module docstring for plant ``name``."""
    t0 = time.process_time()
    pb = Problem(name, ms_max)
    grid = _grid(pb)
    starts, cells = [], []
    for _f, p, cell in grid:
        if all(max(abs(a - b) for a, b in zip(cell, c)) > 2 for c in cells):
            starts.append(p)
            cells.append(cell)
        if len(starts) == N_STARTS:
            break
    best: tuple[float, np.ndarray, float] | None = None
    for p0 in starts:
        p = _slsqp(pb, _slsqp(pb, p0))
        for q in (p, p0):
            ms = pb.ms(q)
            f = pb.iae(q)
            if ms <= pb.ms_max + 1e-9 and math.isfinite(f) and (best is None or f < best[0]):
                best = (f, q, ms)
    if best is None:
        raise RuntimeError(f"{name}: no feasible controller found")
    f, p, ms = best
    return Optimum(name, float(p[0]), float(p[1]), float(p[2]), f, ms, grid[0][0], time.process_time() - t0)


def compute_all(names: list[str] | None = None, path: Path = OPTIMUM_FILE) -> dict[str, Any]:
    """Every plant's optimum, written to ``path`` with the method (this module's docstring)."""
    out = {"method": (__doc__ or "").split("\n\n", 1)[1].strip(), "ms_max": MS_MAX, "grid": GRID,
           "n_dense": N_DENSE, "plants": {}}
    for name in names or list(PLANTS):
        o = optimum(name)
        out["plants"][name] = {**o.params(), "iae": o.iae, "ms": o.ms, "grid_best_iae": o.grid_best_iae,
                               "cpu_s": round(o.seconds, 1)}
        print(f"{name}: IAE {o.iae:.6g} (grid {o.grid_best_iae:.6g}), Ms {o.ms:.6f}, {o.params()}, "
              f"{o.seconds:.0f} s", flush=True)
    path.write_text(json.dumps(out, indent=1) + "\n")
    return out


def load_optimum(path: Path = OPTIMUM_FILE) -> dict[str, Any]:
    """The stored optima (``compute_all``'s document)."""
    return json.loads(path.read_text())


if __name__ == "__main__":
    import sys

    compute_all(sys.argv[1:] or None)

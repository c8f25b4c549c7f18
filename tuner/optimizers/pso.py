"""Particle swarm optimisation, as the seed papers use it, with the options users expect.

Velocity and position update (thesis eq. 2.40-2.41; the FAEKF paper section 5.2)::

    V <- w V + c1 r1 (P - X) + c2 r2 (G - X)
    X <- X + V

with ``r1, r2 ~ U(0, 1)`` drawn per particle and dimension, ``P`` each particle's best position and
``G`` the best position of its neighbourhood (the whole swarm for ``topology: global``). The seed
defaults are ``w = 0.9``, ``c1 = 0.5``, ``c2 = 1.5`` (thesis section 2.4).

Presets
-------
``preset`` picks a coherent set of defaults; any option given explicitly overrides it.

``paper`` (the default, so recorded histories replay unchanged)
    The seed papers: ``w = 0.9`` constant, ``c1 = 0.5``, ``c2 = 1.5``, uniform start, ``v_max = 0.5``.
``lowbudget``
    For a few hundred evaluations: inertia falling linearly 0.7 -> 0.3 over the run, ``c1 = c2 = 1.5``,
    Latin-hypercube start, ``v_max = 0.2``. Chosen among constriction, SPSO-2011 coefficients and
    linear-inertia variants on sphere/Rosenbrock/Rastrigin/Ackley in 5-D at 300 evaluations
    (population 20, median of 10 seeds): sphere 0.013 against 0.78 with ``paper`` (see
    ``benchmarks/results/auto_rules.md``). Needs ``generations`` or ``max_evals``.
``clerc``
    Clerc's constriction ``chi = 0.7298`` with ``c1 = c2 = 2.05`` (phi = 4.1), Latin-hypercube start.
``spso2011``
    The SPSO-2011 coefficients ``w = 1 / (2 ln 2) = 0.7213``, ``c1 = c2 = 0.5 + ln 2 = 1.1931`` with a
    Latin-hypercube start and the global topology (only the coefficients of SPSO-2011; its random
    adaptive topology and hyperspherical sampling are not implemented).

Everything happens in the unit cube, so ``v_max`` is a fraction of each parameter's range.
"""

from __future__ import annotations

import math
from typing import Any, Literal

import numpy as np

from tuner.optimizers.base import Optimizer, OptionError, latin_hypercube

__all__ = ["PSO", "PRESETS"]

#: Named default sets (see the module docstring); explicit options override them.
PRESETS: dict[str, dict[str, Any]] = {
    "paper": dict(w=0.9, w_end=0.4, inertia="constant", c1=0.5, c2=1.5, constriction=False, topology="global",
                  v_max=0.5, init="uniform", v_init=0.1),
    "lowbudget": dict(w=0.7, w_end=0.3, inertia="linear", c1=1.5, c2=1.5, constriction=False, topology="global",
                      v_max=0.2, init="lhs", v_init=0.1),
    "clerc": dict(w=0.9, w_end=0.4, inertia="constant", c1=2.05, c2=2.05, constriction=True, topology="global",
                  v_max=0.5, init="lhs", v_init=0.1),
    "spso2011": dict(w=1.0 / (2.0 * math.log(2.0)), w_end=0.4, inertia="constant", c1=0.5 + math.log(2.0),
                     c2=0.5 + math.log(2.0), constriction=False, topology="global", v_max=0.5, init="lhs",
                     v_init=0.1),
}


class PSO(Optimizer):
    """Particle swarm optimiser (ask/tell).

    Parameters
    ----------
    preset : {"paper", "lowbudget", "clerc", "spso2011"}
        Named defaults for the options below (module docstring); options given explicitly win.
        The defaults quoted below are those of ``paper``.
    w : float
        Inertia weight (the start value when ``inertia: linear``). Seed default 0.9.
    w_end : float
        Final inertia of the linearly decreasing schedule (``inertia: linear``), reached at the last
        generation. Default 0.4 (Shi & Eberhart).
    inertia : {"constant", "linear"}
        Inertia schedule. ``linear`` spans ``generations`` (or ``max_evals / population`` without it).
    c1, c2 : float
        Cognitive and social coefficients. Seed defaults 0.5 and 1.5.
    constriction : bool
        Clerc's constriction: ``V <- chi (V + c1 r1 (P - X) + c2 r2 (G - X))`` with
        ``chi = 2 / |2 - phi - sqrt(phi^2 - 4 phi)|``, ``phi = c1 + c2 > 4``; ``w`` is then ignored.
        Use e.g. ``c1 = c2 = 2.05`` (chi = 0.7298).
    topology : {"global", "ring"}
        Neighbourhood of the social term: the whole swarm, or each particle and its ``neighbors``
        nearest indices on each side (lbest ring).
    neighbors : int
        Ring half-width (default 1).
    v_max : float
        Velocity clamp per dimension, as a fraction of the unit range (default 0.5; ``1`` means none).
    boundary : {"reflect", "clip", "random"}
        What a particle leaving the cube does: mirror back in (and reverse that velocity
        component), stop at the bound (velocity component set to 0), or be re-drawn uniformly in
        that dimension (velocity component set to 0).
    init : {"uniform", "lhs"}
        Initial positions: uniform random or Latin hypercube.
    v_init : float
        Initial velocities are uniform in ``[-v_init, v_init]`` (fraction of the range; 0 = at rest).
    init_spread : float
        With a warm start ``x0``: particle 0 starts at ``x0`` and the others uniformly within
        ``x0 +- init_spread / 2`` (clipped to the cube); ``1`` keeps them anywhere in the cube.
    """

    name = "pso"

    def __init__(
        self,
        dim: int,
        rng: np.random.Generator,
        *,
        preset: str = "paper",
        w: float | None = None,
        w_end: float | None = None,
        inertia: Literal["constant", "linear"] | None = None,
        c1: float | None = None,
        c2: float | None = None,
        constriction: bool | None = None,
        topology: Literal["global", "ring"] | None = None,
        neighbors: int = 1,
        v_max: float | None = None,
        boundary: Literal["reflect", "clip", "random"] = "reflect",
        init: Literal["uniform", "lhs"] | None = None,
        v_init: float | None = None,
        init_spread: float = 1.0,
        **common: Any,
    ):
        super().__init__(dim, rng, **common)
        if preset not in PRESETS:
            raise OptionError(f"preset must be one of {sorted(PRESETS)}, got {preset!r}")
        given = dict(w=w, w_end=w_end, inertia=inertia, c1=c1, c2=c2, constriction=constriction, topology=topology,
                     v_max=v_max, init=init, v_init=v_init)
        opts = {k: (PRESETS[preset][k] if v is None else v) for k, v in given.items()}
        w, w_end, inertia, c1, c2 = opts["w"], opts["w_end"], opts["inertia"], opts["c1"], opts["c2"]
        constriction, topology, v_max, init, v_init = (opts["constriction"], opts["topology"], opts["v_max"],
                                                       opts["init"], opts["v_init"])
        self.preset = preset
        if inertia not in ("constant", "linear"):
            raise OptionError(f"inertia must be 'constant' or 'linear', got {inertia!r}")
        if inertia == "linear" and self.generations is None and self.max_evals is None:
            raise OptionError(f"inertia: linear (preset {preset!r}) needs a generations or max_evals budget")
        if topology not in ("global", "ring"):
            raise OptionError(f"topology must be 'global' or 'ring', got {topology!r}")
        if boundary not in ("reflect", "clip", "random"):
            raise OptionError(f"boundary must be 'reflect', 'clip' or 'random', got {boundary!r}")
        if init not in ("uniform", "lhs"):
            raise OptionError(f"init must be 'uniform' or 'lhs', got {init!r}")
        if not 0 < v_max <= 1:
            raise OptionError(f"v_max must be in (0, 1] (fraction of the range), got {v_max}")
        if c1 < 0 or c2 < 0:
            raise OptionError(f"c1 and c2 must be >= 0, got c1={c1}, c2={c2}")
        if constriction and c1 + c2 <= 4:
            raise OptionError(f"constriction needs c1 + c2 > 4, got {c1 + c2} (try c1 = c2 = 2.05)")
        if topology == "ring" and not 1 <= int(neighbors) < max(2, self.population):
            raise OptionError(f"neighbors must be in [1, population), got {neighbors}")
        self.w, self.w_end, self.inertia = float(w), float(w_end), inertia
        self.c1, self.c2 = float(c1), float(c2)
        self.constriction = bool(constriction)
        self.chi = 1.0
        if self.constriction:
            phi = self.c1 + self.c2
            self.chi = 2.0 / abs(2.0 - phi - math.sqrt(phi * phi - 4.0 * phi))
        self.topology, self.neighbors = topology, int(neighbors)
        self.v_max, self.boundary = float(v_max), boundary
        n, d = self.population, self.dim
        self.X = latin_hypercube(rng, n, d) if init == "lhs" else rng.random((n, d))
        if self.x0 is not None:
            if init_spread < 1.0:
                lo = np.clip(self.x0 - init_spread / 2, 0, 1)
                hi = np.clip(self.x0 + init_spread / 2, 0, 1)
                self.X = lo + self.X * (hi - lo)
            self.X[0] = self.x0
        self.V = rng.uniform(-v_init, v_init, (n, d)) if v_init > 0 else np.zeros((n, d))
        self.P = self.X.copy()
        self.Pf = np.full(n, np.inf)

    def current_inertia(self) -> float:
        """Inertia of this generation; the linear schedule spans ``generations`` (else ``max_evals / population``)."""
        horizon = self.generations
        if horizon is None and self.max_evals is not None:
            horizon = math.ceil(self.max_evals / self.population)
        if self.inertia == "constant" or not horizon or horizon < 2:
            return self.w
        frac = min(1.0, self.generation / (horizon - 1))
        return self.w + (self.w_end - self.w) * frac

    def ask(self) -> np.ndarray:
        return self.X.copy()

    def _neighbourhood_best(self) -> np.ndarray:
        if self.topology == "global":
            return np.broadcast_to(self.P[int(np.argmin(self.Pf))], self.P.shape)
        n, k = self.population, self.neighbors
        idx = (np.arange(n)[:, None] + np.arange(-k, k + 1)[None, :]) % n
        best = idx[np.arange(n), np.argmin(self.Pf[idx], axis=1)]
        return self.P[best]

    def _tell(self, x: np.ndarray, f: np.ndarray) -> None:
        if x.shape != self.X.shape:
            raise ValueError(f"PSO.tell expects the {self.X.shape} swarm from ask(), got {x.shape}")
        better = f < self.Pf
        self.P[better] = x[better]
        self.Pf[better] = f[better]
        G = self._neighbourhood_best()
        n, d = self.X.shape
        r1 = self.rng.random((n, d))
        r2 = self.rng.random((n, d))
        pull = self.c1 * r1 * (self.P - x) + self.c2 * r2 * (G - x)
        if self.constriction:
            V = self.chi * (self.V + pull)
        else:
            V = self.current_inertia() * self.V + pull
        np.clip(V, -self.v_max, self.v_max, out=V)
        X = x + V
        self.X, self.V = self._bound(X, V)

    def _bound(self, X: np.ndarray, V: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        out = (X < 0.0) | (X > 1.0)
        if not out.any():
            return X, V
        if self.boundary == "clip":
            X = np.clip(X, 0.0, 1.0)
            V[out] = 0.0
        elif self.boundary == "reflect":
            # mirror into [0, 1]; folding handles excursions beyond one width
            Y = np.mod(X, 2.0)
            X = np.where(Y > 1.0, 2.0 - Y, Y)
            V[out] = -V[out]
        else:  # random re-initialisation of the offending components
            X = X.copy()
            X[out] = self.rng.random(int(out.sum()))
            V[out] = 0.0
        return X, V

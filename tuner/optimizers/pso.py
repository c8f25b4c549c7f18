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

from tuner.optimizers.base import AT_LEAST_1, Optimizer, OptionError, declare, latin_hypercube
from tuner.params import ANY_REAL, NONNEG, Interval, Param

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


_PAPER = PRESETS["paper"]
_FROM_PRESET = "Unset: the preset's value (the default shown is paper's)."


class PSO(Optimizer):
    """Particle swarm optimiser (ask/tell).

    Its options are declared in :attr:`PSO.options` (``tuner describe pso``); those a preset sets
    (``w``, ``w_end``, ``inertia``, ``c1``, ``c2``, ``constriction``, ``topology``, ``v_max``, ``init``,
    ``v_init``) take the preset's value when left unset (``None``), and their declared default is paper's.
    """

    name = "pso"
    options = declare("pso", (
        Param("preset", "paper", choices=tuple(PRESETS),
              doc="Named defaults for the options a preset sets (module docstring); options given explicitly win."),
        Param("w", _PAPER["w"], unit="1", allowed=ANY_REAL, nullable=True, eq="thesis eq. 2.40",
              doc="Inertia weight (the start value when inertia: linear). Seed default 0.9. " + _FROM_PRESET),
        Param("w_end", _PAPER["w_end"], unit="1", allowed=ANY_REAL, nullable=True,
              doc="Final inertia of the linear schedule (inertia: linear), reached at the last generation "
                  "(Shi & Eberhart 0.4). " + _FROM_PRESET),
        Param("inertia", _PAPER["inertia"], choices=("constant", "linear"), nullable=True,
              doc="Inertia schedule; linear spans generations (or max_evals / population without it). " + _FROM_PRESET),
        Param("c1", _PAPER["c1"], unit="1", allowed=NONNEG, nullable=True, eq="thesis eq. 2.40",
              doc="The cognitive coefficient. Seed default 0.5. " + _FROM_PRESET),
        Param("c2", _PAPER["c2"], unit="1", allowed=NONNEG, nullable=True, eq="thesis eq. 2.40",
              doc="The social coefficient. Seed default 1.5. " + _FROM_PRESET),
        Param("constriction", _PAPER["constriction"], nullable=True,
              doc="Clerc's constriction V <- chi (V + c1 r1 (P - X) + c2 r2 (G - X)), chi = 2 / |2 - phi - "
                  "sqrt(phi^2 - 4 phi)|, phi = c1 + c2 > 4 (e.g. c1 = c2 = 2.05, chi = 0.7298); w is then "
                  "ignored. " + _FROM_PRESET),
        Param("topology", _PAPER["topology"], choices=("global", "ring"), nullable=True,
              doc="Neighbourhood of the social term: the whole swarm, or each particle and its neighbors "
                  "nearest indices on each side (lbest ring). " + _FROM_PRESET),
        Param("neighbors", 1, unit="particles", allowed=AT_LEAST_1, integer=True,
              doc="Ring half-width, below the population."),
        Param("v_max", _PAPER["v_max"], unit="fraction of the range", allowed=Interval(0.0, 1.0, low_open=True),
              nullable=True, doc="Velocity clamp per dimension (1 means none). " + _FROM_PRESET),
        Param("boundary", "reflect", choices=("reflect", "clip", "random"),
              doc="A particle leaving the cube is mirrored back in (that velocity component reversed), stopped "
                  "at the bound, or re-drawn uniformly in that dimension (velocity component set to 0)."),
        Param("init", _PAPER["init"], choices=("uniform", "lhs"), nullable=True,
              doc="Initial positions: uniform random or Latin hypercube. " + _FROM_PRESET),
        Param("v_init", _PAPER["v_init"], unit="fraction of the range", allowed=NONNEG, nullable=True,
              doc="Initial velocities are uniform in [-v_init, v_init] (0 = at rest). " + _FROM_PRESET),
        Param("init_spread", 1.0, unit="fraction of the range", allowed=NONNEG,
              doc="With a warm start x0: particle 0 starts at x0 and the others uniformly within "
                  "x0 +- init_spread / 2 (clipped to the cube); 1 keeps them anywhere in the cube."),
    ))

    @classmethod
    def _combination(cls, v: dict[str, Any], dim: int | None, given: set[str]) -> None:
        super()._combination(v, dim, given)
        o = {k: (PRESETS[v["preset"]][k] if k in PRESETS[v["preset"]] and (k not in given or v[k] is None)
                 else v[k]) for k in v}
        if o["inertia"] == "linear" and o["generations"] is None and o["max_evals"] is None:
            raise OptionError(f"linear (preset {v['preset']!r}) needs a generations or max_evals budget", "inertia")
        if o["constriction"] and o["c1"] + o["c2"] <= 4:
            raise OptionError(f"needs c1 + c2 > 4, got {o['c1'] + o['c2']} (try c1 = c2 = 2.05)", "constriction")
        if o["topology"] == "ring" and not int(o["neighbors"]) < max(2, cls.population_for(dim or 1, v)):
            raise OptionError(f"must be in [1, population), got {o['neighbors']}", "neighbors")

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
        given = dict(w=w, w_end=w_end, inertia=inertia, c1=c1, c2=c2, constriction=constriction, topology=topology,
                     v_max=v_max, init=init, v_init=v_init)
        self.check_options(dict(preset=preset, **given, neighbors=neighbors, boundary=boundary,
                                init_spread=init_spread, **common), dim)
        super().__init__(dim, rng, **common)
        opts = {k: (PRESETS[preset][k] if v is None else v) for k, v in given.items()}
        w, w_end, inertia, c1, c2 = opts["w"], opts["w_end"], opts["inertia"], opts["c1"], opts["c2"]
        constriction, topology, v_max, init, v_init = (opts["constriction"], opts["topology"], opts["v_max"],
                                                       opts["init"], opts["v_init"])
        self.preset = preset
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

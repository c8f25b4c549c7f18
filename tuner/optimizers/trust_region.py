"""Quadratic-model trust region after a Latin-hypercube start, for few parameters and small budgets.

With 2 to 5 free parameters and a hundred evaluations, a population method spends most of its budget
learning a shape that a quadratic model fitted to the evaluations already seen describes well. This
method (in the spirit of Powell's model-based trust regions, e.g. BOBYQA, but batched and without
derivatives or interpolation-set management) does:

1. **Start**: a Latin hypercube of ``n_init`` points over the whole cube (default: the number of
   model coefficients plus ``dim``, rounded up to whole batches), asked ``population`` at a time.
2. **Model**: around the best point ``x_b`` with trust radius ``r`` (a half-width in unit-cube
   coordinates), a least-squares quadratic ``m(z) = c + g.z + z'Hz/2`` in ``z = (x - x_b) / r``, fitted to
   the ``2 p`` evaluated points nearest ``x_b`` (``p`` coefficients; a full ``H`` up to ``full_dim``
   parameters, a diagonal one above), with a small ridge on the curvature so a degenerate geometry
   stays solvable. Failed evaluations (non-finite fitness) and penalties (more than 20 times the spread
   of the best quarter above the best) are left out of the fit.
3. **Batch**: the model's minimiser in the box ``x_b +- r`` (clipped to the cube), then, if the
   population allows, its minimiser in ``x_b +- 2 r``, and Gaussian points ``N(x_b, (r/2)^2)`` (clipped)
   that explore the region and keep the fit well posed. Each minimiser is the best of
   ``n_candidates`` uniform samples of the box (the model is cheap; this handles the bounds and an
   indefinite ``H`` alike). When both minimisers are the same point (the model's minimum lies inside
   ``r``: the local step is settled) the second evaluation explores instead: the candidate of the cube
   farthest from every evaluated point.
   **Valleys.** With batches of 4 or more (3 or more parameters), while at least one exploring point is left,
   one place goes to a Hooke-Jeeves pattern move ``x_b + pattern (x_b - x_prev)`` from the best point before
   the last improvement (halved up to twice while it falls in a failure's cell), and the exploring points are
   drawn along the model's flat directions (:meth:`_shape`) instead of isotropically. A narrow curved valley
   that falls towards a stability edge, as pid_wmp's, is followed by steps that grow with the progress instead
   of a radius that shrinks each time a batch does not improve: pid_wmp reached 1 % of its best-known value
   within 120 evaluations in 53 of seeds 10-109 against 42 without (6 of seeds 0-9 against 4); the 2-D
   problems do not change and the 3-4-D test functions move both ways (``benchmarks/results/auto_rules.md``).
   **Failures.** An evaluation that failed (non-finite, or the engine's
   :data:`~tuner.objective.PENALTY`: an unstable loop, a diverged filter) marks an unknown infeasible
   region, modelled by nearest neighbours: a point is predicted to fail when its nearest evaluated point
   failed. Model minimisers, exploring points and the space-filling point are taken among the points
   predicted to succeed, so a step towards a failure stops at the bisector between ``x_b`` and it (a
   bisection towards the boundary) and a run can sit on a stability edge and slide along it; with a
   failure known, the wide step's box is ``x_b +- 4 r`` (the failures, not the box, bound it). Without
   failures nothing of this changes a run.
4. **Radius**: a batch that improves the best fitness by more than ``tol`` (relative) grows ``r`` by
   1.5 (at most ``r_max``), otherwise it halves. When ``r`` falls under ``r_min`` the region has
   collapsed onto a local minimum: a fresh Latin hypercube of the whole cube follows and the search
   goes on from the best point of everything seen (a restart that keeps the data).

Budget: every batch has ``population`` points (the start takes ``n_init / population`` of them), so
``generations`` budgets count as for any method; with ``max_evals`` the last batch is cut to the
budget. Every random number comes from the generator passed in and ``ask`` depends only on it and on
what was told, so replaying the history reproduces a run; the state is plain arrays (exact resume
through :meth:`~tuner.optimizers.base.Optimizer.state`).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from tuner.objective import PENALTY
from tuner.optimizers.base import AT_LEAST_1, Optimizer, OptionError, declare, latin_hypercube
from tuner.params import NONNEG, Interval, Param

__all__ = ["TrustRegion", "quadratic_features"]

#: Gaussian draws an exploring point gets to land outside the failures' cells
_EXPLORE_TRIES = 20
#: half-width (in radii) of the wide model step once a failure is known (2 without): 4 reached 1 % on pid_wmp
#: in 108.5 evaluations (median of seeds 0-59, median final 0.06247); 2 never did (0.06291), 8 in 108 (0.06250);
#: measured before the space-filling spare point, without the failure cells 4 was worse than 2 (0.06293, 0.06271)
_WIDE_WITH_FAILURES = 4.0


def quadratic_features(z: np.ndarray, full: bool) -> np.ndarray:
    """Design matrix of a quadratic in ``z`` (n, d): ``1, z_i, z_i^2 / 2`` and, if ``full``, ``z_i z_j`` (i < j)."""
    n, d = z.shape
    cols = [np.ones((n, 1)), z, 0.5 * z * z]
    if full and d > 1:
        i, j = np.triu_indices(d, 1)
        cols.append(z[:, i] * z[:, j])
    return np.hstack(cols)


def _curvature(coef: np.ndarray, d: int, full: bool) -> np.ndarray:
    """The (d, d) curvature matrix ``H`` of the model ``coef`` (of :func:`quadratic_features`)."""
    H = np.diag(coef[1 + d:1 + 2 * d]).astype(float)
    if full and d > 1:
        i, j = np.triu_indices(d, 1)
        H[i, j] = H[j, i] = coef[1 + 2 * d:]
    return H


def _box_coordinate_descent(coef: np.ndarray, d: int, full: bool, z: np.ndarray, lo: np.ndarray, hi: np.ndarray,
                            sweeps: int = 30) -> np.ndarray:
    """Lower the model ``coef`` (of :func:`quadratic_features`) from ``z`` within ``[lo, hi]``, one coordinate
    at a time: exact along a coordinate with positive curvature, to the better bound otherwise."""
    g = coef[1:1 + d]
    H = _curvature(coef, d, full)
    z = z.copy()
    for _ in range(sweeps):
        for k in range(d):
            rest = g[k] + H[k] @ z - H[k, k] * z[k]  # derivative along k without the z_k^2 term
            if H[k, k] > 0:
                z[k] = min(max(-rest / H[k, k], lo[k]), hi[k])
            else:
                vals = [rest * b + 0.5 * H[k, k] * b * b for b in (lo[k], hi[k], z[k])]
                z[k] = (lo[k], hi[k], z[k])[int(np.argmin(vals))]
    return z


class TrustRegion(Optimizer):
    """Latin-hypercube start, then a batched quadratic-model trust region (module docstring).

    Options in :attr:`TrustRegion.options`; a warm start ``x0`` is the first point of the starting hypercube."""

    name = "trust_region"
    options = declare("trust_region", (
        Param("population", None, unit="candidates", allowed=AT_LEAST_1, integer=True, nullable=True, kind="number",
              doc="Points per batch after the start; unset: max(3, dim + 1) (in 2-D a batch of 3 reached 1 % on "
                  "madgwick_broad in 38.5 evaluations against 52.5 with 4, median of seeds 0-19, and won 5 of the "
                  "8 2-D test-function rows of benchmarks/results/auto_rules.md)."),
        Param("n_init", None, unit="points", allowed=AT_LEAST_1, integer=True, nullable=True, kind="number",
              doc="Size of the starting Latin hypercube and of each restart's, a multiple of population (unset: "
                  "the smallest multiple not under the number of model coefficients + dim)."),
        Param("r0", 0.1, unit="unit cube", allowed=Interval(0.0, 1.0, low_open=True),
              doc="Initial trust radius, a half-width in unit-cube coordinates (0.1: at 120 evaluations in 2-4 "
                  "dimensions it beat 0.2 on 9 of the 12 test-function rows of benchmarks/results/auto_rules.md "
                  "and reached 1 % on madgwick_broad in 59.5 evaluations (median of 10 seeds) against 73, both "
                  "measured with the start in a single batch, before it was split into whole batches)."),
        Param("r_min", 1e-3, unit="unit cube", allowed=Interval(0.0, 1.0, low_open=True),
              doc="Radius under which the search restarts; 0 < r_min < r0 <= r_max <= 1."),
        Param("r_max", 0.5, unit="unit cube", allowed=Interval(0.0, 1.0, low_open=True),
              doc="Largest radius."),
        Param("full_dim", 5, unit="parameters", allowed=NONNEG, integer=True,
              doc="Largest dimension with a full curvature matrix; above it the model is separable."),
        Param("n_candidates", 2000, unit="points", allowed=AT_LEAST_1, integer=True,
              doc="Uniform samples of the box on which the model's minimiser is picked."),
        Param("pattern", 2.0, unit="last improvements", allowed=NONNEG,
              doc="Length of the pattern move (0 turns it off; 1 reached 1 % on pid_wmp in 53 % of seeds 10-69, "
                  "2 in 57 %, 0.5 in 50 %, none in 50 %)."),
        Param("shaped", 1.0, unit="radii", allowed=NONNEG,
              doc="Largest standard deviation of the exploring points drawn along the model's flat directions "
                  "(0: isotropic r / 2 as in batches of 3; with pattern 2, 1 reached 65 % of seeds 10-69 on "
                  "pid_wmp and 43 % of seeds 70-169, 0.5 58 %, 2 37 %)."),
    ))

    @classmethod
    def _combination(cls, v: dict[str, Any], dim: int | None, given: set[str]) -> None:
        super()._combination(v, dim, given)
        if not v["r_min"] < v["r0"] <= v["r_max"]:
            raise OptionError(f"trust radii must satisfy 0 < r_min < r0 <= r_max <= 1, got r_min={v['r_min']}, "
                              f"r0={v['r0']}, r_max={v['r_max']}", "r0")
        if dim is not None and v["n_init"] is not None and int(v["n_init"]) % cls.population_for(dim, v):
            raise OptionError(f"must be a positive multiple of the population {cls.population_for(dim, v)}, "
                              f"got {v['n_init']}", "n_init")

    @classmethod
    def population_for(cls, dim: int, options: Any) -> int:
        pop = options.get("population")
        return max(3, int(dim) + 1) if pop is None else int(pop)

    def __init__(self, dim: int, rng: np.random.Generator, *, n_init: int | None = None, r0: float = 0.1,
                 r_min: float = 1e-3, r_max: float = 0.5, full_dim: int = 5, n_candidates: int = 2000,
                 pattern: float = 2.0, shaped: float = 1.0, **common: Any):
        self.check_options(dict(n_init=n_init, r0=r0, r_min=r_min, r_max=r_max, full_dim=full_dim,
                                n_candidates=n_candidates, pattern=pattern, shaped=shaped, **common), dim)
        common["population"] = self.population_for(dim, common)
        super().__init__(dim, rng, **common)
        self.full = self.dim <= int(full_dim)
        self.n_coef = quadratic_features(np.zeros((1, self.dim)), self.full).shape[1]
        pop = self.population
        self.n_init = int(n_init) if n_init is not None else pop * -(-(self.n_coef + self.dim) // pop)
        self.r0, self.r_min, self.r_max = float(r0), float(r_min), float(r_max)
        self.full_dim, self.n_candidates = int(full_dim), int(n_candidates)
        self.pattern, self.shaped = float(pattern), float(shaped)
        self.radius = self.r0
        self.restarts = 0
        self.X = np.empty((0, self.dim))  # every point told, in order
        self.F = np.empty(0)
        self._pending_lhs = True  # the next batches come from a Latin hypercube (start or restart)
        self._lhs: np.ndarray | None = None  # the hypercube's points not asked yet
        self._batch: np.ndarray | None = None

    def describe(self) -> str:
        """The method as a progress line shows it."""
        return f"trust_region(radius {self.radius:.3g}, restarts {self.restarts})"

    def _batch_size(self, n: int) -> int:
        if self.max_evals is not None:
            n = min(n, max(1, self.max_evals - self.n_evals))
        return n

    def ask(self) -> np.ndarray:
        if self._batch is None:
            if self._pending_lhs:
                if self._lhs is None:
                    self._lhs = latin_hypercube(self.rng, self.n_init, self.dim)
                    if self.x0 is not None and self.generation == 0:
                        self._lhs[0] = self.x0
                b = self._lhs[: self._batch_size(self.population)]
            else:
                b = self._model_batch(self._batch_size(self.population))
            self._batch = b
        self.population = len(self._batch)
        return self._batch.copy()

    def _usable(self) -> np.ndarray:
        """Mask of the points the model may use: finite and not a penalty.

        Penalties (an unstable loop, a diverged filter) are orders of magnitude above the rest and would bend
        the whole fit: usable are the points within 20 spreads of the best, the spread being measured at the
        lower quartile (or the ``n_coef``-th best). Only the failures proper (non-finite, the engine's
        ``PENALTY``) also fence off a region (:meth:`_feasible`); a merely bad point does not."""
        ok = np.isfinite(self.F)
        if not np.any(ok):
            return ok
        srt = np.sort(self.F[ok])
        f0, fq = srt[0], srt[min(len(srt) - 1, max(self.n_coef, len(srt) // 4))]
        return ok & (self.F <= f0 + 20.0 * (fq - f0) + 1e-12 * max(abs(f0), 1e-300))

    def _fit(self, xb: np.ndarray, r: float, usable: np.ndarray) -> np.ndarray | None:
        """Coefficients of the model around ``xb`` fitted to the ``usable`` points (None when too few)."""
        X, F = self.X[usable], self.F[usable]
        if len(F) < self.dim + 2:
            return None
        k = min(len(F), 2 * self.n_coef)
        near = np.argsort(np.sum((X - xb) ** 2, axis=1), kind="stable")[:k]
        z = (X[near] - xb) / r
        A = quadratic_features(z, self.full)
        y = F[near]
        scale = max(float(np.std(y)), 1e-300)
        y = (y - y.min()) / scale
        ridge = np.zeros(A.shape[1])
        ridge[1 + self.dim:] = 1e-6  # curvature only: keeps an under-determined fit solvable
        coef, *_ = np.linalg.lstsq(A.T @ A + np.diag(ridge * len(y)), A.T @ y, rcond=None)
        return coef

    def _feasible(self, cand: np.ndarray, failed: np.ndarray) -> np.ndarray:
        """Nearest-neighbour feasibility of the points ``cand`` (m, dim): True where the nearest evaluated point
        did not fail (``failed``: a mask over the evaluated points; all True when nothing failed, so a landscape
        without failures sees no change).

        A failed evaluation marks an unknown infeasible region (an unstable loop past a stability boundary).
        Its Voronoi cell is where a step is predicted to fail: a model step towards a failure stops at the
        bisector between the best point and the failure (a bisection towards the boundary), and along a
        boundary of several failures it slides between them instead of falling off it again."""
        if not np.any(failed):
            return np.ones(len(cand), dtype=bool)
        return ~failed[self._nearest(cand)[0]]

    def _nearest(self, cand: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Index of the nearest evaluated point of each of ``cand`` (m, dim) and the squared distance to it."""
        d2 = (np.sum(cand**2, axis=1)[:, None] - 2.0 * cand @ self.X.T) + np.sum(self.X**2, axis=1)[None, :]
        idx = np.argmin(d2, axis=1)
        return idx, d2[np.arange(len(cand)), idx]

    def _argmin_in_box(self, coef: np.ndarray, xb: np.ndarray, half: float, failed: np.ndarray) -> np.ndarray:
        lo, hi = np.clip(xb - half, 0.0, 1.0), np.clip(xb + half, 0.0, 1.0)
        cand = lo + (hi - lo) * self.rng.random((self.n_candidates, self.dim))
        r = self.radius
        m = quadratic_features((cand - xb) / r, self.full) @ coef
        feasible = self._feasible(cand, failed)
        if not np.any(feasible):
            return cand[int(np.argmin(m))]
        m[~feasible] = np.inf
        best = cand[int(np.argmin(m))]
        z = _box_coordinate_descent(coef, self.dim, self.full, (best - xb) / r, (lo - xb) / r, (hi - xb) / r)
        polished = np.clip(xb + r * z, lo, hi)
        # the coordinate descent knows the box, not the failures: keep its point only where it is predicted feasible
        return polished if self._feasible(polished[None, :], failed)[0] else best

    def _space_filling(self, failed: np.ndarray) -> np.ndarray:
        """The point of the cube farthest from every evaluated point, among the ``n_candidates`` uniform samples
        outside the failures' cells (:meth:`_feasible`; all of them if none is outside)."""
        cand = self.rng.random((self.n_candidates, self.dim))
        nearest, gap = self._nearest(cand)
        if np.any(failed):
            ok = ~failed[nearest]
            if np.any(ok):
                gap[~ok] = -np.inf
        return cand[int(np.argmax(gap))]

    def _model_batch(self, n: int) -> np.ndarray:
        xb, r = self.best_x, self.radius
        usable = self._usable()
        failed = ~np.isfinite(self.F) | (self.F >= PENALTY)
        coef = self._fit(xb, r, usable)
        out = []
        if coef is not None:
            out.append(self._argmin_in_box(coef, xb, r, failed))
            if n > 1:
                # failures fence the region in: the wide step may go four times further than without them
                wide = _WIDE_WITH_FAILURES if np.any(failed) else 2.0
                out.append(self._argmin_in_box(coef, xb, min(wide * r, 1.0), failed))
                if np.max(np.abs(out[1] - out[0])) <= 1e-3 * r:
                    # the same minimiser at both radii: the model's local step is settled, so the spare
                    # evaluation explores the cube where nothing has been evaluated yet
                    out[1] = self._space_filling(failed)
        spare = n >= 4  # the valley moves take a batch's spare places, never its last exploring point
        if spare and self.pattern > 0 and len(out) < n - 1:
            prev = self._previous_incumbent()
            if prev is not None:  # Hooke-Jeeves pattern move: on along the last improvement, backing off
                for s in (self.pattern, 0.5 * self.pattern, 0.25 * self.pattern):  # from the failures' cells
                    x = np.clip(xb + s * (xb - prev), 0.0, 1.0)
                    if self._feasible(x[None, :], failed)[0]:
                        out.append(x)
                        break
        B = self._shape(coef) if (spare and self.shaped > 0 and coef is not None) else None

        def draw() -> np.ndarray:
            z = self.rng.standard_normal(self.dim)
            return np.clip(xb + (0.5 * r * z if B is None else r * (B @ z)), 0.0, 1.0)

        while len(out) < n:
            x = draw()
            for _ in range(_EXPLORE_TRIES):  # exploring points too stay out of the failures' cells when they can
                if self._feasible(x[None, :], failed)[0]:
                    break
                x = draw()
            out.append(x)
        return np.array(out[:n])

    def _shape(self, coef: np.ndarray) -> np.ndarray | None:
        """``B`` such that ``r B z`` (z standard normal) spreads along the model's flat directions: in the
        eigenbasis of the model's curvature ``H`` the standard deviation is ``1 / sqrt(|eigenvalue|)``
        (floored at 1e-4 of the largest), scaled so the largest is ``shaped`` radii. None when ``H`` is 0."""
        lam, V = np.linalg.eigh(_curvature(coef, self.dim, self.full))
        lam = np.abs(lam)
        if not np.all(np.isfinite(lam)) or lam.max() <= 0:
            return None
        lam = np.maximum(lam, lam.max() * 1e-4)
        std = 1.0 / np.sqrt(lam)
        std *= self.shaped / std.max()
        return V * std

    def _previous_incumbent(self) -> np.ndarray | None:
        """The best point before the last improvement of the best (None before a second improvement)."""
        F = np.where(np.isfinite(self.F), self.F, np.inf)
        before = np.concatenate(([np.inf], np.minimum.accumulate(F)[:-1]))  # the best before each evaluation
        new = np.flatnonzero(F < before)  # evaluations that improved the best
        if len(new) < 2:
            return None
        return self.X[new[-2]]

    def _tell(self, x: np.ndarray, f: np.ndarray) -> None:
        if self._batch is None or x.shape != self._batch.shape:
            raise ValueError("TrustRegion.tell expects the points returned by the last ask()")
        was_lhs, best_before = self._pending_lhs, self.best_f
        self.X = np.vstack([self.X, x])
        self.F = np.concatenate([self.F, f])
        self._batch = None
        if was_lhs:
            self._lhs = self._lhs[len(x):]
            if len(self._lhs):
                return
            self._lhs, self._pending_lhs = None, False
            self.radius = self.r0
            return
        fmin = float(np.min(f)) if len(f) else np.inf
        gain = best_before - fmin
        if np.isfinite(best_before) and gain > self.tol * max(abs(best_before), 1e-300):
            self.radius = min(1.5 * self.radius, self.r_max)
        elif not np.isfinite(best_before) and np.isfinite(fmin):
            self.radius = self.r0
        else:
            self.radius *= 0.5
            if self.radius < self.r_min:
                self.restarts += 1
                self._pending_lhs = True

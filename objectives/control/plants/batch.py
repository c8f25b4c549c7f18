"""Candidates x models x scenarios of the generic loop in one call: the statistics row of every item.

An *item* is one (candidate, model, scenario) triple. :class:`ItemRunner` holds what the items share
(each model's plant, each scenario's signals and windows, the actuator options) and returns the
statistics rows (:mod:`.metrics`) of every item of a list of candidates' coefficient arrays, shaped
(candidates, models, scenarios, row):

- when every model is a :class:`~objectives.control.plants.base.DiscreteLTI`, one numba kernel runs all
  items: ``prange`` over lanes (one per thread), each lane claiming the next item (longest scenario
  first) by an atomic counter and running the LTI loop kernel and the statistics in its own buffers
  (:mod:`objectives.batch_threads`); serial calls run the same function compiled without threads, so a
  candidate's row is the same bits whichever backend asked for it and whichever lane ran it;
- otherwise (stepped plants: Python dynamics, FMUs) each item runs its plant's own ``run_loop`` and the
  same statistics kernel, one after the other.

So a candidate's models and scenarios cost one kernel call, not one Python loop each, and the
population of ``backend: threads`` is one call for the whole generation.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numba import njit, prange

from objectives.batch_threads import claim, counter, deal, use_threads
from objectives.control.plants.kernels import _loop_lti
from objectives.control.plants.metrics import _item_stats, stat_size
from objectives.control.plants.simulate import _opt
from objectives.jit import CACHE, uncached

__all__ = ["ItemRunner"]

_loop_in_kernel = uncached(_loop_lti)
_stats_in_kernel = uncached(_item_stats)


def _items_body(ad, bd, cd, dd, x0, opt, sig, n_steps, win, cps, items, order, count, out_idx, h,
                ybuf, ubuf, xbuf, stats):
    """Every item ``items[i] = (candidate, model, scenario)`` into ``stats[i]``; lanes claim items in
    ``order`` through ``count``."""
    n_lanes = ybuf.shape[0]
    n_items = order.size
    for lane in prange(n_lanes):
        while True:
            j = claim(count)
            if j >= n_items:
                break
            it = order[j]
            c, m, s = items[it, 0], items[it, 1], items[it, 2]
            n = n_steps[s]
            y, u, x = ybuf[lane, :n], ubuf[lane, :n], xbuf[lane, :n]
            status, done = _loop_in_kernel(ad[m], bd[m], cd[m], dd[m], x0[m], sig[s, :n], cps[c], opt[m], y, u, x)
            _stats_in_kernel(y, u, x, sig[s, :n, 0], out_idx, h, win[s], n, float(status), float(done), stats[it])


_items_serial = njit(cache=CACHE)(_items_body)
_items_threads = njit(cache=CACHE, parallel=True)(_items_body)


class ItemRunner:
    """The items of a model set and a scenario set (module docstring).

    Parameters
    ----------
    plants : list of Plant
        The models (the same sizes; the nominal first).
    sigs : list of (N_s, 2 + n_meas) arrays
        Each scenario's reference, load and noise.
    wins : list of (6,) arrays
        Each scenario's windows (:func:`objectives.control.plants.metrics.windows`).
    kind : int
        The controller kind (:mod:`objectives.control.kinds`).
    real : Realism
        Actuator limits and quanta (:mod:`.scenario`).
    """

    def __init__(self, plants: list[Any], sigs: list[np.ndarray], wins: list[np.ndarray], kind: int, real: Any) -> None:
        self.plants, self.kind, self.real = plants, kind, real
        p0 = plants[0]
        self.out_idx, self.h = int(p0.output), float(p0.period_s)
        self.p, self.n, self.m = p0.n_outputs, p0.n_states, p0.n_inputs
        self.row = stat_size(self.p, self.n)
        self.n_steps = np.array([s.shape[0] for s in sigs], dtype=np.int64)
        nmax = int(self.n_steps.max())
        self.sig = np.zeros((len(sigs), nmax, sigs[0].shape[1]))
        for i, s in enumerate(sigs):
            self.sig[i, :s.shape[0]] = s
        self.sigs = [np.ascontiguousarray(s) for s in sigs]
        self.win = np.ascontiguousarray(np.array(wins, dtype=float))
        self.opt = np.ascontiguousarray(np.array([_opt(pl, kind, real) for pl in plants]))
        self.lti = all(pl.linear for pl in plants)
        if self.lti:
            self.ad = np.ascontiguousarray(np.array([pl.Ad for pl in plants]))
            self.bd = np.ascontiguousarray(np.array([pl.Bd for pl in plants]))
            self.cd = np.ascontiguousarray(np.array([pl.Cd for pl in plants]))
            self.dd = np.ascontiguousarray(np.array([pl.Dd for pl in plants]))
            self.x0 = np.ascontiguousarray(np.array([pl.x0 for pl in plants], dtype=float))

    @property
    def shape(self) -> tuple[int, int]:
        """(models, scenarios)."""
        return len(self.plants), len(self.sigs)

    def run(self, cps: np.ndarray, n_threads: int = 1) -> np.ndarray:
        """Statistics (C, M, S, row) of the candidates' coefficient arrays ``cps`` (C, n_coeffs)."""
        cps = np.ascontiguousarray(np.atleast_2d(np.asarray(cps, dtype=float)))
        n_c, (n_m, n_s) = cps.shape[0], self.shape
        stats = np.zeros((n_c * n_m * n_s, self.row))
        items = np.array([(c, m, s) for c in range(n_c) for m in range(n_m) for s in range(n_s)], dtype=np.int64)
        if not self.lti:
            for i, (c, m, s) in enumerate(items):
                self._stepped(int(c), int(m), int(s), cps, stats[i])
            return stats.reshape(n_c, n_m, n_s, self.row)
        order = deal(self.n_steps[items[:, 2]].astype(float))
        lanes = use_threads(n_threads) if n_threads > 1 else 1
        lanes = min(lanes, items.shape[0])
        nmax = self.sig.shape[1]
        ybuf, ubuf, xbuf = (np.zeros((lanes, nmax, k)) for k in (self.p, self.m, self.n))
        kernel = _items_threads if lanes > 1 else _items_serial
        kernel(self.ad, self.bd, self.cd, self.dd, self.x0, self.opt, self.sig, self.n_steps, self.win, cps, items,
               order, counter(), self.out_idx, self.h, ybuf, ubuf, xbuf, stats)
        return stats.reshape(n_c, n_m, n_s, self.row)

    def _stepped(self, c: int, m: int, s: int, cps: np.ndarray, row: np.ndarray) -> None:
        tr = self.trace(cps[c], m, s)
        _item_stats(tr["y"], tr["u"], tr["x"], self.sigs[s][:, 0], self.out_idx, self.h, self.win[s],
                    self.sigs[s].shape[0], float(tr["status"]), float(tr["n_done"]), row)

    def trace(self, cp: np.ndarray, m: int, s: int, sig: np.ndarray | None = None) -> dict[str, Any]:
        """The response of one item (``sig``: other signals than the scenario's, of its length): t, y (N, p),
        u (N, m), x (N, n), status, n_done."""
        plant, sig = self.plants[m], np.ascontiguousarray(self.sigs[s] if sig is None else sig)
        n = sig.shape[0]
        y, u, x = np.zeros((n, self.p)), np.zeros((n, self.m)), np.zeros((n, self.n))
        status, done = plant.run_loop(sig, np.ascontiguousarray(cp, dtype=float), self.opt[m].copy(), y, u, x)
        return {"t": np.arange(n) * self.h, "y": y, "u": u, "x": x, "status": int(status), "n_done": int(done)}

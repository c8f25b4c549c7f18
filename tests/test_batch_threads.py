"""Dynamic dealing of the population kernels (objectives/batch_threads.py): every item exactly once."""

import numpy as np
from numba import njit, prange

from objectives.batch_threads import claim, counter, deal, use_threads


@njit(cache=False, parallel=True)
def _claim_all(n_lanes, order, count, hits, who, work):
    """Each lane claims items until none is left; ``hits[p]`` counts how often item ``p`` was taken."""
    for lane in prange(n_lanes):
        while True:
            j = claim(count)
            if j >= order.shape[0]:
                break
            p = order[j]
            hits[p] += 1
            who[j] = lane
            s = 0.0
            for i in range(work[p]):  # some work, so that lanes really overlap
                s += np.sqrt(i + 1.0)
            if s < 0.0:
                hits[p] = -1


def test_deal_is_longest_first_with_ties_in_index_order():
    costs = np.array([5.0, 1.0, 4.0, 2.0, 4.0, 3.0])
    assert deal(costs).tolist() == [0, 2, 4, 5, 3, 1]
    assert deal(np.zeros(0)).size == 0 and deal(np.zeros(0)).dtype == np.int64


def test_two_lanes_racing_take_every_item_exactly_once():
    n = use_threads(2)
    order = deal(np.zeros(50_000))  # tiny items: the lanes hit the counter as often as they can
    work = np.random.default_rng(0).integers(0, 40, order.size)
    hits, who, count = np.zeros(order.size, dtype=np.int64), np.full(order.size, -1), counter()
    _claim_all(n, order, count, hits, who, work)
    assert np.all(hits == 1)
    assert count[0] == order.size + n  # each lane's last claim finds the list empty
    assert set(who.tolist()) <= set(range(n)) and np.all(who >= 0)


def test_one_lane_claims_in_the_dealt_order():
    use_threads(1)
    order = deal(np.array([1.0, 3.0, 2.0]))
    hits, who, count = np.zeros(3, dtype=np.int64), np.full(3, -1), counter()
    _claim_all(1, order, count, hits, who, np.zeros(3, dtype=np.int64))
    assert hits.tolist() == [1, 1, 1] and who.tolist() == [0, 0, 0] and count[0] == 4

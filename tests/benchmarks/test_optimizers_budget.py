"""The optimiser benchmark gives every method of ours exactly its budget."""

from __future__ import annotations

from benchmarks.optimizers import OURS, run_method


def test_every_method_of_ours_spends_the_whole_budget():
    """A budget above the optimisers' default of 50 generations is used in full (cmaes stopped at 50)."""
    budget = 400  # 2-D: cmaes has 6 per generation, so 50 generations would be 300 evaluations
    for method in OURS:
        out = run_method(method, lambda u: float(((u - 0.3) ** 2).sum()), 2, budget, 6, 0)
        assert out["error"] == "" and out["n_evals"] == budget, (method, out["n_evals"])

"""benchmarks/broad_cv_nested.py: the nested leave-one-group-out CV on a score matrix worked out by hand."""

import numpy as np

from benchmarks.broad_cv_nested import Design, nested_cv
from objectives.attitude.trials import logo_folds

NAMES = ["a1", "a2", "b1", "b2", "c1", "c2"]
GROUPS = {n: n[0] for n in NAMES}


def test_the_inner_cv_chooses_and_the_outer_scores_what_it_never_saw():
    """Design 1's first point is best on groups a and b and bad on c; its second is fair everywhere. Held out
    a (or b), the inner CV on the other two sees design 1 pick the point that fails the group it holds out
    (inner 3.25) and chooses the untuned design (2); held out c, design 1's inner CV is 1.0, it is chosen,
    tuned on a and b, and scores 5 on c. Its plain LOGO-CV would quote 2.67; the nested figure is 3.0."""
    untuned = Design("untuned", [{}], [[2.0] * 6], [0.0])
    tuned = Design("tuned", [{"x": 1.0}, {"x": 2.0}], [[1, 1, 1, 1, 5, 5], [1.5] * 6], [0.0, 0.0])
    folds = logo_folds(NAMES, GROUPS)
    nested, chosen = nested_cv([untuned, tuned], NAMES, GROUPS, folds)
    np.testing.assert_allclose(nested, [2, 2, 2, 2, 5, 5])
    assert [(g, b, p) for g, b, p, _ in chosen] == [("a", 0, 0), ("b", 0, 0), ("c", 1, 0)]
    np.testing.assert_allclose([c[3] for c in chosen], [[2.0, 3.25], [2.0, 3.25], [2.0, 1.0]])
    assert tuned.logo(np.arange(6), NAMES, GROUPS).mean() == np.float64(16.0 / 6.0)

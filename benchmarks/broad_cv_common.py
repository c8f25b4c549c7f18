"""What the BROAD cross-validation benchmarks share: where the checkout and the data are, the folds.

``benchmarks/broad_cv.py`` (PSO per fold, and the CV of every ``configs/broad_*.yaml`` for ``make bench``)
and ``benchmarks/broad_cv_grid.py`` (many tuning setups on one grid of scores) both use it.
"""

from __future__ import annotations

import sys
from pathlib import Path

import yaml

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:  # run as a script: benchmarks/ is on the path, the checkout is not
    sys.path.insert(0, str(ROOT))
#: ../shared/data/broad of the checkout (or of its parent, for a worktree one level deeper)
_CANDIDATES = [base / "shared" / "data" / "broad" for base in (ROOT.parent, ROOT.parent.parent)]
BROAD_DIR = next((d for d in _CANDIDATES if d.is_dir()), _CANDIDATES[0])
RESULTS_MD = ROOT / "benchmarks" / "results" / "broad_cv.md"

__all__ = ["ROOT", "BROAD_DIR", "RESULTS_MD", "pairs", "broad_folds", "append"]


def pairs(items: list[str] | None, what: str) -> dict:
    """``NAME=VALUE`` strings (values parsed as YAML) as a dict; a malformed item stops the script."""
    out = {}
    for it in items or []:
        if "=" not in it:
            raise SystemExit(f"{what}: expected NAME=VALUE, got {it!r}")
        k, v = it.split("=", 1)
        out[k] = yaml.safe_load(v)
    return out


def broad_folds(data: str | Path):
    """``(paths, groups, folds)`` of the BROAD ``.mat`` files in ``data``: leave-one-group-out folds."""
    from objectives.attitude.cv import broad_trial_groups, logo_folds

    data = Path(data)
    paths = {p.stem: p for p in sorted(data.glob("*.mat"))}
    if not paths:
        raise SystemExit(f"{data}: no BROAD .mat files")
    groups = broad_trial_groups(data, list(paths))
    return paths, groups, logo_folds(list(paths), groups)


def append(out: str | Path, text: str) -> None:
    """Append ``text`` to the Markdown file ``out`` (created with its directory)."""
    out = Path(out)
    out.parent.mkdir(parents=True, exist_ok=True)
    with out.open("a") as fh:
        fh.write(text)


def publish(out: str | Path, lines: list[str]) -> None:
    """Print the Markdown ``lines`` (one text, newline-terminated) and :func:`append` it to ``out``."""
    text = "\n".join(lines) + "\n"
    print(text)
    append(out, text)

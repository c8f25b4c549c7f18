"""``tuner describe NAME``: what one name of a config means (optimiser, objective kind, or a name an
objective kind declares: filter, controller, metric, data source, function).

The engine describes its own optimisers and objective kinds; everything else comes from the kinds'
optional ``explain(name)`` classmethod through :meth:`tuner.registry.Registry.explain`, so the
engine never imports domain code. A description is a plain dict::

    {"section": "filters", "name": "ekf", "summary": "...", "kind": "filter",
     "params": [{"name", "default", "bounds", "scale", "unit", "doc", "eq", ...}, ...]}
"""

from __future__ import annotations

import difflib
import inspect
import math
import re
from typing import Any

__all__ = ["UnknownName", "all_names", "describe", "format_text", "optimizer_description"]


class UnknownName(ValueError):
    """A name nothing declares; the message lists the close matches."""


def optimizer_description(name: str) -> dict[str, Any]:
    """Options of optimiser ``name``: its declaration (:attr:`tuner.optimizers.base.Optimizer.options`)."""
    from tuner.optimizers import OPTIMIZERS

    cls = OPTIMIZERS[name]
    summary = (cls.__doc__ or "").strip().splitlines()
    mod_doc = inspect.getmodule(cls).__doc__ or ""
    eq = re.search(r"(thesis eq\.? [\d.\-]+|eq\. [\d.\-]+)", mod_doc)
    return {"section": "optimizers", "name": name, "kind": None, "summary": summary[0] if summary else "",
            "class": f"{cls.__module__}.{cls.__qualname__}", "eq": eq.group(1) if eq else "",
            "usage": f"optimizer: {{method: {name}, population: 20, generations: 50}}",
            "params": cls.options.describe()}


def _kind_description(kind: str, source: str) -> dict[str, Any]:
    from tuner.registry import REGISTRY

    cls = REGISTRY.get(kind)
    doc = (cls.__doc__ or "").strip().splitlines()
    sections = REGISTRY.catalogs().get(kind, {})
    return {"section": "objective kinds", "name": kind, "kind": kind, "summary": doc[0] if doc else "",
            "source": source, "usage": f"objective: {{kind: {kind}, ...}}", "names": sections, "params": []}


def all_names() -> list[str]:
    """Every name ``describe`` knows (optimisers, objective kinds, every catalog entry)."""
    from tuner.optimizers import OPTIMIZERS
    from tuner.registry import REGISTRY

    names = set(OPTIMIZERS) | set(REGISTRY.kinds())
    for _kinds, entries in REGISTRY.catalog().values():
        names.update(entries)
    return sorted(names)


def describe(name: str) -> list[dict[str, Any]]:
    """Every description of ``name`` (a name may be, e.g., both a filter metric and a data source).

    Raises
    ------
    UnknownName
        Nothing declares ``name``; the message lists the closest known names.
    """
    from tuner.optimizers import OPTIMIZERS
    from tuner.registry import REGISTRY

    out: list[dict[str, Any]] = []
    if name in OPTIMIZERS:
        out.append(optimizer_description(name))
    kinds = REGISTRY.kinds()
    if name in kinds:
        out.append(_kind_description(name, kinds[name]))
    out += [{**d, "kind": kind} for kind, d in REGISTRY.explain(name)]
    if not out:
        close = difflib.get_close_matches(name, all_names(), n=5, cutoff=0.5)
        hint = f"; did you mean {', '.join(close)}?" if close else "; `tuner list` shows every name"
        raise UnknownName(f"describe: unknown name {name!r}{hint}")
    return out


def _fmt(v: Any) -> str:
    if v is None:
        return "-"
    if isinstance(v, float):
        return "inf" if math.isinf(v) and v > 0 else "-inf" if math.isinf(v) else f"{v:.4g}"
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(_fmt(x) for x in v) + "]"
    return str(v)


def format_text(d: dict[str, Any]) -> str:
    """A description as aligned text for the terminal."""
    head = f"{d['name']} ({d['section']}" + (f", objective.kind: {d['kind']}" if d.get("kind") else "") + ")"
    lines = [head, f"  {d.get('summary', '')}".rstrip()]
    for key in ("class", "source", "unit", "eq", "usage", "working_frame"):
        if d.get(key):
            lines.append(f"  {key}: {d[key]}")
    for section, names in (d.get("names") or {}).items():
        lines.append(f"  {section}: {', '.join(names)}")
    params = d.get("params") or []
    if params and d["section"] == "optimizers":  # options: what is allowed, not a search range
        rows = [("name", "default", "allowed", "unit", "eq.", "doc")]
        for p in params:
            allowed = _fmt(p.get("allowed")) + (" or null" if p.get("nullable") and p.get("allowed") else "")
            rows.append((p["name"], _fmt(p.get("default")), allowed, p.get("unit") or "-", p.get("eq") or "-",
                         p.get("doc") or ""))
        widths = [max(len(r[i]) for r in rows) for i in range(5)]
        lines.append("  options:")
        for r in rows:
            lines.append("    " + "  ".join(c.ljust(w) for c, w in zip(r[:5], widths)) + "  " + r[5])
    elif params:
        rows = [("name", "default", "bounds", "scale", "unit", "eq.", "doc")]
        for p in params:
            rows.append((p["name"], _fmt(p.get("default")), _fmt(p.get("bounds")) if p.get("bounds") else "fixed"
                         if d["section"] in ("filters", "controllers") else "-", p.get("scale") or "-",
                         p.get("unit") or "-", p.get("eq") or "-", p.get("doc") or ""))
        widths = [max(len(r[i]) for r in rows) for i in range(6)]
        lines.append("  parameters:")
        for r in rows:
            lines.append("    " + "  ".join(c.ljust(w) for c, w in zip(r[:6], widths)) + "  " + r[6])
    return "\n".join(lines)

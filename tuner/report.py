"""Run reports: ``report.md`` with the result table and a convergence figure.

Objectives can add their own figures (error traces, fuzzy surfaces) through their ``finalize`` hook;
those land in ``figures/`` and are listed in the report.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from tuner.rundir import RunDir, RunError

__all__ = ["write_run_report", "plot_convergence", "load_history", "run_summary"]


def load_history(run_dir: Path) -> pd.DataFrame:
    """``history.csv`` as a frame; a missing or unparsable file raises :class:`tuner.rundir.RunError`."""
    p = Path(run_dir) / "history.csv"
    if not p.is_file():
        raise RunError(f"{p}: missing (nothing evaluated yet?)")
    try:
        df = pd.read_csv(p, keep_default_na=False, na_values=[""])
    except (pd.errors.ParserError, pd.errors.EmptyDataError, UnicodeDecodeError) as exc:
        raise RunError(f"{p}: unreadable: {str(exc).strip()}") from None
    missing = [c for c in ("eval", "stage", "generation", "fitness", "status") if c not in df.columns]
    if missing:
        raise RunError(f"{p}: missing columns {missing}")
    return df


def _convergence(hist: pd.DataFrame) -> pd.DataFrame:
    ok = hist[hist["status"] == "ok"]
    g = ok.groupby(["stage", "generation"])["fitness"]
    df = pd.DataFrame({"gen_best": g.min(), "gen_median": g.median()}).reset_index()
    evals = hist.groupby(["stage", "generation"])["eval"].max().reset_index()
    df = df.merge(evals, on=["stage", "generation"], how="right").sort_values("eval")
    df["best"] = df["gen_best"].cummin()
    df["n_evals"] = df["eval"] + 1
    return df


def plot_convergence(run_dir: Path, path: Path | None = None) -> Path:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    run_dir = Path(run_dir)
    conv = _convergence(load_history(run_dir))
    path = path or run_dir / "figures" / "convergence.png"
    path.parent.mkdir(parents=True, exist_ok=True)
    fig, ax = plt.subplots(figsize=(6.4, 3.8), dpi=110)
    ax.plot(conv["n_evals"], conv["best"], label="best so far", lw=2)
    ax.plot(conv["n_evals"], conv["gen_median"], label="generation median", lw=1, alpha=0.7)
    pos = conv[["best", "gen_median"]].to_numpy()
    if np.nanmin(pos) > 0 and np.nanmax(pos) / max(np.nanmin(pos), 1e-300) > 20:
        ax.set_yscale("log")
    for s in sorted(conv["stage"].unique())[1:]:
        ax.axvline(conv[conv["stage"] == s]["n_evals"].min(), color="grey", ls=":", lw=1)
    ax.set_xlabel("evaluations")
    ax.set_ylabel("fitness")
    ax.set_title(run_dir.name, fontsize=9)
    ax.grid(alpha=0.3)
    ax.legend()
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)
    return path


def run_summary(run_dir: Path) -> dict[str, Any]:
    """Status, best fitness, parameters and counts of a run directory.

    Raises :class:`tuner.rundir.RunError` (naming the file) if ``meta.json`` or ``best.yaml`` is corrupt.
    """
    rd = RunDir(run_dir)
    meta = rd.meta()
    best = rd.best() if rd.has_best() else None
    return {"run": rd.path.name, "status": meta.status, "optimizer": meta.optimizer, "seed": meta.seed,
            "n_evals": meta.n_evals, "n_failed": meta.n_failed,
            "best_fitness": best.fitness if best else None, "params": dict(best.params) if best else {},
            "metrics": dict(best.metrics) if best else {}, "evaluation": dict(best.evaluation) if best else {},
            "wall_s": meta.timing.wall_s, "stop_reason": meta.stop_reason, "created": meta.created,
            "notes": list(meta.notes)}


def md_table(df: pd.DataFrame, floatfmt: str = ".6g") -> str:
    """A pandas frame as a Markdown table (no extra dependency)."""
    if df is None or len(df) == 0:
        return "(no rows)"
    cols = list(df.columns)
    lines = ["| " + " | ".join(str(c) for c in cols) + " |", "|" + "---|" * len(cols)]
    for _, r in df.iterrows():
        cells = [format(v, floatfmt) if isinstance(v, float) else str(v) for v in (r[c] for c in cols)]
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines)


def _md_table(rows: list[tuple[str, Any]], head=("name", "value")) -> str:
    out = [f"| {head[0]} | {head[1]} |", "|---|---|"]
    for k, v in rows:
        if isinstance(v, float):
            v = f"{v:.6g}"
        out.append(f"| {k} | {v} |")
    return "\n".join(out)


def write_run_report(run_dir: Path) -> Path:
    """Write ``report.md`` (and ``figures/convergence.png``) for a run directory."""
    run_dir = Path(run_dir)
    s = run_summary(run_dir)
    conv_png = plot_convergence(run_dir)
    lines = [f"# Run {s['run']}", "",
             f"Status **{s['status']}** ({s['stop_reason']}); optimizer `{s['optimizer']}`, seed {s['seed']}, "
             f"{s['n_evals']} evaluations ({s['n_failed']} failed), {s['wall_s']:.1f} s wall.", "",
             *[f"Note: {n}." for n in s["notes"]], *([""] if s["notes"] else []),
             f"Best fitness: **{s['best_fitness']:.6g}**", "", "## Best parameters", "",
             _md_table(list(s["params"].items()), ("parameter", "value")), ""]
    if s["metrics"]:
        lines += ["## Metrics of the best candidate (tuning data)", "",
                  _md_table(list(s["metrics"].items()), ("metric", "value")), ""]
    ev = s["evaluation"]
    if ev:
        tables = ev.get("tables_md")
        lines += ["## Evaluation", ""]
        if tables:
            lines += [tables, ""]
        flat = [(k, v) for k, v in ev.items() if not isinstance(v, (dict, list)) and k != "tables_md"]
        if flat:
            lines += [_md_table(flat, ("metric", "value")), ""]
    lines += ["## Figures", "", f"![convergence](figures/{conv_png.name})", ""]
    for png in sorted((run_dir / "figures").glob("*.png")):
        if png.name != conv_png.name:
            lines += [f"![{png.stem}](figures/{png.name})", ""]
    path = run_dir / "report.md"
    text = "\n".join(lines)
    path.write_text(text)
    write_html(run_dir / "report.html", text, run_dir)
    return path


# --- sweep figures and the self-contained HTML report ------------------------------------------
def sweep_figures(sweep_dir: Path, df: pd.DataFrame) -> list[tuple[str, Path]]:
    """Convergence of every job, final fitness per method (box plot), best-parameter distributions."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    figs_dir = Path(sweep_dir) / "figures"
    figs_dir.mkdir(parents=True, exist_ok=True)
    out: list[tuple[str, Path]] = []
    done = df[df["status"] == "finished"] if len(df) else df
    if len(done) == 0:
        return out
    methods = sorted(done["method"].unique())
    colors = {m: plt.cm.tab10(i % 10) for i, m in enumerate(methods)}

    fig, ax = plt.subplots(figsize=(7, 4), dpi=110)
    for _, r in done.iterrows():
        h = load_history(Path(sweep_dir) / "jobs" / r["job"])
        c = _convergence(h)
        ax.plot(c["n_evals"], c["best"], color=colors[r["method"]], alpha=0.8, lw=1.2,
                label=r["method"])
    handles, labels = ax.get_legend_handles_labels()
    uniq = dict(zip(labels, handles))
    ax.legend(uniq.values(), uniq.keys(), fontsize=8)
    vals = done["best_fitness"].astype(float)
    if vals.min() > 0 and vals.max() / vals.min() > 20:
        ax.set_yscale("log")
    ax.set_xlabel("evaluations")
    ax.set_ylabel("best fitness so far")
    ax.grid(alpha=0.3)
    fig.tight_layout()
    p = figs_dir / "convergence_all.png"
    fig.savefig(p)
    plt.close(fig)
    out.append(("Convergence of every job", p))

    col = "test_fitness" if "test_fitness" in done and done["test_fitness"].notna().any() else "best_fitness"
    fig, ax = plt.subplots(figsize=(max(4.5, 1.1 * len(methods) + 2), 3.8), dpi=110)
    data = [done[done["method"] == m][col].astype(float).dropna().to_numpy() for m in methods]
    ax.boxplot(data, tick_labels=methods, showmeans=True)
    for i, d in enumerate(data):
        ax.scatter(np.full(len(d), i + 1), d, s=12, color="k", alpha=0.6, zorder=3)
    ax.set_ylabel(col.replace("_", " "))
    ax.tick_params(axis="x", labelrotation=20, labelsize=8)
    ax.grid(alpha=0.3, axis="y")
    fig.tight_layout()
    p = figs_dir / "final_fitness_box.png"
    fig.savefig(p)
    plt.close(fig)
    out.append((f"Final {col.replace('_', ' ')} per method over seeds", p))

    pcols = [c for c in done.columns if c.startswith("param.") and done[c].notna().any()
             and done[c].astype(float).nunique() > 1]
    if pcols:
        pcols = pcols[:12]
        ncol = min(4, len(pcols))
        nrow = int(np.ceil(len(pcols) / ncol))
        fig, axes = plt.subplots(nrow, ncol, figsize=(3 * ncol, 2.4 * nrow), dpi=100, squeeze=False)
        for ax, c in zip(axes.ravel(), pcols):
            for i, m in enumerate(methods):
                v = done[done["method"] == m][c].astype(float).dropna()
                ax.scatter(v, np.full(len(v), i), color=colors[m], s=18)
            v = done[c].astype(float).dropna()
            if (v > 0).all() and v.max() / v.min() > 100:
                ax.set_xscale("log")
            ax.set_yticks(range(len(methods)), methods, fontsize=7)
            ax.set_title(c[6:], fontsize=8)
            ax.grid(alpha=0.3)
        for ax in axes.ravel()[len(pcols):]:
            ax.set_visible(False)
        fig.tight_layout()
        p = figs_dir / "best_parameters.png"
        fig.savefig(p)
        plt.close(fig)
        out.append(("Best parameters of every job", p))
    return out


def _md_to_html(md: str) -> str:
    """A small Markdown subset (headings, tables, code blocks, images, links, paragraphs) to HTML."""
    import html
    import re

    out, lines, i = [], md.splitlines(), 0
    inline_link = re.compile(r"\[([^\]]+)\]\(([^)]+)\)")

    def inline(s: str) -> str:
        s = html.escape(s)
        s = re.sub(r"\*\*([^*]+)\*\*", r"<b>\1</b>", s)
        s = re.sub(r"`([^`]+)`", r"<code>\1</code>", s)
        return inline_link.sub(r'<a href="\2">\1</a>', s)

    while i < len(lines):
        ln = lines[i]
        if ln.startswith("```"):
            j = i + 1
            while j < len(lines) and not lines[j].startswith("```"):
                j += 1
            out.append("<pre>" + html.escape("\n".join(lines[i + 1:j])) + "</pre>")
            i = j + 1
            continue
        m = re.match(r"^(#{1,4}) (.*)", ln)
        if m:
            n = len(m.group(1))
            out.append(f"<h{n}>{inline(m.group(2))}</h{n}>")
        elif ln.startswith("|"):
            rows = []
            while i < len(lines) and lines[i].startswith("|"):
                rows.append([c.strip() for c in lines[i].strip().strip("|").split("|")])
                i += 1
            body = [r for r in rows if not all(set(c) <= set("-: ") for c in r)]
            t = ["<table>", "<tr>" + "".join(f"<th>{inline(c)}</th>" for c in body[0]) + "</tr>"]
            t += ["<tr>" + "".join(f"<td>{inline(c)}</td>" for c in r) + "</tr>" for r in body[1:]]
            out.append("\n".join(t + ["</table>"]))
            continue
        else:
            m = re.match(r"^!\[([^\]]*)\]\(([^)]+)\)$", ln.strip())
            if m:
                out.append(f'<figure><img alt="{html.escape(m.group(1))}" src="{m.group(2)}">'
                           f"<figcaption>{html.escape(m.group(1))}</figcaption></figure>")
            elif ln.startswith("- "):
                out.append(f"<li>{inline(ln[2:])}</li>")
            elif ln.strip():
                out.append(f"<p>{inline(ln)}</p>")
        i += 1
    return "\n".join(out)


def write_html(path: Path, markdown: str, base_dir: Path) -> Path:
    """A self-contained HTML page of a Markdown report: every PNG embedded as base64."""
    import base64
    import re

    body = _md_to_html(markdown)

    def embed(m: re.Match) -> str:
        src = m.group(1)
        p = Path(base_dir) / src
        if p.suffix.lower() == ".png" and p.exists():
            data = base64.b64encode(p.read_bytes()).decode("ascii")
            return f'src="data:image/png;base64,{data}"'
        return m.group(0)

    body = re.sub(r'src="([^"]+)"', embed, body)
    page = f"""<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8"><title>{path.parent.name} report</title>
<style>
body {{ font-family: system-ui, sans-serif; max-width: 1100px; margin: 2em auto; padding: 0 1em; color: #222; }}
table {{ border-collapse: collapse; margin: 1em 0; font-size: 0.85em; }}
th, td {{ border: 1px solid #ccc; padding: 3px 8px; text-align: right; }}
th {{ background: #f2f2f2; }} td:first-child, th:first-child {{ text-align: left; }}
img {{ max-width: 100%; }} figure {{ margin: 1em 0; }} figcaption {{ font-size: 0.8em; color: #555; }}
pre {{ background: #f6f6f6; padding: 0.6em; overflow-x: auto; }}
</style></head><body>
{body}
</body></html>
"""
    Path(path).write_text(page)
    return Path(path)

"""The export formats: YAML, strict JSON, an importable Python module and a C99 header.

Every format carries the same document (:func:`tuner.export.provenance`): ``params`` plus the
provenance (run, fitness, objective, data, optimizer, seed, date, commit) and, where known, each
parameter's unit and the sample rate the values assume (a per-sample noise variance tuned at 1 kHz
is wrong at 286 Hz).

Non-finite values (a robustness gate switched off with ``inf``, a metric that is ``nan``) survive
every format:

- YAML: ``.inf``, ``-.inf``, ``.nan`` (YAML 1.1 floats; ``yaml.safe_load`` reads them back);
- JSON: strict RFC 8259 has no ``Infinity``/``NaN`` tokens, so a non-finite number is written as the
  string ``"inf"``, ``"-inf"`` or ``"nan"`` and the document says so in its top-level key
  ``"nonfinite"``, with the JSON pointers of those values in ``"nonfinite_paths"`` (so a string
  parameter whose value happens to be ``"inf"`` stays a string); :func:`json_load` reverses it;
- Python: ``math.inf`` / ``-math.inf`` / ``math.nan`` in a module that imports ``math``;
- C: ``INFINITY`` / ``-INFINITY`` / ``NAN`` from ``<math.h>`` (C99).

C headers put every identifier behind a prefix (``--prefix EKF1`` gives ``EKF1_Q_Q``) and use the
prefix in the include guard, so that two exported headers can be included in one translation unit.
"""

from __future__ import annotations

import json
import math
import re
from typing import Any

import numpy as np
import yaml

from tuner.records import plain as _plain

__all__ = ["to_yaml", "to_json", "json_load", "to_python", "to_c", "c_prefix", "NONFINITE_NOTE", "FORMATS"]

FORMATS = ("yaml", "json", "python", "c")

NONFINITE_NOTE = ("strict JSON (RFC 8259) has no Infinity or NaN: non-finite numbers are written as the strings "
                  "\"inf\", \"-inf\" and \"nan\"; nonfinite_paths lists where (JSON pointers)")


# --- YAML ----------------------------------------------------------------------------------------
def to_yaml(doc: dict[str, Any]) -> str:
    """YAML; non-finite floats as ``.inf``/``-.inf``/``.nan`` (read back by ``yaml.safe_load``)."""
    return yaml.safe_dump(_plain(doc), sort_keys=False)


# --- JSON ----------------------------------------------------------------------------------------
def _nonfinite_str(f: float) -> str:
    return "nan" if math.isnan(f) else ("inf" if f > 0 else "-inf")


def _encode_nonfinite(v: Any, path: str, paths: list[str]) -> Any:
    if isinstance(v, dict):
        return {k: _encode_nonfinite(x, f"{path}/{_pointer(k)}", paths) for k, x in v.items()}
    if isinstance(v, list):
        return [_encode_nonfinite(x, f"{path}/{i}", paths) for i, x in enumerate(v)]
    if isinstance(v, float) and not math.isfinite(v):
        paths.append(path)
        return _nonfinite_str(v)
    return v


def _pointer(key: str) -> str:
    return str(key).replace("~", "~0").replace("/", "~1")


def to_json(doc: dict[str, Any]) -> str:
    """Strict JSON (``allow_nan=False``): non-finite numbers as strings, listed in ``nonfinite_paths``."""
    paths: list[str] = []
    body = _encode_nonfinite(_plain(doc), "", paths)
    out = {"nonfinite": NONFINITE_NOTE, "nonfinite_paths": paths, **body} if paths else body
    return json.dumps(out, indent=2, allow_nan=False)


def json_load(text: str) -> dict[str, Any]:
    """Read a document written by :func:`to_json`, turning the listed non-finite strings back into floats."""
    doc = json.loads(text)
    if not isinstance(doc, dict):
        raise ValueError(f"expected a JSON object at the top level, got {type(doc).__name__}")
    paths = doc.pop("nonfinite_paths", [])
    doc.pop("nonfinite", None)
    for ptr in paths:
        parts = [p.replace("~1", "/").replace("~0", "~") for p in ptr.split("/")[1:]]
        node: Any = doc
        for p in parts[:-1]:
            node = node[int(p)] if isinstance(node, list) else node[p]
        last = int(parts[-1]) if isinstance(node, list) else parts[-1]
        if node[last] not in ("inf", "-inf", "nan"):
            raise ValueError(f"nonfinite_paths: {ptr} holds {node[last]!r}, expected 'inf', '-inf' or 'nan'")
        node[last] = float(node[last])
    return doc


# --- Python --------------------------------------------------------------------------------------
def _py(v: Any) -> str:
    """Python source of a plain value; non-finite floats through ``math``."""
    if isinstance(v, bool) or v is None:
        return repr(v)
    if isinstance(v, float):
        if math.isnan(v):
            return "math.nan"
        if math.isinf(v):
            return "math.inf" if v > 0 else "-math.inf"
        return repr(v)
    if isinstance(v, (int, str)):
        return repr(v)
    if isinstance(v, dict):
        return "{" + ", ".join(f"{_py(str(k))}: {_py(x)}" for k, x in v.items()) + "}"
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(_py(x) for x in v) + "]"
    return repr(str(v))


def _notes(doc: dict[str, Any]) -> list[str]:
    """One line per deployment note (e.g. how a filter scored from truth starts on live data)."""
    dep = doc.get("deployment") or {}
    what = f"{dep.get('kind')} {dep.get('name')}".strip() if dep else ""
    out = [f"Deployed: {what}; every value of it below (searched, fixed and defaults; sources in "
           "DEPLOYMENT). Settings that only served scoring (DEPLOYMENT['scoring']) are not part of it."] if dep else []
    return out + [f"Note: {n}." for n in dep.get("notes") or ()]


def to_python(doc: dict[str, Any]) -> str:
    """A module defining ``PARAMS`` (every value of the deployed system), ``UNITS``, ``PROVENANCE``,
    ``DEPLOYMENT`` (sources, choices, scoring-only settings, notes; when the run records them) and
    ``TABLES`` (when the objective exports matrices or look-up tables); importable from anywhere
    (needs only ``math``)."""
    doc = _plain(doc)
    prov = {k: v for k, v in doc.items() if k not in ("params", "units", "tables", "deployment")}
    lines = [f'"""Tuned parameters from tuner run {doc["run"]} (fitness {doc["fitness"]!r}).', "",
             _rate_line(doc), *_notes(doc), '"""', "", "import math", "",
             f"PARAMS = {_py(doc['params'])}", "", f"UNITS = {_py(doc.get('units') or {})}", "",
             f"PROVENANCE = {_py(prov)}", ""]
    if doc.get("deployment"):
        lines += [f"DEPLOYMENT = {_py(doc['deployment'])}", ""]
    if doc.get("tables"):  # {name: {"table": nested lists, "doc": ..., ...}}: matrices and look-up tables
        lines += [f"TABLES = {_py(doc['tables'])}", ""]
    return "\n".join(lines)


# --- C -------------------------------------------------------------------------------------------
def c_prefix(name: str) -> str:
    """A C identifier prefix from a run name or a user's ``--prefix``: upper case, ``[A-Z0-9_]``, no
    leading digit; ``20261122T101500Z-ekf-bench6dof-a1b2c3`` gives ``EKF_BENCH6DOF``."""
    s = str(name)
    m = re.fullmatch(r"\d{8}T\d{6}Z-(.+)-[0-9a-f]{6}", s)  # a default run directory name
    if m:
        s = m.group(1)
    s = re.sub(r"[^0-9A-Za-z_]+", "_", s).strip("_").upper()
    if not s:
        return "TUNER"
    return f"P_{s}" if s[0].isdigit() else s


def _c_ident(name: str) -> str:
    s = re.sub(r"[^0-9A-Za-z_]", "_", str(name)).upper()
    return s if s and not s[0].isdigit() else f"P_{s}"


def _c_idents(names: list[str]) -> dict[str, str]:
    """Distinct C identifiers for ``names``: names that map to the same one (``k`` and ``K``, ``a-b`` and
    ``a_b``) get ``_2``, ``_3``... in their order, never two constants of one name."""
    out: dict[str, str] = {}
    used: set[str] = set()
    for name in names:
        base = ident = _c_ident(name)
        n = 1
        while ident in used:
            n += 1
            ident = f"{base}_{n}"
        used.add(ident)
        out[name] = ident
    return out


def _c_number(v: Any) -> str:
    if isinstance(v, bool):
        return "1" if v else "0"
    if isinstance(v, int):
        return str(v)
    f = float(v)
    if math.isnan(f):
        return "NAN"
    if math.isinf(f):
        return "INFINITY" if f > 0 else "-INFINITY"
    return repr(f)


def _c_string(s: str) -> str:
    """A C string literal of ``s`` (UTF-8 bytes; non-printable and non-ASCII bytes as octal escapes)."""
    out = []
    for b in s.encode("utf-8"):
        c = chr(b)
        if c in '"\\':
            out.append("\\" + c)
        elif 32 <= b < 127 and c != "?":  # '?' escaped: no trigraphs
            out.append(c)
        else:
            out.append(f"\\{b:03o}")
    return '"' + "".join(out) + '"'


def _comment(text: Any) -> str:
    """Text safe inside a C block comment (no ``*/``, one line)."""
    return " ".join(str(text).splitlines()).replace("*/", "* /").replace("/*", "/ *")


def _rate_line(doc: dict[str, Any]) -> str:
    rate = doc.get("sample_rate_hz")
    note = doc.get("sample_rate_note") or ""
    if isinstance(rate, (int, float)) and math.isfinite(rate):
        s = f"Sample rate the values assume: {rate:.6g} Hz"
    else:
        s = "Sample rate the values assume: unknown (not given by the run's data)"
    return s + (f" ({note})." if note else ".")


def _c_value(prefix: str, name: str, v: Any, choices: list | None, ident: str | None = None) -> list[str]:
    """The C lines of one value: booleans as ``int`` 0/1, numbers as ``int``/``double`` (arrays of
    numbers as ``double[]``), an option with choices as one ``#define`` per choice and an ``int`` equal to
    the chosen one; other strings have no C form (a comment)."""
    ident = f"{prefix}_{ident or _c_ident(name)}"
    if isinstance(v, bool) or isinstance(v, int):
        return [f"static const int {ident} = {_c_number(v)};"]
    if isinstance(v, float):
        return [f"static const double {ident} = {_c_number(v)};"]
    if isinstance(v, str) and choices and v in choices:
        lines = [f"#define {ident}_{_c_ident(c)} {i} /* {_comment(c)} */" for i, c in enumerate(choices)]
        return lines + [f"static const int {ident} = {ident}_{_c_ident(v)};"]
    if isinstance(v, list) and v and all(isinstance(x, (int, float)) and not isinstance(x, bool) for x in v):
        return [f"static const double {ident}[{len(v)}] = {{{', '.join(_c_number(float(x)) for x in v)}}};"]
    return [f"/* {_comment(name)}: {_comment(repr(v))} has no C form */"]


def to_c(doc: dict[str, Any], prefix: str = "TUNER", tables: dict[str, Any] | None = None) -> str:
    """A C99 header: ``static const`` values (``int``, ``double``, ``double[]``), choices, look-up tables.

    Compiles with ``cc -std=c99 -Wall -Wextra -Werror -pedantic``; booleans are ``int`` 0/1, an option
    with a set of choices is one ``#define PREFIX_NAME_CHOICE i`` per choice and ``static const int
    PREFIX_NAME`` equal to the chosen one (strings are never C strings), non-finite values use
    ``INFINITY``/``NAN`` of ``<math.h>``. Settings that only served scoring are a comment, never values.
    ``prefix`` must be a C identifier (see :func:`c_prefix`).
    """
    if not re.fullmatch(r"[A-Za-z_][A-Za-z0-9_]*", prefix or ""):
        raise ValueError(f"prefix: expected a C identifier ([A-Za-z_][A-Za-z0-9_]*), got {prefix!r}")
    doc = _plain(doc)
    units = doc.get("units") or {}
    guard = f"{prefix}_TUNED_PARAMS_H"
    lines = [
        f"/* Tuned parameters exported by tuner from run {_comment(doc['run'])}.",
        f" * Fitness {_comment(repr(doc['fitness']))}; optimizer {_comment(doc.get('optimizer'))}; "
        f"seed {_comment(doc.get('seed'))}; {_comment(doc.get('n_evals'))} evaluations.",
        f" * Objective {_comment(json.dumps(doc.get('objective', {})))}.",
        f" * {_comment(_rate_line(doc))}",
        f" * Exported {_comment(doc.get('exported'))}; commit {_comment(doc.get('git_commit') or 'unknown')}.",
        " * Units (per parameter, as the objective defines them):",
    ]
    idents = _c_idents([*doc["params"], *(tables or {})])
    dep = doc.get("deployment") or {}
    sources = dep.get("sources") or {}
    for name in doc["params"]:
        src = f" [{sources[name]}]" if name in sources else ""
        renamed = f" (parameter {_comment(name)})" if idents[name] != _c_ident(name) else ""
        lines.append(f" *   {prefix}_{idents[name]}{renamed}: {_comment(units.get(name) or 'unit not declared')}{src}")
    for line in _notes(doc):
        lines.append(f" * {_comment(line)}")
    for key, v in (dep.get("scoring") or {}).items():  # never values: they only served scoring the run
        lines.append(f" * Scoring only (not part of the deployed system): {_comment(key)} = {_comment(json.dumps(v))}")
    lines += [" */", f"#ifndef {guard}", f"#define {guard}", "", "#include <math.h> /* INFINITY, NAN */", ""]
    choices = dep.get("choices") or {}
    for name, v in doc["params"].items():
        lines += _c_value(prefix, name, v, choices.get(name), idents[name])
    for name, t in (tables or {}).items():
        ident = f"{prefix}_{idents[name]}"
        arr = np.asarray(t["table"], float)
        if arr.ndim == 1:
            arr = arr[None, :]
        ny, nx = arr.shape
        if "x_range" in t or "y_range" in t:
            what = f"look-up table {_comment(name)}: rows follow y, columns follow x"
        else:  # a matrix (e.g. a gain): NY rows, NX columns
            what = f"matrix {_comment(name)} ({ny} x {nx}, row-major)"
        for key in ("doc", "unit"):
            if t.get(key):
                what += f"; {_comment(t[key])}"
        lines += ["", f"/* {what} */", f"#define {ident}_NX {nx}", f"#define {ident}_NY {ny}"]
        for key, lab in (("x_range", "X"), ("y_range", "Y")):
            if key in t:
                lines += [f"static const double {ident}_{lab}_MIN = {_c_number(float(t[key][0]))};",
                          f"static const double {ident}_{lab}_MAX = {_c_number(float(t[key][1]))};"]
        lines.append(f"static const double {ident}[{ny}][{nx}] = {{")
        for row in arr:
            lines.append("    {" + ", ".join(_c_number(float(x)) for x in row) + "},")
        lines.append("};")
    lines += ["", f"#endif /* {guard} */", ""]
    return "\n".join(lines)

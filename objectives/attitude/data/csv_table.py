"""A CSV file's table as loggers write it: header rows, names from merged cells, delimiter, decimal mark, comments.

The layout options of a ``csv:`` data spec (:mod:`objectives.attitude.data.csv`):

``header_rows``  rows before the data (default 1). One of them holds the column names (``names_row``, counted
                 from 1, default 1); the others (a units row, a title) are skipped. ``header_rows: 0``: no
                 names in the file; columns are called ``col1``, ``col2``, ...
``delimiter``    the field separator, one character (``,`` by default; ``;`` and a tab are common).
``decimal``      the decimal mark, ``.`` (default) or ``,``.
``comment``      a character: a line starting with it is skipped (before the header too), and the rest of a
                 data line after it is ignored.

Column names follow one rule (the one pandas applies to repeated names, extended to empty cells, which is how
a spreadsheet saves a merged header cell): a cell's text stripped of spaces; an empty cell takes the name of
the nearest named cell to its left with ``.1``, ``.2``, ... appended (``gyro;;`` gives ``gyro``, ``gyro.1``,
``gyro.2``); a name seen before also gets the next suffix; an empty cell with no name to its left is
``col<position>``. A data row longer than the names row gives its extra columns ``col<position>`` names.
"""

from __future__ import annotations

import csv as _csv
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from objectives.attitude.data.recording import RecordingError

__all__ = ["Table", "read_table", "column_names", "LAYOUT_OPTIONS"]

#: the layout keys of a ``csv:`` spec read here (their defaults)
LAYOUT_OPTIONS = {"delimiter": ",", "header_rows": 1, "names_row": 1, "decimal": ".", "comment": None}


@dataclass(frozen=True)
class Table:
    """The data rows of a CSV file by column name.

    Attributes
    ----------
    path : Path
    names : list of str
        Column names in file order (the rule of the module docstring).
    frame : pandas.DataFrame
        The data rows, columns named ``names``; cells as pandas parsed them (numbers, NaN for empty cells,
        or text where a column holds any).
    """

    path: Path
    names: list[str]
    frame: Any

    def __len__(self) -> int:
        return len(self.frame)


def column_names(cells: list[str], ncols: int | None = None) -> list[str]:
    """Names of the columns from a header row's ``cells`` (rule of the module docstring), padded with
    ``col<position>`` to ``ncols`` columns when the data rows are longer."""
    out: list[str] = []
    seen: dict[str, int] = {}
    last = ""
    total = max(len(cells), ncols or 0)
    for j in range(total):
        text = cells[j].strip() if j < len(cells) else ""
        if text:
            last = text
        base = text or last or f"col{j + 1}"
        if base in seen:
            seen[base] += 1
            name = f"{base}.{seen[base]}"
        else:
            seen[base] = 0
            name = base
        out.append(name)
    return out


def _check_layout(path: Path, delimiter: Any, header_rows: Any, names_row: Any, decimal: Any,
                  comment: Any) -> None:
    if not isinstance(delimiter, str) or len(delimiter) != 1 or delimiter in "\r\n\"":
        raise RecordingError(f"{path}: delimiter: expected one character (e.g. ',' ';' or a tab \"\\t\"), "
                             f"got {delimiter!r}")
    for key, v, lo in (("header_rows", header_rows, 0), ("names_row", names_row, 1)):
        if isinstance(v, bool) or not isinstance(v, int) or v < lo:
            raise RecordingError(f"{path}: {key}: expected an integer >= {lo}, got {v!r}")
    if header_rows and names_row > header_rows:
        raise RecordingError(f"{path}: names_row: {names_row} is not one of the {header_rows} header row(s)")
    if decimal not in (".", ","):
        raise RecordingError(f"{path}: decimal: expected '.' or ',', got {decimal!r}")
    if decimal == delimiter:
        raise RecordingError(f"{path}: decimal: {decimal!r} is also the delimiter; set delimiter: ';'")
    if comment is not None and (not isinstance(comment, str) or len(comment) != 1 or comment == delimiter):
        raise RecordingError(f"{path}: comment: expected one character other than the delimiter (e.g. '#'), "
                             f"got {comment!r}")


def _header(path: Path, header_rows: int, comment: str | None) -> tuple[list[str], int]:
    """The header rows' lines (comment and blank lines before and among them skipped) and the number of
    physical lines they take."""
    lines: list[str] = []
    used = 0
    try:
        with open(path, newline="", encoding="utf-8-sig") as f:
            for raw in f:
                if len(lines) == header_rows:
                    break
                used += 1
                text = raw.rstrip("\r\n")
                if not text.strip() or (comment and text.lstrip().startswith(comment)):
                    continue
                lines.append(text)
    except UnicodeDecodeError as exc:
        raise RecordingError(f"{path}: not a text file in UTF-8 ({exc.reason} at byte {exc.start})") from None
    if len(lines) < header_rows:
        raise RecordingError(f"{path}: header_rows: {header_rows}, but the file has {len(lines)} non-empty "
                             "line(s)")
    return lines, used


def read_table(path: str | Path, *, delimiter: str = ",", header_rows: int = 1, names_row: int = 1,
               decimal: str = ".", comment: str | None = None) -> Table:
    """The data rows of ``path`` by column name (layout options of the module docstring).

    Raises
    ------
    RecordingError
        Naming the file and the option: a bad layout option, fewer lines than ``header_rows``, a file
        pandas cannot parse (rows of differing length, binary data).
    """
    import pandas as pd

    path = Path(path)
    _check_layout(path, delimiter, header_rows, names_row, decimal, comment)
    lines, skip = _header(path, header_rows, comment)
    cells = next(_csv.reader([lines[names_row - 1]], delimiter=delimiter)) if header_rows else []
    try:
        df = pd.read_csv(path, sep=delimiter, header=None, skiprows=skip, comment=comment, decimal=decimal,
                         skipinitialspace=True, skip_blank_lines=True, encoding="utf-8-sig")
    except pd.errors.EmptyDataError:
        df = pd.DataFrame(columns=range(len(cells)))
    except Exception as exc:  # pandas raises several parser/IO error types
        raise RecordingError(f"{path}: cannot read as CSV ({type(exc).__name__}: {' '.join(str(exc).split())})"
                             ) from None
    names = column_names(cells, df.shape[1])
    for j in range(df.shape[1], len(names)):  # rows shorter than the names row: their last cells are empty
        df[j] = np.nan
    df.columns = names
    if decimal == ",":  # a column pandas left as text (one bad cell): read its numbers with the decimal comma
        for c in df.columns:
            if not pd.api.types.is_numeric_dtype(df[c]):
                df[c] = df[c].astype(str).str.replace(",", ".", regex=False).where(df[c].notna())
    return Table(path, names, df)


def numeric_column(table: Table, name: str) -> tuple[np.ndarray, int]:
    """Column ``name`` as floats (empty cells NaN) and the index of its first cell that is text, not a number
    (-1 when none)."""
    import pandas as pd

    raw = table.frame[name]
    vals = pd.to_numeric(raw, errors="coerce").to_numpy(dtype=float)
    not_num = np.isnan(vals) & raw.notna().to_numpy()
    return vals, int(np.argmax(not_num)) if not_num.any() else -1


def delimiter_hint(table: Table, delimiter: str) -> str:
    """``; the file looks ';'-separated: set delimiter: ';'`` when the names hold another common separator."""
    for d in (";", "\t", ",", "|"):
        if d != delimiter and any(d in n for n in table.names):
            return f"; the names hold {d!r}: is the file {d!r}-separated? set delimiter: {d!r}"
    return ""

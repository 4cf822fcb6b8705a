"""Numeric CSV tables as users export them: one reader for every hillsim CSV input.

What a spreadsheet or a digitizer may hand over, and what :func:`read_table` does with it:

- a UTF-8 byte-order mark (Excel's "CSV UTF-8"): accepted;
- semicolon- or tab-separated columns (spreadsheets in locales whose decimal separator is a comma): the delimiter
  is detected from the header line; with a semicolon or tab a decimal comma is accepted when no cell mixes commas and
  points. The choice is stated in :attr:`Table.note` (the callers print it as a warning);
- blank lines: skipped;
- a non-UTF-8 file, a short or long row, a cell that is not a finite number: an
  :class:`~hillchart.errors.InputError` naming the file, the line and the column.

Rows are numbered as the file's lines (header = row 1, blank lines counted), in every message and in
:attr:`Table.lines`, so ``row 302`` is line 302 in an editor.
"""

from __future__ import annotations

import csv
import io
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from hillchart.errors import InputError

DELIMITER_NAMES = {",": "comma", ";": "semicolon", "\t": "tab"}


@dataclass(frozen=True, eq=False)
class Table:
    """A numeric table read by :func:`read_table`.

    Attributes
    ----------
    columns : dict[str, ndarray]
        The requested columns (float arrays, one value per data row).
    lines : ndarray of int
        The file line number of each data row (header = line 1).
    header : list[str]
        The header as read.
    note : str or None
        How an unusual file was read (delimiter, decimal comma), for a warning; None for a plain CSV.
    """

    columns: dict
    lines: np.ndarray
    header: list
    note: str | None = None


def read_text(path: Path, what: str = "file") -> str:
    """The text of a UTF-8 file (a byte-order mark is dropped); errors are InputErrors naming the file."""
    try:
        return Path(path).read_text(encoding="utf-8-sig")
    except UnicodeDecodeError as exc:
        raise InputError(f"{path}: not a UTF-8 text file {not_utf8_detail(exc)}") from None
    except IsADirectoryError:
        raise InputError(f"{path}: is a folder, expected a {what}") from None
    except OSError as exc:
        raise InputError(f"cannot read {what} {str(path)!r}: {exc.strerror}") from None


def not_utf8_detail(exc: UnicodeDecodeError) -> str:
    """Why a file is not UTF-8 and how to fix it, in parentheses (UTF-16, as Notepad's "Unicode" writes it, and a
    binary file are named as such)."""
    data = exc.object if isinstance(exc.object, (bytes, bytearray)) else b""
    if data[:2] in (b"\xff\xfe", b"\xfe\xff"):
        kind = "it is UTF-16, Notepad's \"Unicode\""
    elif b"\x00" in data[:4096]:
        kind = "it looks like a binary file"
    else:
        kind = f"byte 0x{data[exc.start]:02x} at offset {exc.start}: {exc.reason}" if data else exc.reason
    return f"({kind}); save it as UTF-8 (\"CSV UTF-8\" in a spreadsheet, \"UTF-8\" in an editor)"


def csv_rows(text: str, path, *, delimiter: str = ",") -> list[list[str]]:
    """``csv.reader`` over ``text``; a malformed file (a cell over the csv module's 128 KiB limit, a NUL byte)
    is an InputError naming the file instead of a ``_csv.Error`` traceback."""
    try:
        return list(csv.reader(io.StringIO(text, newline=""), delimiter=delimiter))
    except csv.Error as exc:
        raise InputError(f"{path}: not a readable CSV table ({exc}); is this the right file?") from None


def detect_delimiter(header_line: str) -> str:
    """``,`` unless the header has no comma but semicolons or tabs (then the one it has most of)."""
    if "," in header_line:
        return ","
    counts = {d: header_line.count(d) for d in (";", "\t")}
    best = max(counts, key=counts.get)
    return best if counts[best] else ","


def numbered_rows(text: str, where, *, comments: bool = False) -> tuple[str, list[tuple[int, list[str]]]]:
    """The delimiter of ``text`` (:func:`detect_delimiter` on its first line with something in it) and its rows
    with something in them, each with its line number (first line = 1); ``comments``: lines starting with ``#``
    are left out first. A malformed file is an InputError beginning with ``where``."""
    lines = [(no, line) for no, line in enumerate(io.StringIO(text, newline=""), start=1)
             if not (comments and line.lstrip().startswith("#"))]
    delimiter = detect_delimiter(next((line for _, line in lines if line.strip()), ""))
    try:
        rows = [(no, row) for (no, _), row in zip(lines, csv.reader((line for _, line in lines), delimiter=delimiter))]
    except csv.Error as exc:
        raise InputError(f"{where}: not a readable CSV table ({exc})") from None
    return delimiter, [(no, row) for no, row in rows if row and any(cell.strip() for cell in row)]


def decimal_commas(path, delimiter: str, cells) -> tuple[bool, str | None]:
    """Whether the numeric ``cells`` of a ``delimiter``-separated file write their decimals with a comma (only a
    semicolon- or tab-separated file may), and how the file was read, for a warning (None for a plain CSV). A cell
    that holds both a comma and a point is an InputError: the separator cannot be told."""
    if delimiter == ",":
        return False, None
    cells = list(cells)
    has_comma = any("," in c for c in cells)
    mixed = next((c for c in cells if "," in c and "." in c), None)
    if has_comma and mixed is not None:
        raise InputError(f"{path}: {DELIMITER_NAMES[delimiter]}-separated, but the cell {mixed!r} holds both a "
                         "comma and a point: save the file as CSV with a point as the decimal separator")
    return has_comma, (f"{path}: {DELIMITER_NAMES[delimiter]}-separated" + (" with decimal commas" if has_comma
                                                                            else "") + "; read as such")


def parse_number(path, line_no: int, column: str, cell: str, *, decimal_comma: bool = False) -> float:
    """One finite number from a cell; the error names file, line and column and shows the cell as written.

    An underscore is refused: Python's ``float`` reads ``4_4.02`` as 44.02 (digit grouping), which in a chart or a
    table is a typo, not a number."""
    text = cell.strip()
    if decimal_comma:
        text = text.replace(",", ".")
    if "_" in text:
        raise InputError(f"{path}: row {line_no}, column {column!r}: not a number: {cell!r} (an underscore is no "
                         "digit separator in a CSV file); write the number without it")
    try:
        value = float(text)
    except ValueError:
        raise InputError(f"{path}: row {line_no}, column {column!r}: not a number: {cell!r}") from None
    if not math.isfinite(value):
        raise InputError(f"{path}: row {line_no}, column {column!r}: value must be finite, got {cell!r}")
    return value


def without_empty_trailing_columns(header: list, body: list) -> tuple[list, list]:
    """``header`` (names, stripped) and ``body`` (``(line, cells)`` rows) without their empty trailing columns: no
    name and no value in any row of the header's width, as a spreadsheet exports a column it once used (a trailing
    comma on every line). Rows of another width are left for the caller's field count.

    Examples
    --------
    >>> without_empty_trailing_columns(["a", "b", ""], [(2, ["1", "2", ""]), (3, ["3", "4", " "])])
    (['a', 'b'], [(2, ['1', '2']), (3, ['3', '4'])])
    >>> without_empty_trailing_columns(["a", ""], [(2, ["1", "5"])])[0]  # a value: the column is the caller's
    ['a', '']
    """
    width, header = len(header), list(header)
    while (len(header) > 1 and not header[-1]
           and all(len(row) != width or not row[len(header) - 1].strip() for _, row in body)):
        header.pop()
    if len(header) == width:
        return header, body
    return header, [(no, row[:len(header)] if len(row) == width else row) for no, row in body]


def read_table(path, columns: tuple[str, ...], *, extra: str = "error", example: str | None = None,
               what: str = "CSV file") -> Table:
    """Read the numeric ``columns`` (any order) of a CSV file. Lines starting with ``#`` are comments (before the
    header or between rows); rows keep their line numbers in the file for messages. Column names match whatever
    their case and surrounding spaces (``Q11`` is ``q11``); empty trailing columns, a name-less column with no value
    that a spreadsheet exports, are dropped.

    Parameters
    ----------
    path : path
    columns : tuple of str
        Required column names.
    extra : "error" | "ignore"
        What to do with other columns.
    example : str, optional
        The header to show in messages (default ``columns`` joined by commas).
    what : str
        What the file is, for the message when it cannot be read.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> p = pathlib.Path(tempfile.mkdtemp()) / "flow.csv"
    >>> _ = p.write_bytes("\\ufeffopening;n11;q11\\n10;60,5;0,25\\n\\n12;61;0,3\\n".encode("utf-8"))
    >>> t = read_table(p, ("opening", "n11", "q11"))
    >>> t.columns["n11"].tolist(), t.lines.tolist(), t.note.split(":")[1].strip()
    ([60.5, 61.0], [2, 4], 'semicolon-separated with decimal commas; read as such')
    """
    path = Path(path)
    expected = example or ",".join(columns)
    text = read_text(path, what)
    lines_text = text.splitlines()
    # lines starting with # are comments (a digitizer's notes, a source line), anywhere in the file
    delimiter, numbered = numbered_rows(text, path, comments=True)
    if not numbered:
        raise InputError(f"{path}: empty file; expected a header {expected}")
    header_line = lines_text[numbered[0][0] - 1]
    header = [name.strip() for name in numbered[0][1]]
    header, body = without_empty_trailing_columns(header, numbered[1:])
    folded = [name.lower() for name in header]  # names match whatever their case: "Q11" is q11
    missing = [c for c in columns if c.lower() not in folded]
    if missing:
        hint = ""
        if delimiter == "," and len(header) == 1 and any(d in header_line for d in (";", "\t")):
            hint = " (the header has no comma-separated columns)"
        raise InputError(f"{path}: missing column(s) {missing}{hint}; the header must be {expected}, got "
                         f"{header_line!r}")
    unknown = [name for name, f in zip(header, folded) if f not in {c.lower() for c in columns}]
    if unknown and extra == "error":
        raise InputError(f"{path}: unknown column(s) {unknown}; the header must be {expected}")
    if len(set(folded)) != len(folded):
        raise InputError(f"{path}: repeated column in header {header}")
    index = [(c, folded.index(c.lower())) for c in columns]
    decimal_comma, note = decimal_commas(path, delimiter, (row[i] for _, row in body for _, i in index
                                                          if i < len(row)))
    data = {c: [] for c in columns}
    lines = []
    for line_no, row in body:
        if len(row) != len(header):
            raise InputError(f"{path}: row {line_no} has {len(row)} fields, the header has {len(header)}")
        for name, i in index:
            data[name].append(parse_number(path, line_no, name, row[i], decimal_comma=decimal_comma))
        lines.append(line_no)
    if not lines:
        raise InputError(f"{path}: no data rows below the header")
    return Table(columns={c: np.asarray(v, dtype=float) for c, v in data.items()},
                 lines=np.asarray(lines, dtype=int), header=header, note=note)

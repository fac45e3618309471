"""Text tables as loggers write them: decoding, compression, comments, exact floats.

:func:`read_text` turns a file's bytes into text whatever the logger did to it:
gzip, bzip2, xz or zstd compression (told by the content, not the name), a UTF-8
byte-order mark, UTF-16 with or without its mark. :func:`read_table` then parses
a delimited table from that text, dropping ``#`` comment lines, and reports every
problem in one line naming the file, the line and the column.
"""

from __future__ import annotations

import bz2
import csv
import gzip
import io
import lzma
import re
import warnings
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

__all__ = ["Table", "TableError", "read_csv_exact", "read_csv_numbers", "read_table", "read_text"]

_PANDAS_MAJOR = int(pd.__version__.split(".")[0])

_MAGIC = (
    (b"\x1f\x8b", "gzip"),
    (b"BZh", "bzip2"),
    (b"\xfd7zXZ\x00", "xz"),
    (b"\x28\xb5\x2f\xfd", "zstd"),
)


class TableError(ValueError):
    """A text table cannot be read; the message names the file, the line and the problem."""


def read_csv_exact(src: Any, **kwargs: Any) -> pd.DataFrame:
    """``pandas.read_csv`` with exact (round-trip) float parsing.

    pandas < 3 needs ``float_precision='round_trip'`` for that; from pandas 3 the
    default parser is exact and the argument is deprecated.
    """
    if _PANDAS_MAJOR < 3:
        kwargs.setdefault("float_precision", "round_trip")
    return pd.read_csv(src, **kwargs)


def read_csv_numbers(path: str | Path, numeric: tuple[str, ...] | list[str], what: str) -> pd.DataFrame:
    """A recorder's CSV (:func:`read_csv_exact`) whose damage is refused by name.

    Parameters
    ----------
    path : str or Path
    numeric : sequence of str
        Columns that must hold numbers where present (a missing one is the caller's
        to name); an empty cell is a missing value (NaN).
    what : str
        The file in messages (``"DS1/imuData.csv"``).

    Raises
    ------
    TableError
        Empty or not text, rows a CSV parser cannot split, or text in a numeric
        column (``what: column 'c' holds 'n/a' at line 7, not a number``).
    """
    try:
        df = read_csv_exact(path)
    except pd.errors.EmptyDataError:
        raise TableError(f"{what} is empty") from None
    except UnicodeDecodeError as exc:
        raise TableError(f"{what}: bytes that are not UTF-8 text at byte {exc.start} ({exc.reason}); "
                         "not a CSV table") from None
    except pd.errors.ParserError as exc:
        raise TableError(f"{what}: not a readable CSV table ({' '.join(str(exc).split())[:160]})") from None
    for c in numeric:
        if c in df.columns and not pd.api.types.is_numeric_dtype(df[c]):
            num = pd.to_numeric(df[c], errors="coerce")
            bad = (num.isna() & df[c].notna()).to_numpy()
            if not bad.any():  # an object column of numbers and missing values
                df[c] = num
                continue
            i = int(np.flatnonzero(bad)[0])
            raise TableError(f"{what}: column {c!r} holds {str(df[c].iloc[i])[:40]!r} at line {i + 2}, "
                             "not a number")
    return df


def _decompress(raw: bytes, name: str) -> bytes:
    kind = next((k for magic, k in _MAGIC if raw.startswith(magic)), None)
    if kind is None:
        return raw
    try:
        if kind == "gzip":
            return gzip.decompress(raw)
        if kind == "bzip2":
            return bz2.decompress(raw)
        if kind == "xz":
            return lzma.decompress(raw)
        try:
            import zstandard  # optional
        except ImportError:
            raise TableError(f"{name}: zstd-compressed; decompress it first (zstd -d) or install "
                             "the 'zstandard' package") from None
        return zstandard.ZstdDecompressor().decompressobj().decompress(raw)
    except TableError:
        raise
    except Exception as exc:  # truncated or corrupt archives raise several types
        raise TableError(f"{name}: {kind}-compressed but the archive is damaged or truncated "
                         f"({type(exc).__name__}: {exc})") from None


def _utf16_without_bom(raw: bytes) -> str | None:
    """'utf-16-le' / 'utf-16-be' when every other byte of the start is NUL, else None."""
    head = raw[:400]
    if len(head) < 4:
        return None
    even, odd = head[0::2], head[1::2]
    if odd.count(0) > 0.9 * len(odd) and even.count(0) < 0.1 * len(even):
        return "utf-16-le"
    if even.count(0) > 0.9 * len(even) and odd.count(0) < 0.1 * len(odd):
        return "utf-16-be"
    return None


def read_text(path: str | Path) -> str:
    """The text of a file: decompressed and decoded, universal newlines.

    Parameters
    ----------
    path : str or Path

    Returns
    -------
    str
        Text with ``\\n`` line ends and no byte-order mark.

    Raises
    ------
    TableError
        Unreadable file, damaged archive, bytes that are not text (the line is named).
    """
    p = Path(path)
    try:
        raw = p.read_bytes()
    except FileNotFoundError:
        raise TableError(f"no such file: {p}") from None
    except IsADirectoryError:
        raise TableError(f"{p} is a folder, not a file") from None
    except OSError as exc:
        raise TableError(f"{p} cannot be read: {exc.strerror}") from None
    raw = _decompress(raw, p.name)
    if raw.startswith(b"\xef\xbb\xbf"):
        enc, raw = "utf-8", raw[3:]
    elif raw.startswith((b"\xff\xfe", b"\xfe\xff")):
        enc = "utf-16"
    else:
        enc = _utf16_without_bom(raw) or "utf-8"
    try:
        text = raw.decode(enc)
    except UnicodeDecodeError as exc:
        line = raw[: exc.start].count(b"\n") + 1
        raise TableError(f"{p.name}:{line}: bytes that are not {enc} text ({exc.reason}); "
                         "not a text table (or an encoding other than UTF-8 / UTF-16)") from None
    if "\x00" in text:
        line = text[: text.index("\x00")].count("\n") + 1
        raise TableError(f"{p.name}:{line}: NUL byte in the text; the file is binary or damaged")
    return text.lstrip("\ufeff").replace("\r\n", "\n").replace("\r", "\n")


@dataclass
class Table:
    """A parsed table and where its rows came from.

    Attributes
    ----------
    frame : DataFrame
        The columns; canonical numeric columns parsed as numbers.
    lines : ndarray of int, shape (n,)
        File line number (1-based) of each row.
    name : str
        File name for messages.
    """

    frame: pd.DataFrame
    lines: np.ndarray
    name: str


def _sniff_sep(header: str) -> str:
    counts = {s: header.count(s) for s in (",", ";", "\t")}
    best = max(counts, key=lambda s: counts[s])
    return best if counts[best] else ","


_THOUSANDS = re.compile(r"^[+-]?\d{1,3}([,.' ]\d{3})+([.,]\d+)?$")
_DECIMAL_COMMA = re.compile(r"^[+-]?\d*,\d+([eE][+-]?\d+)?$")


def read_table(
    path: str | Path,
    text: str | None = None,
    *,
    numeric: frozenset[str] | set[str] = frozenset(),
    decimal: str = ".",
    thousands: str | None = None,
    skip_first: bool = False,
) -> Table:
    """Parse a delimited text table as real loggers write it.

    ``#`` comment lines (anywhere) and blank lines are dropped; the delimiter
    (``,``, ``;`` or tab) is told from the header. Rows with an empty time ``t``
    are dropped with a warning naming the first line.

    Parameters
    ----------
    path : str or Path
        The file (read with :func:`read_text` unless ``text`` is given).
    text : str, optional
        Its text, already read.
    numeric : set of str
        Columns that must be numbers: a value that is not is refused naming the line.
    decimal : str
        Decimal mark, ``'.'`` or ``','``.
    thousands : str, optional
        Thousands separator, only where the file uses one.
    skip_first : bool
        Skip the first line (a metadata line read by the caller).

    Raises
    ------
    TableError
        One line: ``file:line: problem`` (duplicated column, ragged row, text in
        a numeric column, a separator that needs the ``decimal`` / ``thousands`` option).
    """
    p = Path(path)
    name = p.name
    if text is None:
        text = read_text(p)
    all_lines = text.split("\n")
    kept: list[str] = []
    numbers: list[int] = []
    for i, line in enumerate(all_lines):
        if (i == 0 and skip_first) or not line.strip() or line.lstrip().startswith("#"):
            continue
        kept.append(line)
        numbers.append(i + 1)
    if not kept:
        raise TableError(f"{name} is empty: no header and no samples")
    sep = _sniff_sep(kept[0])
    header = next(csv.reader([kept[0]], delimiter=sep))
    header = [h.strip() for h in header]
    seen: set[str] = set()
    for h in header:
        if h in seen:
            raise TableError(f"{name}:{numbers[0]}: duplicated column name {h!r} in the header")
        seen.add(h)
    if any(h == "" for h in header):
        raise TableError(f"{name}:{numbers[0]}: empty column name in the header (column "
                         f"{header.index('') + 1})")
    try:
        df = read_csv_exact(io.StringIO("\n".join(kept[1:])), sep=sep, names=header, header=None,
                            decimal=decimal, thousands=thousands, skipinitialspace=True,
                            dtype={"surface": str} if "surface" in header else None,
                            keep_default_na=True)
    except pd.errors.ParserError as exc:
        m = re.search(r"line (\d+)", str(exc))
        where = f"{numbers[int(m.group(1))]}" if m and int(m.group(1)) < len(numbers) else "?"
        raise TableError(f"{name}:{where}: the row has more fields than the header's "
                         f"{len(header)} columns") from None
    lines = np.asarray(numbers[1:], dtype=np.int64)
    if len(lines) != len(df):  # pandas skipped something we did not
        lines = np.arange(len(df), dtype=np.int64) + numbers[0] + 1
    for c in header:
        if c in numeric and not pd.api.types.is_numeric_dtype(df[c]):
            _refuse_text(df[c], c, lines, name, decimal, thousands)
    if "t" in df.columns and df["t"].dtype.kind == "f" and df["t"].isna().any():
        bad = df["t"].isna().to_numpy()
        warnings.warn(f"{name}:{int(lines[bad][0])}: {int(bad.sum())} row(s) with an empty time 't' "
                      "dropped", stacklevel=2)
        df = df[~bad].reset_index(drop=True)
        lines = lines[~bad]
    return Table(df, lines, name)


def _refuse_text(col: pd.Series, c: str, lines: np.ndarray, name: str, decimal: str,
                 thousands: str | None) -> None:
    num = pd.to_numeric(col, errors="coerce")
    bad = (num.isna() & col.notna()).to_numpy()
    if not bad.any():
        return
    i = int(np.flatnonzero(bad)[0])
    v = str(col.iloc[i])
    hint = ""
    if _THOUSANDS.match(v.strip()) and thousands is None:
        hint = "; it looks like a thousands separator: pass thousands=',' (or the mark used)"
    elif _DECIMAL_COMMA.match(v.strip()) and decimal != ",":
        hint = "; it looks like a decimal comma: pass decimal=','"
    raise TableError(f"{name}:{int(lines[i])}: column {c!r} holds {v[:40]!r}, not a number{hint}")

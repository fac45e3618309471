"""The memory a drive file needs when a command reads it whole, known before it is read.

A canonical Parquet drive says its size in its footer: rows and columns, read by pyarrow
without reading the data. A canonical CSV says only its size in bytes (a gzip file its
uncompressed size too, modulo 4 GiB). From them, :func:`memory_needed` estimates the peak
resident memory that reading the drive whole and running the command adds, with the
constants below, measured on simulated drives (10 to 34 columns, 60 000 to 10 million rows;
the peak resident memory of ``roadgrip info`` / ``roadgrip estimate`` less that of the same
command on a one-minute drive). The imports (about 200 MB for ``info``, 450 MB for
``estimate``) are not counted: a small drive is never refused.

:func:`check_whole_read` compares that with :data:`~roadgrip.cli.options.MEMORY_FRACTION`
of :func:`~roadgrip.cli.options.available_memory`: ``roadgrip info`` then reads a Parquet
drive in chunks and refuses a CSV in one line saying what to do; ``roadgrip estimate``
names ``--stream``. Other inputs (data sets, ROS bags, MDF4 files) are not sized.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from roadgrip.cli.options import GIB, MEMORY_FRACTION, available_memory

__all__ = [
    "CSV_BYTES_PER_BYTE",
    "READ_BYTES",
    "RUN_BYTES",
    "DriveSize",
    "WholeRead",
    "check_whole_read",
    "drive_size",
    "memory_needed",
]

READ_BYTES = (22.0, 160.0)
"""Peak memory of reading a Parquet drive whole and describing it, ``(per value, per row)``
[B]: the Arrow table, its pandas copy and the description's temporaries (``roadgrip info``:
885 / 437 / 373 B per row measured with 34 / 13 / 10 columns)."""

RUN_BYTES = {
    "brls": (19.0, 480.0),
    "slipmap": (8.0, 1120.0),
    "cascade": (8.0, 2300.0),
    "gpssm": (8.0, 2300.0),
}
"""Peak memory of ``roadgrip estimate --method M`` on a drive read whole, ``(per value, per
row)`` [B]: the drive and the estimator's per-sample arrays and result table. Measured per
row: bRLS 611 / 1006 with 13 / 34 columns (a tiled one-minute drive), 577 / 660 with 10
(the 1- and 28-hour drives of ``benchmarks/bench_long_drive.py``); slip map 1116 with 34,
1195 with 10; cascade 1527 / 1675 with 13 / 34, 2367 / 2227 with 10 (1 and 28 hours).
GP-SSM 1828 with 34 (60 000 rows; longer drives take hours) is taken as the cascade; its
particles are checked apart (:func:`~roadgrip.cli.options.check_gpssm_resources`)."""

CSV_BYTES_PER_BYTE = 7.5
"""Peak memory of reading a canonical CSV whole per byte of its text [B/B]: the text, the
parser's tokens and the frame (7.1 measured on what :meth:`~roadgrip.drive.Drive.to_csv`
writes, 17 significant digits a value; the estimators' peak, after the text is released,
stays below that)."""

PARQUET_SUFFIXES = (".parquet", ".pq")


@dataclass(frozen=True)
class DriveSize:
    """What a drive file says of its size before it is read.

    Attributes
    ----------
    path : Path
    kind : {'parquet', 'csv'}
    file_bytes : int
        Size on disk [B].
    rows, columns : int or None
        From a Parquet footer; a CSV's estimated from its first lines (None when it has
        no data line there).
    text_bytes : int or None
        A CSV's text [B]: its size, or a gzip file's uncompressed size when larger.
    """

    path: Path
    kind: str
    file_bytes: int
    rows: int | None = None
    columns: int | None = None
    text_bytes: int | None = None

    def describe(self) -> str:
        """``'day.parquet (10080000 rows x 12 columns, 310 MB)'`` or ``'log.csv (1.9 GB)'``."""
        on_disk = _bytes(self.file_bytes)
        if self.kind == "parquet":
            return f"{self.path.name} ({self.rows} rows x {self.columns} columns, {on_disk})"
        text = f", {_bytes(self.text_bytes)} of text" if self.text_bytes != self.file_bytes else ""
        rows = f", about {self.rows} rows x {self.columns} columns" if self.rows is not None else ""
        return f"{self.path.name} ({on_disk}{text}{rows})"


@dataclass(frozen=True)
class WholeRead:
    """A drive's estimated memory read whole against the memory available.

    Attributes
    ----------
    size : DriveSize
    need, available : float
        Estimated peak memory added by the command, memory available [B].
    """

    size: DriveSize
    need: float
    available: float

    @property
    def fits(self) -> bool:
        """The estimate is within :data:`~roadgrip.cli.options.MEMORY_FRACTION` of the available memory."""
        return self.need <= MEMORY_FRACTION * self.available

    def describe(self, task: str = "read whole") -> str:
        """``'<file> would need about 15.3 GiB <task>; 7.0 GiB are available (80 % usable)'``."""
        return (f"{self.size.describe()} would need about {self.need / GIB:.1f} GiB {task}; "
                f"{self.available / GIB:.1f} GiB are available ({MEMORY_FRACTION:.0%} usable)")


def _bytes(n: int | None) -> str:
    n = 0 if n is None else n
    return f"{n / 1e9:.1f} GB" if n >= 1e9 else f"{n / 1e6:.0f} MB" if n >= 1e6 else f"{n} B"


def _gzip_text_bytes(path: Path, size: int) -> int | None:
    """The uncompressed size of a gzip file (its trailer, modulo 4 GiB), None if not gzip."""
    try:
        with path.open("rb") as fh:
            if fh.read(2) != b"\x1f\x8b" or size < 18:
                return None
            fh.seek(-4, 2)
            return int.from_bytes(fh.read(4), "little")
    except OSError:
        return None


SAMPLE_BYTES = 1 << 20
"""Bytes of a CSV's text sampled, at its start and in its middle, for its columns and line
length [B]."""


def _data_lines(block: bytes, cut_start: bool) -> list[bytes]:
    lines = block.split(b"\n")
    lines = lines[1:-1] if cut_start else lines[:-1] if len(block) == SAMPLE_BYTES else lines
    return [ln for ln in lines if ln.strip() and not ln.lstrip().startswith(b"#")]


def _csv_shape(path: Path, text_bytes: int, gzip: bool) -> tuple[int, int] | None:
    """Estimated ``(rows, columns)`` of a CSV: the columns of its header, the rows from the
    mean length of the data lines in :data:`SAMPLE_BYTES` from its middle (a gzip file: from
    its start), ``#`` lines skipped."""
    import gzip as gz

    try:
        with (gz.open(path, "rb") if gzip else path.open("rb")) as fh:
            lines = _data_lines(fh.read(SAMPLE_BYTES), cut_start=False)
            if not gzip and text_bytes > 3 * SAMPLE_BYTES:
                fh.seek(text_bytes // 2)
                middle = _data_lines(fh.read(SAMPLE_BYTES), cut_start=True)
                lines = lines[:1] + middle if middle else lines
    except (OSError, EOFError):
        return None
    if len(lines) < 2:
        return None
    header, data = lines[0], lines[1:]
    columns = 1 + max(header.count(sep) for sep in (b",", b";", b"\t"))
    per_line = (sum(len(ln) for ln in data) + len(data)) / len(data)
    return max(int(text_bytes / per_line), len(data)), columns


def drive_size(path: str | Path, fmt: str | None = None) -> DriveSize | None:
    """The size of a canonical Parquet or CSV drive file, from its footer or its length.

    Parameters
    ----------
    path : str or Path
    fmt : str, optional
        ``--format``; None detects it (:func:`roadgrip.io.read.detect_format`).

    Returns
    -------
    DriveSize or None
        None for anything else (a folder, a data set, a ROS bag, an MDF4 file, a DART CSV)
        and for a file the readers will refuse (they say why).
    """
    p = Path(path)
    if fmt not in (None, "canonical") or not p.is_file():
        return None
    file_bytes = p.stat().st_size
    if p.suffix.lower() in PARQUET_SUFFIXES:
        import pyarrow.parquet as pq

        try:
            md = pq.ParquetFile(str(p)).metadata
        except Exception:  # not readable as Parquet: the reader says why
            return None
        return DriveSize(p, "parquet", file_bytes, rows=md.num_rows, columns=md.num_columns)
    if fmt is None:
        from roadgrip.io.read import detect_format

        try:
            if detect_format(p) != "canonical":
                return None
        except ValueError:
            return None
    unzipped = _gzip_text_bytes(p, file_bytes)
    text = max(file_bytes, unzipped or 0)
    shape = _csv_shape(p, text, unzipped is not None)
    rows, columns = shape if shape is not None else (None, None)
    return DriveSize(p, "csv", file_bytes, rows=rows, columns=columns, text_bytes=text)


def memory_needed(size: DriveSize, method: str | None = None) -> float:
    """Estimated peak memory [B] that reading ``size``'s drive whole and running adds.

    Parameters
    ----------
    size : DriveSize
    method : str, optional
        The estimator of ``roadgrip estimate`` (:data:`RUN_BYTES`); None for ``roadgrip info``.

    Returns
    -------
    float
        The larger of reading and running: reading a Parquet drive ``rows * (per_value *
        columns + per_row)`` (:data:`READ_BYTES`), a CSV :data:`CSV_BYTES_PER_BYTE` times
        its text; running ``rows * (per_value * columns + per_row)`` (:data:`RUN_BYTES`).
    """
    if size.kind == "csv":
        read = CSV_BYTES_PER_BYTE * float(size.text_bytes or size.file_bytes)
    else:
        read = float(size.rows) * (READ_BYTES[0] * size.columns + READ_BYTES[1])
    if method is None or size.rows is None:
        return read
    run = RUN_BYTES.get(method) or tuple(max(v) for v in zip(*RUN_BYTES.values(), strict=True))
    return max(read, float(size.rows) * (run[0] * size.columns + run[1]))


def check_whole_read(path: str | Path, fmt: str | None = None, method: str | None = None,
                     available: float | None = None) -> WholeRead | None:
    """The estimate of reading a drive whole (:func:`memory_needed`) against the memory available.

    Parameters
    ----------
    path, fmt : see :func:`drive_size`
    method : str, optional
        ``roadgrip estimate``'s method; None for ``roadgrip info``.
    available : float, optional
        Memory available [B] (default :func:`~roadgrip.cli.options.available_memory`).

    Returns
    -------
    WholeRead or None
        None when the drive is not sized (:func:`drive_size`).
    """
    size = drive_size(path, fmt)
    if size is None:
        return None
    avail = available_memory() if available is None else float(available)
    return WholeRead(size, memory_needed(size, method), avail)

"""Long drives in chunks: a canonical Parquet drive read row group by row group, estimated
chunk by chunk and written as it goes, so that memory follows the chunk, not the drive.

``roadgrip estimate --stream`` uses it; ``benchmarks/bench_long_drive.py`` measures it.
Only the columns an estimator reads are read (no truth columns). Streaming needs an
estimator that continues from its state over a block of samples, :data:`STREAM_METHODS`:
the cascade (:mod:`roadgrip.estimators.cascade.stream`), the two classifiers, bRLS
and slip map (:mod:`roadgrip.estimators.classify.stream`), and the GP-SSM
(:mod:`roadgrip.estimators.gpssm.stream`). Each method's ``run_chunks`` yields per chunk
its table, its state after the chunk and what it derived from the first chunk. Streamed,
the GP-SSM writes its estimates table; its posterior curves (``--curves``) need the whole
drive.
"""

from __future__ import annotations

import resource
import sys
import time
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import pandas as pd

STREAM_METHODS = ("cascade", "brls", "slipmap", "gpssm")
"""Methods ``--stream`` runs."""

CHUNK_ROWS = 60_000
"""Rows per chunk (10 min at 100 Hz)."""

__all__ = ["CHUNK_ROWS", "STREAM_METHODS", "drive_chunks", "peak_rss_bytes", "stream_estimate"]


def peak_rss_bytes() -> int:
    """Peak resident memory of this process so far [B].

    Linux: ``VmHWM`` of ``/proc/self/status``, the peak of this program's memory.
    ``ru_maxrss`` survives ``execve``, so a process started from a large one (a test
    worker, a notebook) would report its parent's peak. Elsewhere ``ru_maxrss``
    (KiB on Linux, bytes on macOS).
    """
    from roadgrip.cli.options import proc_kib

    peak = proc_kib("/proc/self/status", "VmHWM")
    if peak is not None:
        return int(peak)
    rss = int(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss)
    return rss if sys.platform == "darwin" else rss * 1024


def _estimator_columns(names: list[str]) -> list[str]:
    from roadgrip.drive import TRUTH_COLUMNS

    truth = set(TRUTH_COLUMNS)
    return [c for c in names if c not in truth and not c.endswith("_true")]


def drive_chunks(path: str | Path, vehicle: str | None = None, rows: int = CHUNK_ROWS, *,
                 truth: bool = False) -> tuple[int, Iterator[Any]]:
    """A canonical Parquet drive as consecutive :class:`~roadgrip.drive.Drive` chunks.

    The file is read one row group at a time: memory follows the larger of a row group
    and a chunk, not the file.

    Parameters
    ----------
    path : str or Path
        Canonical Parquet file (metadata in the schema key ``roadgrip``).
    vehicle : str, optional
        Preset or YAML overriding the file's vehicle.
    rows : int
        Rows per chunk (the last chunk may hold up to twice as many, never fewer than two).
    truth : bool
        Read the truth columns too (``roadgrip info``); the estimators never need them.

    Returns
    -------
    n_rows : int
        Rows in the file.
    chunks : iterator of Drive
        Validated chunks; the units check runs on the first one only.

    Raises
    ------
    ValueError
        Not a Parquet file, no roadgrip metadata and no vehicle.
    """
    import pyarrow as pa
    import pyarrow.parquet as pq

    from roadgrip.drive import Drive
    from roadgrip.io.canonical import parquet_meta
    from roadgrip.vehicle.params import load_vehicle

    p = Path(path)
    try:
        pf = pq.ParquetFile(str(p))
    except (pa.ArrowInvalid, OSError) as exc:
        raise ValueError(f"{p.name}: --stream needs a canonical Parquet drive ({exc})") from None
    meta = parquet_meta(pf.schema_arrow.metadata, p)
    if meta is None and vehicle is None:
        raise ValueError(f"{p.name} has no roadgrip metadata: pass the vehicle (--vehicle)")
    veh = load_vehicle(vehicle) if vehicle is not None else meta.vehicle
    extra = dict(meta.extra) if meta is not None else {}
    source = meta.source if meta is not None else p.name
    columns = list(pf.schema_arrow.names) if truth else _estimator_columns(pf.schema_arrow.names)

    def frames() -> Iterator[pd.DataFrame]:
        pending: list[pd.DataFrame] = []
        size = 0
        # one row group at a time, released before the next (pyarrow's iter_batches kept
        # about 15 MiB per row group read: 700 MiB after a day at 100 Hz instead of 450)
        for i in range(pf.num_row_groups):
            group = pf.read_row_group(i, columns=columns)
            for batch in group.to_batches(max_chunksize=rows):
                pending.append(batch.to_pandas())
                size += batch.num_rows
                if size >= rows:
                    yield pd.concat(pending, ignore_index=True)
                    pending, size = [], 0
            del group
        if pending:
            yield pd.concat(pending, ignore_index=True)

    def chunks() -> Iterator[Any]:
        held = None
        first = True
        for df in frames():
            if held is not None and len(df) < 2:  # a one-row rest joins the chunk before
                df = pd.concat([held, df], ignore_index=True)
                held = None
            if held is not None:
                yield Drive.from_frame(held, veh, source=source, extra=extra, check_units=first)
                first = False
            held = df
        if held is not None:
            yield Drive.from_frame(held, veh, source=source, extra=extra, check_units=first)

    return pf.metadata.num_rows, chunks()


def stream_estimate(path: str | Path, output: str | Path, method: str = "cascade", *,
                    vehicle: str | None = None, options: dict[str, Any] | None = None, seed: int = 0,
                    rows: int = CHUNK_ROWS, progress: Callable[[int], None] | None = None,
                    on_chunk: Callable[[Any], None] | None = None) -> dict[str, Any]:
    """Estimate a long drive chunk by chunk, writing the estimates as they come.

    Parameters
    ----------
    path, output : str or Path
        Canonical Parquet drive; ``.parquet`` / ``.pq`` (with the roadgrip estimate
        metadata) or ``.csv`` estimates.
    method : str
        One of :data:`STREAM_METHODS`.
    options : dict, optional
        Estimator options (:meth:`EstimatorConfig.from_options`).
    rows : int
        Rows per chunk.
    progress : callable, optional
        Called with the rows of each chunk.
    on_chunk : callable, optional
        Called with each chunk's result (``table``, ``state`` and ``info``: the cascade's
        :class:`~roadgrip.estimators.cascade.stream.ChunkResult`, the classifiers'
        :class:`~roadgrip.estimators.classify.stream.ClassifierChunk`), for checks.

    Returns
    -------
    dict
        ``rows``, ``wall_s``, ``samples_per_s``, ``peak_rss_bytes``, ``last`` (the final
        row as a dict) and ``duration_s``.
    """
    if method not in STREAM_METHODS:
        raise ValueError(f"--stream runs {', '.join(STREAM_METHODS)}, not {method!r}: it cannot "
                         "continue from a state over a block of samples (run the whole drive without --stream)")
    import json

    import pyarrow as pa
    import pyarrow.parquet as pq

    from roadgrip.cli.options import ESTIMATE_KEY
    from roadgrip.estimators import get

    if method == "cascade":
        from roadgrip.estimators.cascade.stream import run_chunks
    elif method == "gpssm":
        from roadgrip.estimators.gpssm.stream import run_chunks
    else:
        from roadgrip.estimators.classify.stream import run_chunks
    est = get(method)
    config = est.Config.from_options(options or {})
    _, chunks = drive_chunks(path, vehicle, rows)
    out = Path(output)
    csv = out.suffix.lower() == ".csv"
    writer = None
    n = 0
    t_first = t_last = None
    last: dict[str, Any] = {}
    t0 = time.perf_counter()
    try:
        for res in run_chunks(chunks, config, seed):
            table = res.table
            if csv:
                table.to_csv(out, mode="w" if writer is None else "a", header=writer is None, index=False)
                writer = True
            else:
                arrow = pa.Table.from_pandas(table, preserve_index=False)
                if writer is None:
                    meta = {"method": method, "config": config.to_meta(), "seed": int(seed),
                            "streamed": {"chunk_rows": int(rows)},
                            "derived": {k: v for k, v in res.info.derived.items()
                                        if isinstance(v, int | float | str | bool)}}
                    md = dict(arrow.schema.metadata or {})
                    md[ESTIMATE_KEY] = json.dumps(meta, default=str).encode()
                    schema = arrow.schema.with_metadata(md)
                    writer = pq.ParquetWriter(str(out), schema)
                writer.write_table(arrow.cast(schema))
            n += len(table)
            t_first = float(table["t"].iloc[0]) if t_first is None else t_first
            t_last = float(table["t"].iloc[-1])
            last = table.iloc[-1].to_dict()
            if progress is not None:
                progress(len(table))
            if on_chunk is not None:
                on_chunk(res)
    finally:
        if writer is not None and writer is not True:
            writer.close()
    wall = time.perf_counter() - t0
    return {"rows": n, "wall_s": wall, "samples_per_s": n / max(wall, 1e-12),
            "peak_rss_bytes": peak_rss_bytes(), "last": last,
            "duration_s": (t_last - t_first) if n else 0.0}

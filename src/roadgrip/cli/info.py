"""Command ``roadgrip info``: what a drive holds."""

from __future__ import annotations

from typing import Annotated

import typer
from rich.console import Group
from rich.table import Table

from roadgrip.cli._common import (
    AlignOpt,
    ChannelsOpt,
    DbcOpt,
    FormatOpt,
    TopicsOpt,
    VehicleOpt,
    app,
    console,
    load_drive,
)


def render(sections) -> Group:
    """Rich tables of :func:`roadgrip.io.describe.describe_drive`'s sections."""
    tables = []
    for sec in sections:
        table = Table(title=sec.title, show_header=sec.header)
        for i, name in enumerate(sec.columns):
            table.add_column(name, justify="right" if name in sec.right else "left",
                             style="bold" if not sec.header and i == 0 else None)
        for row in sec.rows:
            table.add_row(*row)
        tables.append(table)
    return Group(*tables)


@app.command()
def info(
    file: Annotated[str, typer.Argument(help="Drive file or data-set path.")],
    fmt: FormatOpt = None,
    vehicle: VehicleOpt = None,
    topics: TopicsOpt = None,
    channels: ChannelsOpt = None,
    dbc: DbcOpt = None,
    align: AlignOpt = False,
) -> None:
    """Duration, rates, signal ranges, tire excitation and sensor delays of a drive."""
    from roadgrip.cli.drive_memory import check_whole_read
    from roadgrip.cli.options import check_drive_args
    from roadgrip.io import describe_drive

    check_drive_args(file, fmt, vehicle, topics, channels)
    read = check_whole_read(file, fmt)  # before anything is read: chunks, or one line saying why not
    if read is not None and read.size.kind == "parquet" and (read.size.rows > LONG_ROWS or not read.fits):
        _long_info(file, vehicle, align)
        return
    if read is not None and not read.fits:
        raise ValueError(f"{read.describe()}: a CSV is parsed whole; convert it to Parquet, "
                         "which `roadgrip info` reads in chunks")
    drive = load_drive(file, fmt, vehicle, topics, channels, dbc)
    delays = estimate_delays(drive)
    if align:
        drive = apply_alignment(drive, delays)
    console.print(render(describe_drive(drive)))
    console.print(delay_table(delays))
    sources = source_table(drive.meta.extra)
    if sources is not None:
        console.print(sources)


LONG_ROWS = 2_000_000
"""Canonical Parquet drives longer than this are described chunk by chunk (5.6 h at 100 Hz), as are
shorter ones that would not fit in memory read whole (:mod:`roadgrip.cli.drive_memory`)."""

INFO_CHUNK_ROWS = 360_000
"""Rows per chunk of a long drive (1 h at 100 Hz); its sensor delays come from the first."""


def _long_info(file: str, vehicle: str | None, align: bool) -> None:
    """A long canonical Parquet drive described chunk by chunk (memory of one chunk)."""
    from roadgrip.cli.stream import drive_chunks
    from roadgrip.io.describe import describe_chunks

    n_rows, chunks = drive_chunks(file, vehicle, INFO_CHUNK_ROWS, truth=True)
    state: dict = {}

    def described():
        for chunk in chunks:
            if "delays" not in state:
                state["delays"] = estimate_delays(chunk)
                state["span"] = chunk.duration
            if align:
                from roadgrip.sensor_delay import align_drive

                chunk = align_drive(chunk, state["delays"])[0]
            yield chunk

    sections = describe_chunks(described())
    console.print(render(sections))
    table = delay_table(state["delays"])
    table.caption = (f"from the first {state['span']:.0f} s of {n_rows} rows (read in chunks); "
                     + (table.caption or ""))
    console.print(table)
    if align:
        console.print("--align: each chunk aligned by these delays", highlight=False)


def estimate_delays(drive) -> list:
    """:func:`roadgrip.sensor_delay.sensor_delays` of a drive."""
    from roadgrip.sensor_delay import sensor_delays

    return sensor_delays(drive)


def apply_alignment(drive, delays):
    """The drive with its reliable sensor delays removed (``--align``), a line saying which."""
    from roadgrip.sensor_delay import align_drive

    aligned, applied = align_drive(drive, delays)
    if not applied:
        console.print("--align: no reliable sensor delay to remove; the drive is used as recorded",
                      highlight=False)
        return drive
    moved = ", ".join(f"{'/'.join(d.columns)} {1000 * d.delay:+.0f} ms" for d in applied)
    console.print(f"--align: moved {moved} (against the {applied[0].reference}); "
                  f"{drive.n - aligned.n} samples at the ends dropped", highlight=False)
    return aligned


def delay_table(delays) -> Table:
    """Sensor delays (:func:`roadgrip.sensor_delay.sensor_delays`) as a rich table."""
    from rich.markup import escape

    table = Table(title="sensor delays (positive: the sensor's samples arrive late)")
    for name, right in (("sensor", False), ("against", False), ("delay [ms]", True), ("± [ms]", True),
                        ("peak corr.", True), ("windows", True), ("pairs [ms]", False), ("status", False)):
        table.add_column(escape(name), justify="right" if right else "left")
    for d in delays:
        fits = d.fits
        parts = ", ".join(f"{p} {1000 * f.delay:+.0f}" for p, f in zip(d.pairs, fits, strict=True))
        windows = min(fits, key=lambda f: f.windows)
        if not all(f.windows_total for f in fits):
            status = "no data"
        elif d.reliable:
            status = "reliable"
        elif any(f.at_edge for f in fits):
            status = "peak at the search edge"
        elif d.peak_corr < 0.5:
            status = "weak correlation"
        else:
            status = "uncertain"
        fmt = (lambda v: f"{1000 * v:+.0f}") if d.delay == d.delay else (lambda v: "-")
        std = f"{1000 * d.std:.0f}" if d.std == d.std else "-"
        table.add_row(d.sensor, d.reference, fmt(d.delay), std,
                      f"{d.peak_corr:.2f}" if d.peak_corr == d.peak_corr else "-",
                      f"{windows.windows}/{windows.windows_total}", parts, status)
    table.caption = ("r: yaw rate; reliable: peak corr. >= 0.5, ± <= 20 ms, peak inside ±1 s; "
                     "--align removes the reliable ones")
    if not delays:
        table.caption = "no pair of signals to correlate (needs ay, yaw_rate and a speed, or a pose)"
    return table


def source_table(extra: dict) -> Table | None:
    """The streams of a ROS bag or MDF4 file: rate, count and use, or None for other drives.

    Reads ``meta.extra['source_rates_hz']`` / ``['source_counts']`` and, where the
    reader gives them, which source fills which column and which were not used.
    """
    rates = extra.get("source_rates_hz") if isinstance(extra, dict) else None
    if not rates:
        return None
    counts = extra.get("source_counts") or {}
    used: dict[str, list[str]] = {}
    for section in ("signals", "extras"):
        for col, e in ((extra.get("topic_map") or {}).get(section) or {}).items():
            used.setdefault(e["topic"], []).append(col)
    units = extra.get("units") or {}
    for col, name in (extra.get("channel_map") or {}).items():
        used.setdefault(name, []).append(f"{col} (in {units[col]})" if col in units else col)
    title = "source topics" if extra.get("format") == "rosbag" else "source channels"
    table = Table(title=title)
    for name, right in (("source", False), ("rate [Hz]", True), ("samples", True), ("fills", False)):
        table.add_column(name, justify="right" if right else "left")
    for name, hz in rates.items():
        table.add_row(name, f"{hz:.2f}", str(counts.get(name, "")), ", ".join(used.get(name, [])) or "unused")
    for name in extra.get("channels_unused") or ():
        table.add_row(name, "", "", "unused")
    if extra.get("interpolation"):
        table.caption = f"time base: {extra['interpolation']}"
    return table

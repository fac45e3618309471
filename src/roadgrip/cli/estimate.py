"""Command ``roadgrip estimate``: one estimator over one drive."""

from __future__ import annotations

from dataclasses import fields
from pathlib import Path
from typing import Annotated, Any

import typer

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
    progress_bar,
)

RESULT_SUFFIXES = (".parquet", ".pq", ".csv")
"""Suffixes of ``--output`` and ``--curves``: Parquet, or CSV (the table only)."""

PLOT_SUFFIXES = (".png", ".pdf", ".svg")

PLOT_CURVE_TIMES = (4.0, 20.0, 40.0, 50.0)
"""Curve times [s from the drive start] of ``--plot`` when no ``--curve-times`` are given."""


@app.command()
def estimate(
    drive_path: Annotated[str, typer.Argument(metavar="DRIVE", help="Drive file or data-set path.")],
    method: Annotated[str, typer.Option(help="gpssm, brls, slipmap or cascade.")],
    output: Annotated[Path, typer.Option("-o", "--output", help="estimates.parquet, or .csv for the table only.")],
    vehicle: VehicleOpt = None,
    fmt: FormatOpt = None,
    topics: TopicsOpt = None,
    channels: ChannelsOpt = None,
    dbc: DbcOpt = None,
    particles: Annotated[int | None, typer.Option(help="gpssm: number of particles.")] = None,
    basis: Annotated[str | None, typer.Option(help="gpssm: tensor:10x10 (paper), separable:20, or their -odd variants (default separable-odd:20).")] = None,
    seed: Annotated[int, typer.Option(help="Random seed.")] = 0,
    linalg: Annotated[str | None, typer.Option(help="gpssm: exact (default) or fast linear algebra (docs/gpssm.md).")] = None,
    calibration: Annotated[str | None, typer.Option(help="brls/slipmap: calibration YAML.")] = None,
    curves: Annotated[Path | None, typer.Option(help="gpssm: write posterior curves here.")] = None,
    curve_times: Annotated[str | None, typer.Option(help="gpssm: comma-separated times [s].")] = None,
    plot: Annotated[Path | None, typer.Option(help="Write a PNG figure.")] = None,
    vss: Annotated[Path | None, typer.Option(help="Write VSS road friction (percent) as JSON lines.")] = None,
    align: AlignOpt = False,
    stream: Annotated[bool, typer.Option(
        "--stream", help="Long drives: read, estimate and write in chunks of 10 min with bounded "
        "memory (every method; canonical Parquet drive).")] = False,
) -> None:
    """Run one estimator over a drive and write its estimates."""
    from roadgrip import estimators
    from roadgrip.cli import options as opt

    # every option is checked before the drive is read
    opt.check_drive_args(drive_path, fmt, vehicle, topics, channels)
    opt.check_seed(seed)
    opt.check_output(output, "--output", RESULT_SUFFIXES)
    opt.check_output(curves, "--curves", RESULT_SUFFIXES)
    opt.check_output(plot, "--plot", PLOT_SUFFIXES)
    opt.check_output(vss, "--vss")
    options: dict[str, Any] = {"particles": particles, "basis": basis, "linalg": linalg,
                               "curve_times": opt.parse_curve_times(curve_times)}
    if calibration is not None:
        from roadgrip.cli.calibrate import read_calibration

        options["calibration"] = read_calibration(calibration)
    options = {k: v for k, v in options.items() if v is not None}
    est = estimators.get(method)
    takes_curves = "curve_times" in {f.name for f in fields(est.Config)}
    if curves is not None and not takes_curves:
        raise ValueError(f"option --curves does not apply to {method}")
    if plot is not None and takes_curves and "curve_times" not in options:
        options["curve_times"] = PLOT_CURVE_TIMES
    if method == "gpssm":
        opt.check_gpssm_resources(options)
    est.Config.from_options(options)  # rejects options of other methods before reading the drive
    if stream:
        _stream(drive_path, output, method, vehicle, fmt, options, seed,
                {"--plot": plot, "--vss": vss, "--curves": curves, "--align": align or None})
        return
    check_fits(drive_path, fmt, method)
    drive = load_drive(drive_path, fmt, vehicle, topics, channels, dbc)
    if align:
        from roadgrip.cli.info import apply_alignment, estimate_delays

        drive = apply_alignment(drive, estimate_delays(drive))
    from roadgrip.io.presets import preset_options

    all_options = {**preset_options(method, drive), **options}
    if method == "gpssm":
        opt.check_gpssm_resources(all_options)  # a data set's preset may change the particles
    config = est.Config.from_options(all_options)
    with progress_bar(method, drive.n) as advance:
        result = est.run(drive, config, seed, progress=advance)
    write_estimates(result, output)
    written = [output]
    if curves is not None and result.curves is not None and len(result.curves):
        write_table(result.curves, curves)
        written.append(curves)
    if vss is not None:
        from roadgrip.io.vss import write_vss

        counts = write_vss(vss, result.table, method, est.prior_band(config))
        written.append(vss)
        console.print(f"VSS: {counts['lines']} lines, MostProbable in {counts['MostProbable']}, "
                      f"LowerBound in {counts['LowerBound']}, UpperBound in {counts['UpperBound']}")
    if plot is not None:
        from roadgrip.plots import plot_estimate

        plot_estimate(method, drive, result, plot)
        written.append(plot)
    from roadgrip.cli.summary import summary_table

    console.print(summary_table(result))
    console.print(f"wrote {', '.join(str(p) for p in written)}")


def check_fits(drive_path: str, fmt: str | None, method: str) -> None:
    """Refuse, before reading it, a drive that would not fit in memory read whole, naming
    ``--stream`` (:func:`roadgrip.cli.drive_memory.check_whole_read`)."""
    from roadgrip.cli.drive_memory import check_whole_read

    read = check_whole_read(drive_path, fmt, method)
    if read is None or read.fits:
        return
    what = read.describe(f"read whole for {method}")
    stream = "--stream (10-minute chunks in bounded memory; it writes the estimates only)"
    if read.size.kind == "parquet":
        raise ValueError(f"{what}: use {stream}")
    raise ValueError(f"{what}: a CSV is parsed whole; convert it to Parquet and use {stream}")


def _stream(drive_path: str, output: Path, method: str, vehicle: str | None, fmt: str | None,
            options: dict[str, Any], seed: int, others: dict[str, Any]) -> None:
    """``--stream``: the drive in chunks (:func:`roadgrip.cli.stream.stream_estimate`)."""
    from roadgrip.cli.stream import STREAM_METHODS, drive_chunks, stream_estimate

    if method not in STREAM_METHODS:
        raise ValueError(f"--stream runs {', '.join(STREAM_METHODS)}, not {method!r} (it cannot continue "
                         "from a state over a block of samples); run the whole drive without --stream")
    given = [k for k, v in others.items() if v is not None]
    if given:
        raise ValueError(f"--stream writes the estimates only: {', '.join(given)} need the whole drive")
    if fmt not in (None, "canonical") or Path(drive_path).suffix.lower() not in (".parquet", ".pq"):
        raise ValueError(f"--stream reads canonical Parquet drives, not {Path(drive_path).name!r}")
    n_rows, _ = drive_chunks(drive_path, vehicle)
    with progress_bar(f"{method} (streamed)", n_rows) as advance:
        stats = stream_estimate(drive_path, output, method, vehicle=vehicle, options=options, seed=seed,
                                progress=advance)
    last = stats["last"]
    if method == "cascade":
        for axle in ("front", "rear"):
            console.print(f"peak friction {axle} (final): {last[f'mu_{axle}']:.3f}  "
                          f"[{last[f'mu_{axle}_lower']:.3f}, {last[f'mu_{axle}_upper']:.3f}]", highlight=False)
    else:
        console.print(f"grip class (final): {last['grip_class']}, grip index {last['grip_index']:.2f}",
                      highlight=False)
    console.print(f"{stats['rows']} samples ({stats['duration_s'] / 3600:.2f} h) in {stats['wall_s']:.1f} s: "
                  f"{stats['samples_per_s']:.0f} samples/s, peak memory "
                  f"{stats['peak_rss_bytes'] / 2**20:.0f} MiB", highlight=False)
    console.print(f"wrote {output}")


def write_table(table, path: Path) -> None:
    """A table as Parquet (``.parquet``, ``.pq``) or CSV (``.csv``), by the name's suffix."""
    if path.suffix.lower() == ".csv":
        table.to_csv(path, index=False)
    else:
        table.to_parquet(path, index=False)


def write_estimates(result, path: Path) -> None:
    """The estimates as Parquet with their metadata (``roadgrip map`` reads it back), or as
    CSV, the per-sample table only, for a name ending in ``.csv``."""
    if path.suffix.lower() == ".csv":
        result.table.to_csv(path, index=False)
    else:
        result.to_parquet(path)

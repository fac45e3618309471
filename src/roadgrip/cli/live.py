"""Commands ``roadgrip live`` (CAN in, friction out) and ``roadgrip replay`` (a drive onto a bus)."""

from __future__ import annotations

import math
import sys
from pathlib import Path
from typing import Annotated, Any

import typer

from roadgrip.cli._common import FormatOpt, VehicleOpt, app, err_console, load_drive

InterfaceOpt = Annotated[str | None, typer.Option(
    "--interface", help="python-can interface: socketcan, vector, pcan, kvaser, virtual, udp_multicast, ...")]
ChannelOpt = Annotated[str | None, typer.Option("--channel", help="Bus channel (can0, a virtual bus name, ...).")]
DbcFileOpt = Annotated[str | None, typer.Option("--dbc", help="DBC file (default the shipped roadgrip.dbc).")]
MapOpt = Annotated[str | None, typer.Option(
    "--map", help="Signal map YAML: DBC signal -> canonical column (default the shipped one).")]


def _codec(dbc: str | None, signals: str | None) -> tuple[Any, dict[str, Any], str]:
    from roadgrip.io.can import SHIPPED_DBC, SHIPPED_MAP, load_dbc, load_signal_map

    path = Path(dbc) if dbc is not None else SHIPPED_DBC
    return load_dbc(path), load_signal_map(signals if signals is not None else SHIPPED_MAP), path.name


def _udp(text: str) -> tuple[str, int]:
    host, _, port = text.rpartition(":")
    if not host or not port.isdigit() or not 0 < int(port) < 65536:
        raise ValueError(f"--udp must be HOST:PORT, got {text!r}")
    return host, int(port)


@app.command()
def live(
    method: Annotated[str, typer.Option(help="cascade, brls, slipmap or gpssm.")] = "cascade",
    interface: InterfaceOpt = None,
    channel: ChannelOpt = None,
    log: Annotated[Path | None, typer.Option(
        "--log", help="Read the frames from a CAN log (.blf, .asc, .trc) instead of a bus.")] = None,
    speed: Annotated[float, typer.Option(
        help="--log: log seconds per wall second (1: as recorded; 0: as fast as possible).")] = 0.0,
    dbc: DbcFileOpt = None,
    signals: MapOpt = None,
    vehicle: VehicleOpt = None,
    vss: Annotated[str | None, typer.Option(
        "--vss", help="Write VSS JSON lines: '-' for stdout, or a file.")] = None,
    udp: Annotated[str | None, typer.Option("--udp", help="Send VSS JSON lines as UDP datagrams to HOST:PORT.")] = None,
    can_out: Annotated[bool, typer.Option(
        "--can-out", help="Send the map's output message (e.g. RG_Friction) on the bus.")] = False,
    view: Annotated[int | None, typer.Option(
        "--view", help="Serve the Foxglove live view on this port (ws://127.0.0.1:PORT).")] = None,
    warmup: Annotated[float, typer.Option(help="Seconds of rows the estimator derives its constants from [s].")] = 1.0,
    idle: Annotated[float, typer.Option(help="End after this long without a frame, once frames came [s].")] = 5.0,
    reconnect: Annotated[int, typer.Option(help="Times to reopen a bus that went away.")] = 0,
    max_rows: Annotated[int | None, typer.Option(help="End after this many rows.")] = None,
    particles: Annotated[int | None, typer.Option(help="gpssm: number of particles.")] = None,
    seed: Annotated[int, typer.Option(help="Random seed.")] = 0,
) -> None:
    """Estimate friction live from a CAN bus (or a CAN log) and write it out as it comes."""
    from roadgrip.cli import options as opt

    opt.check_vehicle(vehicle)
    if (log is None) == (interface is None):
        raise ValueError("give a bus (--interface, --channel) or a CAN log (--log), one of the two")
    if log is not None and can_out:
        raise ValueError("--can-out needs a bus (--interface)")
    opt.check_input(log, "--log")
    if vss not in (None, "-"):
        opt.check_output(vss, "--vss")
    address = _udp(udp) if udp is not None else None
    if not (speed >= 0 and math.isfinite(speed)):
        raise ValueError(f"--speed must be 0 (as fast as possible) or a positive factor, got {speed}")
    if not (math.isfinite(warmup) and warmup > 0):
        raise ValueError(f"--warmup must be a positive number of seconds, got {warmup}")
    from roadgrip.io.can import FrameDecoder, FrameEncoder
    from roadgrip.io.mapping import map_vehicle
    from roadgrip.live.assembler import RowAssembler
    from roadgrip.live.loop import run_live
    from roadgrip.live.replay import LogSource, open_bus
    from roadgrip.live.runner import LiveEstimator
    from roadgrip.live.sinks import CanSink, FoxgloveSink, UdpSink, VssSink

    db, m, dbc_name = _codec(dbc, signals)
    veh = map_vehicle(m, vehicle, "roadgrip live", "signal map")
    decoder = FrameDecoder(db, m, dbc_name)
    options = {"particles": particles} if particles is not None else {}
    est = LiveEstimator(method, veh, decoder.columns, options, warmup=warmup, seed=seed)

    def open_source() -> Any:
        if log is not None:
            return LogSource(log, speed if speed > 0 else float("inf"))
        return open_bus(interface, channel)  # type: ignore[arg-type]

    source = open_source()
    sinks: list[Any] = []
    vss_file = None
    try:
        if vss == "-":
            sinks.append(VssSink(sys.stdout))
        elif vss is not None:
            vss_file = open(vss, "w")
            sinks.append(VssSink(vss_file))
        if address is not None:
            sinks.append(UdpSink(*address))
        if can_out:
            if not m.get("output"):
                raise ValueError("--can-out needs the signal map's 'output' message")
            sinks.append(CanSink(source, FrameEncoder(db, m), m["output"]))
        if view is not None:
            sinks.append(FoxgloveSink(est, port=view))
            err_console.print(f"live view: ws://127.0.0.1:{sinks[-1].port} (Foxglove Studio: open connection)")
        stats = run_live(source, RowAssembler(decoder), est, sinks, idle=idle, max_rows=max_rows,
                         reconnect=reconnect, open_source=open_source)
    finally:
        for s in sinks:
            s.close()
        if vss_file is not None:
            vss_file.close()
        if hasattr(source, "shutdown"):
            source.shutdown()
    lat = stats.latency_summary()
    dropped = {k: v for k, v in stats.frames_report.items() if k not in ("accepted", "ignored") and v}
    err_console.print(
        f"{stats.rows} rows from {stats.frames} frames ({stats.frames_report.get('accepted', 0)} accepted, "
        f"dropped: {dropped or 'none'}); claims withheld for silent signals in {stats.withheld} rows; "
        f"latency p50 {lat['p50']:.2f} ms, p99 {lat['p99']:.2f} ms, max {lat['max']:.2f} ms; ended: {stats.ended}",
        highlight=False, soft_wrap=True)


@app.command()
def replay(
    drive_path: Annotated[str, typer.Argument(metavar="DRIVE", help="Drive file or data-set path.")],
    interface: InterfaceOpt = None,
    channel: ChannelOpt = None,
    log: Annotated[Path | None, typer.Option(
        "--log", help="Write the frames into a CAN log (.blf, .asc, .trc) instead of a bus.")] = None,
    speed: Annotated[float, typer.Option(
        help="Drive seconds per wall second (1: real time; 0: as fast as possible).")] = 1.0,
    dbc: DbcFileOpt = None,
    signals: MapOpt = None,
    vehicle: VehicleOpt = None,
    fmt: FormatOpt = None,
) -> None:
    """Play a drive onto a CAN bus (or into a CAN log), encoded per the DBC."""
    import can

    from roadgrip.cli import options as opt
    from roadgrip.io.can import CAN_LOG_SUFFIXES, FrameEncoder
    from roadgrip.live.replay import open_bus, replay_drive

    opt.check_drive_args(drive_path, fmt, vehicle)
    if (log is None) == (interface is None):
        raise ValueError("give a bus (--interface, --channel) or a CAN log (--log), one of the two")
    if not (speed >= 0 and math.isfinite(speed)):
        raise ValueError(f"--speed must be 0 (as fast as possible) or a positive factor, got {speed}")
    opt.check_output(log, "--log", CAN_LOG_SUFFIXES)
    db, m, _ = _codec(dbc, signals)
    encoder = FrameEncoder(db, m)
    drive = load_drive(drive_path, fmt, vehicle)
    rate = speed if speed > 0 else float("inf")
    if log is not None:
        with can.Logger(str(log)) as writer:
            sent = replay_drive(drive, writer.on_message_received, encoder, speed=float("inf"))
    else:
        bus = open_bus(interface, channel)  # type: ignore[arg-type]
        try:
            sent = replay_drive(drive, bus.send, encoder, speed=rate)
        finally:
            bus.shutdown()
    err_console.print(f"{sent} frames of {drive.n} samples ({drive.duration:.1f} s) sent to "
                      f"{log if log is not None else f'{interface}:{channel}'}", highlight=False)

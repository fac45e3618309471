"""Helpers of the live tests: a drive replayed through python-can's in-process virtual bus into
the live loop, and the causal batch run it is compared with."""

from __future__ import annotations

import itertools
import threading

import pandas as pd

from roadgrip.drive import Drive
from roadgrip.io.can import FrameDecoder, FrameEncoder

_channels = itertools.count()



def replay_live(drive: Drive, method: str, codec, *, options=None, send_wrapper=None, drop=None,
                speed: float = float("inf"), warmup: float = 1.0):
    """Replay ``drive`` on a fresh virtual bus and run the live loop on it.

    Returns the estimator (its tables kept), the list sink and the loop's stats.
    """
    from roadgrip.live.assembler import RowAssembler
    from roadgrip.live.loop import run_live
    from roadgrip.live.replay import open_bus, replay_drive
    from roadgrip.live.runner import LiveEstimator
    from roadgrip.live.sinks import ListSink

    db, m = codec
    name = f"test-live-{next(_channels)}"
    rx, tx = open_bus("virtual", name), open_bus("virtual", name)
    decoder = FrameDecoder(db, m)
    est = LiveEstimator(method, drive.vehicle, decoder.columns, options, warmup=warmup, keep_tables=True)
    sink = ListSink()
    send = tx.send if send_wrapper is None else send_wrapper(tx.send)
    th = threading.Thread(target=replay_drive, args=(drive, send, FrameEncoder(db, m)),
                          kwargs={"speed": speed, "drop": drop}, daemon=True)
    th.start()
    try:
        stats = run_live(rx, RowAssembler(decoder), est, [sink], poll=0.05, idle=1.0)
    finally:
        th.join()
        rx.shutdown()
        tx.shutdown()
    return est, sink, stats


def causal_batch(drive: Drive, method: str, warmup_rows: int, options=None) -> pd.DataFrame:
    """The method's streaming run over two chunks: the first ``warmup_rows`` rows (what it
    derives from a drive comes from them) and the rest."""
    from roadgrip.estimators import get

    if method == "cascade":
        from roadgrip.estimators.cascade.stream import run_chunks
    elif method == "gpssm":
        from roadgrip.estimators.gpssm.stream import run_chunks
    else:
        from roadgrip.estimators.classify.stream import run_chunks
    config = get(method).Config.from_options(options or {})
    first = Drive.from_frame(drive.data.iloc[:warmup_rows], drive.vehicle)
    rest = Drive.from_frame(drive.data.iloc[warmup_rows:].reset_index(drop=True), drive.vehicle)
    return pd.concat([r.table for r in run_chunks([first, rest], config, 0)], ignore_index=True)

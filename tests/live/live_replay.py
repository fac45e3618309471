"""Helpers of the live tests: a drive replayed through python-can's in-process virtual bus into
the live loop (:func:`roadgrip.live.replay.replay_live`), and the causal batch run it is
compared with."""

from __future__ import annotations

import pandas as pd

from roadgrip.drive import Drive


def replay_live(drive: Drive, method: str, codec, *, options=None, send_wrapper=None, drop=None,
                speed: float = float("inf"), warmup: float = 1.0):
    """Replay ``drive`` on a fresh virtual bus and run the live loop on it.

    Returns the estimator (its tables kept), the rows written and the loop's stats.
    """
    from roadgrip.live.replay import replay_live as replay

    res = replay(drive, method, codec=codec, options=options, speed=speed, warmup=warmup,
                 send_wrapper=send_wrapper, drop=drop, keep_tables=True)
    return res.estimator, res.rows, res.stats


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

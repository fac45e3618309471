"""The cascade over a drive given in chunks: memory bounded by the chunk, not the drive.

:func:`run_chunks` takes consecutive pieces of one drive (e.g. row groups of a Parquet
file, :func:`roadgrip.cli.stream.drive_chunks`) and yields the estimates table of each,
carrying the filter state (:func:`~roadgrip.estimators.cascade.estimator.run_filter`,
with the running noise estimates) and the sustained-grip floor from one chunk to the
next. What :func:`prepare` knows before the first sample comes from the first chunk
(the columns, the reader's metadata, the first speed); the noise levels and the
standstill that switches the biases on are estimated as the samples arrive
(:mod:`~roadgrip.estimators.cascade.running_noise`), so the chunks give the rows of
:func:`~roadgrip.estimators.cascade.estimator.run` over the whole drive. A pose velocity
the cascade differentiates itself is fitted per chunk and differs within half a window
of a seam.
"""

from __future__ import annotations

from collections.abc import Iterable, Iterator
from typing import NamedTuple

import numpy as np
import pandas as pd

from roadgrip.drive import Drive
from roadgrip.estimators.base import conform
from roadgrip.estimators.cascade.config import CascadeConfig
from roadgrip.estimators.cascade.estimator import CascadeState, init, prepare, run_filter
from roadgrip.estimators.cascade.inputs import CascadeSamples, drive_inputs, drive_pose
from roadgrip.estimators.cascade.result import output_columns
from roadgrip.estimators.protocol import DriveInfo
from roadgrip.signals import SUSTAIN_WINDOW, current_grip

__all__ = ["ChunkResult", "run_chunks"]


class ChunkResult(NamedTuple):
    """One chunk's estimates.

    Attributes
    ----------
    table : DataFrame
        The rows of the chunk's samples (the columns of :func:`run`'s table).
    state : CascadeState
        The filter after the chunk's last sample.
    info : DriveInfo
        What :func:`prepare` derived from the first chunk (the same for every chunk).
    """

    table: pd.DataFrame
    state: CascadeState
    info: DriveInfo


def run_chunks(chunks: Iterable[Drive], config: CascadeConfig | None = None,
               seed: int = 0) -> Iterator[ChunkResult]:
    """The cascade over consecutive chunks of one drive (times increasing across chunks).

    Parameters
    ----------
    chunks : iterable of Drive
        Pieces of one drive, in order; each at least two samples.
    config : CascadeConfig, optional
    seed : int

    Yields
    ------
    ChunkResult
    """
    config = config if config is not None else CascadeConfig()
    state: CascadeState | None = None
    info: DriveInfo | None = None
    tail_t = np.zeros(0)
    tail_ay = np.zeros(0)
    best = 0.0
    for chunk in chunks:
        if state is None:
            prepared = prepare(chunk, config)
            info = prepared.info
            state = init(info, config, seed)
            samples: CascadeSamples = prepared.samples  # type: ignore[assignment]
        else:
            inputs, _, _, _, candidates = drive_inputs(chunk, config)
            samples = CascadeSamples(inputs, drive_pose(chunk), candidates)
        out, new_state = run_filter(state, samples)
        t, ay = samples.inputs.t, samples.inputs.ay
        # the floor continues: the trailing window reaches into the previous chunk's tail
        tt, aa = np.concatenate([tail_t, t]), np.concatenate([tail_ay, ay])
        now = current_grip(tt, aa)[len(tail_t):]
        floor = np.maximum(np.maximum.accumulate(now), best) if len(now) else now
        best = float(floor[-1]) if len(floor) else best
        keep = tt > tt[-1] - 2.0 * SUSTAIN_WINDOW
        tail_t, tail_ay = tt[keep], aa[keep]
        table = pd.DataFrame(output_columns(out, t, samples.pose, state.params.lf, state.params.lr, floor, now))
        state = new_state
        assert info is not None
        yield ChunkResult(conform(table), state, info)

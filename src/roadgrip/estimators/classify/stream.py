"""The two classifiers over a drive given in chunks: memory bounded by the chunk, not the drive.

:func:`run_chunks` takes consecutive pieces of one drive (e.g. row groups of a Parquet
file, :func:`roadgrip.cli.stream.drive_chunks`) and yields the estimates table of each,
carrying the classifier's whole state from one chunk to the next: the kinematic stage
(:func:`roadgrip.inference.kinematic.kinematics_from`), the previous sample's time and
lateral velocity (the step and ``dvy/dt`` of a chunk's first sample), the input
prefilters, and the bRLS channels with their state machine
(:func:`~roadgrip.estimators.classify.brls.brls_block`) or the slip map's recursion
(:func:`~roadgrip.estimators.classify.slipmap.slipmap_block`). The evidence and the
regressors are per sample, and neither classifier has a trailing window.

What the classifiers derive from a drive before its first sample is the velocity aid,
from the columns present (:func:`~roadgrip.estimators.classify.frontend.classifier_info`),
which the first chunk gives as the whole drive does: the chunks give the rows of the
whole-drive ``run`` (to float round-off of the vectorised per-sample evidence).
"""

from __future__ import annotations

from collections.abc import Iterable, Iterator
from typing import NamedTuple

import pandas as pd

from roadgrip.drive import Drive
from roadgrip.estimators.base import conform
from roadgrip.estimators.classify import brls, slipmap
from roadgrip.estimators.classify.brls import BRLSEstimatorConfig, BRLSRunState
from roadgrip.estimators.classify.calibration import ClassifierConfig
from roadgrip.estimators.classify.frontend import classifier_info
from roadgrip.estimators.classify.slipmap import SlipMapEstimatorConfig, SlipMapRunState
from roadgrip.estimators.protocol import DriveInfo

__all__ = ["ClassifierChunk", "run_chunks"]


class ClassifierChunk(NamedTuple):
    """One chunk's estimates.

    Attributes
    ----------
    table : DataFrame
        The rows of the chunk's samples (the columns of the classifier's ``run`` table).
    state : BRLSRunState or SlipMapRunState
        The classifier after the chunk's last sample.
    info : DriveInfo
        What the classifier derived from the first chunk (the same for every chunk).
    """

    table: pd.DataFrame
    state: BRLSRunState | SlipMapRunState
    info: DriveInfo


def run_chunks(chunks: Iterable[Drive], config: ClassifierConfig | None = None,
               seed: int = 0) -> Iterator[ClassifierChunk]:
    """A classifier over consecutive chunks of one drive (times increasing across chunks).

    Parameters
    ----------
    chunks : iterable of Drive
        Pieces of one drive, in order; each at least one sample.
    config : BRLSEstimatorConfig or SlipMapEstimatorConfig, optional
        Which classifier and its calibration (default the uncalibrated bRLS).
    seed : int
        Not used (both classifiers are deterministic); kept for the streaming interface.

    Yields
    ------
    ClassifierChunk

    Raises
    ------
    ValueError
        A configuration of neither classifier, or a chunk that does not start after the
        previous chunk's last sample.
    """
    config = config if config is not None else BRLSEstimatorConfig()
    if isinstance(config, BRLSEstimatorConfig):
        start, block = brls.init, _brls_rows
    elif isinstance(config, SlipMapEstimatorConfig):
        start, block = slipmap.init, slipmap.slipmap_block
    else:
        raise ValueError(f"run_chunks streams the bRLS or the slip-map classifier, not a {type(config).__name__}")
    state = None
    info: DriveInfo | None = None
    for chunk in chunks:
        if state is None:
            info = classifier_info(chunk, config.settings.lateral_acceleration)
            state = start(info, config, seed)
        elif not chunk.t[0] > state.kin.t_prev:
            raise ValueError(f"chunks must follow each other in time: a chunk starts at t = {chunk.t[0]} "
                             f"after the previous one ended at {state.kin.t_prev}")
        table, state = block(chunk, state)
        assert info is not None
        yield ClassifierChunk(conform(table), state, info)


def _brls_rows(drive: Drive, state: BRLSRunState) -> tuple[pd.DataFrame, BRLSRunState]:
    table, _, new = brls.brls_block(drive, state)
    return table, new

"""The protocol every estimator follows.

An estimator is a model plus an inference rule, kept apart from everything
around it (reading drives, progress bars, plots, files). It is described by
an :class:`Estimator` record of five parts:

``Config``
    A frozen, validated dataclass deriving from :class:`EstimatorConfig`.
    Constructing it does no work beyond checking the values;
    ``Config.from_options(mapping)`` builds it from command-line style options
    and rejects an unknown option by name.
``prepare(drive, config) -> Prepared``
    Extracts what the filter needs from a :class:`~roadgrip.drive.Drive`: a
    :class:`DriveInfo` (vehicle, rates, what the method knows before the first
    sample: columns, metadata, configuration resolved for the drive; never a
    constant of later samples) and the sequence of per-step samples.
``init(info, config, seed) -> state``
    The initial state, immutable (NamedTuple of arrays, never mutated in place).
``step(state, sample) -> (state, row)``
    A pure function: the next state and the output row of this sample (a
    mapping of column name to scalar holding the contract columns of
    :data:`~roadgrip.estimators.base.CONTRACT_COLUMNS` that apply), or ``None``
    for an internal sub-step that produces no row.
``run(drive, config=None, seed=0, progress=None) -> EstimateResult``
    The whole drive at once, usually through a compiled batch kernel; it gives
    the rows that stepping gives (the common check,
    :func:`roadgrip.estimators.check.check_estimator`, asserts it).
``prior_band(config) -> (lower, upper)``
    The peak-friction band the estimator reports before it has seen any
    friction information.
``lookahead(config, info) -> float``
    The look-ahead [s]: every row, in ``run`` and in stepping, is a function of
    the samples up to its time plus this (0 for a causal estimator; a centred
    smoothing window declares its half-width). Cutting a drive at ``T`` leaves
    every row before ``T - lookahead`` unchanged (``tests/test_causality.py``);
    ``info`` (a :class:`DriveInfo`, or None for the largest over all drives)
    lets it depend on the drive's columns and nominal rate, never on its samples.
``prepare_rows(drive, config, info) -> samples`` (optional)
    The per-step samples of a piece of a drive whose start ``prepare`` has seen
    (``info``): what ``prepare`` derives from the start (the GP-SSM's sub-steps per
    sample interval) is taken from ``info``, not from the piece. Online stepping
    (:class:`~roadgrip.estimators.online.OnlineEstimator`) prepares the newest samples
    with it; without it, ``prepare(piece, config).samples``.
``step_donated(state, sample) -> (state, row)`` (optional)
    ``step`` allowed to overwrite the arrays of its input state, which the caller gives
    up (a filter whose pure ``step`` copies a large state first). Online stepping uses it;
    without it, ``step``.

The registry in :mod:`roadgrip.estimators` maps a method name to its record.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass, field, fields
from typing import Any, ClassVar, TypeVar

import numpy as np
import pandas as pd

from roadgrip.drive import Drive
from roadgrip.estimators.base import EstimateResult, ProgressCallback, conform, timed
from roadgrip.vehicle.params import VehicleParams

__all__ = [
    "DriveInfo",
    "Estimator",
    "EstimatorConfig",
    "Prepared",
    "no_lookahead",
    "rows_to_table",
    "run_by_stepping",
    "to_plain",
]

C = TypeVar("C", bound="EstimatorConfig")


@dataclass(frozen=True)
class EstimatorConfig:
    """Base of every estimator's frozen configuration.

    Subclasses are ``@dataclass(frozen=True)`` with validated fields
    (``__post_init__`` raises ``ValueError`` naming the field) and set
    ``method``.
    """

    method: ClassVar[str] = ""

    @classmethod
    def from_options(cls: type[C], options: Mapping[str, Any] | None = None) -> C:
        """Build the configuration from ``{field name: value}`` options.

        ``None`` values are left at their defaults; an unknown name raises
        ``ValueError`` naming it and the method.
        """
        options = {k: v for k, v in (options or {}).items() if v is not None}
        known = {f.name for f in fields(cls) if f.init}
        unknown = sorted(set(options) - known)
        if unknown:
            names = ", ".join(repr(u) for u in unknown)
            raise ValueError(
                f"option(s) {names} do not apply to {cls.method or cls.__name__}; "
                f"its options are: {', '.join(sorted(known))}"
            )
        return cls(**options)

    def to_meta(self) -> dict[str, Any]:
        """JSON-friendly dictionary of the fields (for ``EstimateResult.meta``)."""
        return {f.name: to_plain(getattr(self, f.name)) for f in fields(self)}


def to_plain(v: Any) -> Any:
    """``v`` as plain Python (dicts, lists, scalars) for JSON or YAML: dataclasses by field,
    mappings with string keys, tuples as lists, NumPy scalars and arrays unwrapped."""
    if dataclasses.is_dataclass(v) and not isinstance(v, type):
        return {f.name: to_plain(getattr(v, f.name)) for f in fields(v)}
    if isinstance(v, Mapping):
        return {str(k): to_plain(x) for k, x in v.items()}
    if isinstance(v, tuple | list):
        return [to_plain(x) for x in v]
    if isinstance(v, np.generic):
        return v.item()
    if isinstance(v, np.ndarray):
        return v.tolist()
    return v


@dataclass(frozen=True)
class DriveInfo:
    """What an estimator knows about a drive before its first step.

    Attributes
    ----------
    vehicle : VehicleParams
        The vehicle.
    t0 : float
        Time of the first sample [s].
    duration : float
        Drive duration [s].
    n : int
        Number of samples.
    sample_rate : float
        Nominal sample rate [Hz].
    columns : frozenset of str
        Signal columns present.
    derived : mapping
        What the method knows before its first sample: configuration resolved for
        the drive's columns and metadata (the chosen speed source, the velocity
        aid, a reader's sensor noise, ...). Nothing in it depends on a sample
        after the first: estimates from the samples (noise levels, standstills)
        are made as the samples arrive, so that a row depends on the samples up to
        its time plus the estimator's look-ahead.
    """

    vehicle: VehicleParams
    t0: float
    duration: float
    n: int
    sample_rate: float
    columns: frozenset[str]
    derived: Mapping[str, Any] = field(default_factory=dict)

    @classmethod
    def from_drive(cls, drive: Drive, **derived: Any) -> DriveInfo:
        return cls(
            vehicle=drive.vehicle,
            t0=float(drive.t[0]),
            duration=float(drive.duration),
            n=int(drive.n),
            sample_rate=float(drive.meta.sample_rate),
            columns=frozenset(drive.data.columns),
            derived=dict(derived),
        )


@dataclass(frozen=True)
class Prepared:
    """The output of ``prepare``: the drive's info and its per-step samples."""

    info: DriveInfo
    samples: Sequence[Any]


def no_lookahead(config: Any, info: DriveInfo | None = None) -> float:
    """The look-ahead of a causal estimator: 0 s."""
    return 0.0


@dataclass(frozen=True)
class Estimator:
    """One estimation method: its configuration and its functions.

    See the module docstring for the contract of each part; ``lookahead``
    defaults to :func:`no_lookahead` (causal).
    """

    name: str
    paper: str
    summary: str
    Config: type[EstimatorConfig]
    prepare: Callable[[Drive, Any], Prepared]
    init: Callable[[DriveInfo, Any, int], Any]
    step: Callable[[Any, Any], tuple[Any, Mapping[str, Any] | None]]
    run: Callable[..., EstimateResult]
    prior_band: Callable[[Any], tuple[float, float]]
    lookahead: Callable[[Any, DriveInfo | None], float] = no_lookahead
    prepare_rows: Callable[[Drive, Any, DriveInfo], Sequence[Any]] | None = None
    step_donated: Callable[[Any, Any], tuple[Any, Mapping[str, Any] | None]] | None = None


def rows_to_table(rows: Iterable[Mapping[str, Any] | None]) -> pd.DataFrame:
    """Table of the non-``None`` rows of stepping, contract columns first."""
    kept = [dict(r) for r in rows if r is not None]
    return conform(pd.DataFrame(kept))


def run_by_stepping(
    estimator: Estimator,
    drive: Drive,
    config: EstimatorConfig | None = None,
    seed: int = 0,
    progress: ProgressCallback | None = None,
    summary: Callable[[pd.DataFrame], dict[str, Any]] | None = None,
) -> EstimateResult:
    """Reference ``run``: ``prepare``, ``init`` and ``step`` over every sample.

    For estimators without a batch kernel, and for the common check.
    ``summary`` maps the table to ``meta['summary']``.
    """
    config = config if config is not None else estimator.Config()
    meta: dict[str, Any] = {"config": config.to_meta(), "seed": int(seed)}
    with timed(meta, drive.n, drive.duration):
        prepared = estimator.prepare(drive, config)
        meta["lookahead"] = float(estimator.lookahead(config, prepared.info))
        state = estimator.init(prepared.info, config, seed)
        rows = []
        for sample in prepared.samples:
            state, row = estimator.step(state, sample)
            rows.append(row)
            if progress is not None:
                progress(1)
        table = rows_to_table(rows)
    if summary is not None:
        meta["summary"] = summary(table)
    return EstimateResult(estimator.name, table, meta)

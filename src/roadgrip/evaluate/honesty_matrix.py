"""The honesty matrix: every estimator on every drive of a corpus, judged by one rule.

Each cell is one estimator on one drive, scored by
:func:`roadgrip.evaluate.honesty.score_result`: the share of samples with a wrong claim
per output path (per-axle bands, VSS, grip class, lateral-velocity band), whether the
final summary is wrong, the share with an informative claim, the median width of the
informative bands and the share flagged ``diverged``.

The corpus (:func:`corpus`):

* ``'full'``: the project's own scenarios (all, seeds 0-2), the multi-body engine (both
  vehicles, every scenario, seeds 0-1) and every recording in the shared data (DART,
  frictionmaps, revs), at their own lengths;
* ``'short'``: the same kinds of drive, shortened, one seed, one recording of each data
  set: what ``make test`` runs.

Every method runs on every drive with the data set's presets
(:func:`roadgrip.io.presets.preset_options`); the classifiers run uncalibrated.
"""

from __future__ import annotations

import re
import time
from collections.abc import Iterator
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from roadgrip.evaluate.cases import real_data_root
from roadgrip.evaluate.honesty import reference_vy, score_result

__all__ = ["METHODS", "DriveSpec", "corpus", "load_drive", "matrix", "run_cell"]

METHODS = ("gpssm", "cascade", "brls", "slipmap")
"""Every estimator of the project."""

SHORT_S = {"snow-slalom": 40.0, "dry-gravel-dry": 80.0, "f1tenth-patches": 40.0,
           "straight-cruise": 20.0, "figure-eight": 60.0}
"""Simulated durations [s] of the short corpus (dry-gravel-dry: 60 s dry, 20 s on gravel)."""

SHORT_RECORDING_S = 60.0
"""Length [s] of each recording in the short corpus (its first minute)."""

GPSSM_OPTIONS = {"basis": "separable-odd:20"}
"""The GP-SSM variant of the matrix (the project's real-data variant)."""


@dataclass(frozen=True)
class DriveSpec:
    """One drive of the corpus.

    Attributes
    ----------
    name : str
        Row name (``'sim:<scenario>:<seed>'``, ``'mb:<vehicle>:<scenario>:<seed>'``,
        ``'dart:<MMDD-HHMMSS>'``, ``'frictionmaps:DSn'``, ``'revs'``).
    scenario, vehicle, seed, duration :
        The simulation (``vehicle`` set: the multi-body engine); ``duration`` [s], None
        for the scenario's own.
    path, format :
        A recording and its reader format; ``vehicle`` its vehicle file where needed.
    """

    name: str
    scenario: str | None = None
    vehicle: str | None = None
    seed: int = 0
    duration: float | None = None
    path: str | None = None
    format: str | None = None


def corpus(size: str = "full") -> list[DriveSpec]:
    """The drives of the ``'full'`` or ``'short'`` matrix (module docstring)."""
    from roadgrip.sim.scenarios import MB_VEHICLES, SCENARIOS

    if size not in ("full", "short"):
        raise ValueError(f"matrix size must be 'full' or 'short', got {size!r}")
    short = size == "short"
    specs: list[DriveSpec] = []
    for sc, scenario in SCENARIOS.items():
        if scenario.engines == ("multibody",):
            continue
        for seed in (0,) if short else (0, 1, 2):
            specs.append(DriveSpec(f"sim:{sc}:{seed}", sc, None, seed, SHORT_S.get(sc) if short else None))
    for vehicle in MB_VEHICLES[:1] if short else MB_VEHICLES:
        for sc, scenario in SCENARIOS.items():
            if "multibody" not in scenario.engines or (short and sc not in ("snow-slalom", "dry-gravel-dry")):
                continue
            for seed in (0,) if short else (0, 1):
                specs.append(DriveSpec(f"mb:{vehicle}:{sc}:{seed}", sc, vehicle, seed,
                                       SHORT_S.get(sc) if short else None))
    root = real_data_root()
    if root is not None:
        dart = sorted((root / "dart").glob("*/*.csv"))
        for f in dart[:1] if short else dart:
            stamp = re.search(r"(\d\d)_(\d\d)_\d{4}_(\d\d)_(\d\d)_(\d\d)", f.stem)
            label = "{}{}-{}{}{}".format(*stamp.groups()) if stamp else f.stem
            specs.append(DriveSpec(f"dart:{label}", path=str(f), format="dart",
                                   duration=SHORT_RECORDING_S if short else None))
        runs = sorted(p for p in (root / "frictionmaps").glob("DS*") if p.is_dir())
        for p in runs[:1] if short else runs:
            specs.append(DriveSpec(f"frictionmaps:{p.name}", path=str(p), format="frictionmaps",
                                   duration=SHORT_RECORDING_S if short else None))
        revs = root / "revs" / "race_car_100hz.csv"
        if revs.exists():
            specs.append(DriveSpec("revs", path=str(revs), format="canonical",
                                   vehicle=str(revs.with_name("race_car.yaml")),
                                   duration=SHORT_RECORDING_S if short else None))
    return specs


def load_drive(spec: DriveSpec):
    """The drive of ``spec`` and its reference lateral velocity (or None)."""
    if spec.path is None:
        from roadgrip.sim.scenarios import simulate_scenario

        kwargs: dict[str, Any] = {"seed": spec.seed}
        if spec.duration:
            kwargs["duration"] = spec.duration
        if spec.vehicle:
            kwargs.update(engine="multibody", vehicle=spec.vehicle)
        return simulate_scenario(spec.scenario, **kwargs), None
    from roadgrip.io import read_drive

    kwargs = {"format": spec.format}
    if spec.vehicle:
        kwargs["vehicle"] = spec.vehicle
    drive = read_drive(spec.path, **kwargs)
    vy_ref = reference_vy(spec.path, drive.t)
    if spec.duration and drive.duration > spec.duration:
        drive = drive.slice_time(drive.t[0], drive.t[0] + spec.duration)
        if vy_ref is not None:
            vy_ref = vy_ref[: drive.n]
    return drive, vy_ref


def run_cell(method: str, drive: Any, vy_ref=None, seed: int = 0) -> dict[str, Any]:
    """One estimator on one drive, judged: the :class:`HonestyScore` fields and ``wall_s``."""
    from roadgrip.estimators import run_estimator
    from roadgrip.io.presets import preset_options

    options = preset_options(method, drive)
    if method == "gpssm":
        options = {**GPSSM_OPTIONS, **options}
    t0 = time.perf_counter()
    result = run_estimator(method, drive, options, seed=seed)
    wall = time.perf_counter() - t0
    s = score_result(result, drive, vy_ref=vy_ref)
    return {**asdict(s), "wrong": s.wrong, "honest": s.honest, "wall_s": wall}


def matrix(size: str = "full", methods: tuple[str, ...] = METHODS,
           drives: list[DriveSpec] | None = None) -> Iterator[dict[str, Any]]:
    """Rows of the matrix, one per (drive, method), as they are computed.

    A run that raises becomes a row with ``status`` naming the error (never silent).
    """
    for spec in drives if drives is not None else corpus(size):
        try:
            drive, vy_ref = load_drive(spec)
        except Exception as exc:  # reported as a row
            for m in methods:
                yield {"drive": spec.name, "method": m, "status": f"drive: {type(exc).__name__}: {exc}"}
            continue
        for m in methods:
            row: dict[str, Any] = {"drive": spec.name, "method": m}
            try:
                row.update(run_cell(m, drive, vy_ref), status="ok")
            except Exception as exc:  # reported as a row
                row["status"] = f"{type(exc).__name__}: {exc}"
            yield row


def table_markdown(rows: list[dict[str, Any]]) -> str:
    """The matrix as a Markdown table (percentages of samples)."""
    cols = ["drive", "method", "wrong_axle", "wrong_vss", "wrong_class", "wrong_vy",
            "summary_wrong", "informative", "width", "diverged", "status"]
    df = pd.DataFrame(rows).reindex(columns=cols)

    def fmt(c: str, v: Any) -> str:
        if isinstance(v, float) and not np.isfinite(v):
            return "–"
        if c in ("wrong_axle", "wrong_vss", "wrong_class", "wrong_vy", "informative", "diverged"):
            return f"{100 * float(v):.1f} %"
        if c == "width":
            return f"{float(v):.2f}"
        if c == "summary_wrong":
            return "WRONG" if v is True else "ok" if v is False else "–"
        return str(v)

    head = "| " + " | ".join(cols) + " |\n|" + "---|" * len(cols) + "\n"
    body = "".join("| " + " | ".join(fmt(c, r[c]) for c in cols) + " |\n" for r in df.to_dict("records"))
    return head + body


def write(rows: list[dict[str, Any]], out: Path) -> None:
    """``honesty_matrix.csv`` and ``honesty_matrix.md`` in ``out``."""
    out.mkdir(parents=True, exist_ok=True)
    pd.DataFrame(rows).to_csv(out / "honesty_matrix.csv", index=False)
    (out / "honesty_matrix.md").write_text(table_markdown(rows))

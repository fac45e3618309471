"""The benchmark cases: every estimator on every drive it applies to, and how long and hard to run.

Which estimator runs where
--------------------------
==================  =========================================  ==============================
drive               estimators                                 scored against
==================  =========================================  ==============================
snow-slalom         gpssm (tensor 10x10 exact and fast,        true curves, true peak
                    separable, odd separable)
dry-gravel-dry      gpssm (the variant of straight-cruise),    true peak, true grip class,
                    brls, slipmap                              changes
f1tenth-patches     cascade (+ friction grid)                  true peak, true cell friction
straight-cruise     all                                        no confident claim may be made
DART high / low     gpssm, brls, slipmap (calibrated on the    floor label (high 0.8, low 0.35)
                    first halves, tested on second halves)
frictionmaps DSn    cascade (+ friction grid)                  DS3-DS5 map agreement
==================  =========================================  ==============================

The true curve is the drive's parametric tire, or, for a drive that states its truth
binned (a multi-body model), its binned ``Fy / Fz`` in the same 0.5 deg slip bins
(:func:`roadgrip.truth.true_curve`); the true peak is the tire's or else the
``mu_true`` column (:func:`roadgrip.evaluate.metrics.true_peak_series`).
Every run is also judged by the project's honesty rule
(:func:`roadgrip.evaluate.honesty.score_result`): against the truth where there is
one, against the friction the car demonstrably used on the recordings.

:mod:`roadgrip.evaluate.suite` runs the cases, :mod:`roadgrip.evaluate.scoring`
scores each run and :mod:`roadgrip.evaluate.table` writes the table.
"""


from __future__ import annotations

import os
import re
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

__all__ = [
    "CLASSIFIERS",
    "DEMO",
    "FULL",
    "GPSSM_VARIANTS",
    "MB_TAG",
    "QUICK",
    "BenchSettings",
    "Case",
    "RunRecord",
    "default_cases",
    "real_data_root",
]

GPSSM_VARIANTS: dict[str, tuple[str | None, tuple[tuple[str, Any], ...]]] = {
    "gpssm": ("tensor:10x10", ()),
    "gpssm-fast": ("tensor:10x10", (("linalg", "fast"),)),
    "gpssm-sep": ("separable:20", ()),
    "gpssm-sep-odd": ("separable-odd:20", ()),
}
"""Row label -> (``--basis``, options) of the GP-SSM variants: the paper's tensor 10x10
basis with the exact per-particle linear algebra, the same with the fast backend, the
separable per-axle basis, and its odd-symmetric form."""

CLASSIFIERS = ("brls", "slipmap")
PEAK_FLAG_METHODS = ("gpssm",)
"""Methods that write ``peak_observed_*``; for the others ``mu_*`` is the friction
coefficient itself, a claim about the peak wherever its band is narrow."""
FRICTION_METHODS = ("gpssm", "cascade")

CURVE_BIN_WIDTH = float(np.radians(0.5))
"""Slip bin width [rad] of the covered range of curve errors (20 visits per bin)."""

DART_REFERENCE = {"high": 0.8, "low": 0.35}
"""Approximate peak friction of the two DART floors (data README: lateral plateaus of about
0.78 g and 0.35 g), used as the reference of real-data peak estimates."""


@dataclass(frozen=True)
class BenchSettings:
    """How long to simulate and how hard to work.

    Attributes
    ----------
    name : str
        ``'full'``, ``'quick'`` or ``'demo'``.
    durations : dict
        Scenario -> simulated duration [s] (missing or None: the scenario's own).
    particles : int or None
        GP-SSM particles (None: the method default, N = 200 as in paper 000).
    scenarios : tuple of str
        Simulated scenarios to run.
    real_data : bool
        Also run the shared real data sets where present.
    dart_files : int
        Files per DART floor to run (0: all).
    frictionmaps_runs : tuple of str
        frictionmaps runs to use.
    gpssm_variants : tuple of str
        Row labels of :data:`GPSSM_VARIANTS` to run on snow-slalom.
    gpssm_other : str
        The variant run on dry-gravel-dry, straight-cruise and the real data.
    multibody : tuple of (scenario, vehicle)
        Drives of the independent multi-body engine, each its own rows
        (drive name ``'<scenario>:mb:<vehicle>'``).
    multibody_durations : dict
        Scenario -> multi-body duration [s] (missing: the scenario's own).
    """

    name: str
    durations: dict[str, float | None] = field(default_factory=dict)
    particles: int | None = None
    scenarios: tuple[str, ...] = ("snow-slalom", "dry-gravel-dry", "f1tenth-patches", "straight-cruise")
    real_data: bool = True
    dart_files: int = 0
    frictionmaps_runs: tuple[str, ...] = ("DS1", "DS2", "DS3", "DS4", "DS5")
    gpssm_variants: tuple[str, ...] = ("gpssm", "gpssm-fast", "gpssm-sep", "gpssm-sep-odd")
    gpssm_other: str = "gpssm-sep-odd"
    multibody: tuple[tuple[str, str], ...] = (
        ("snow-slalom", "ford-escort"), ("dry-gravel-dry", "ford-escort"),
        ("figure-eight", "ford-escort"), ("straight-cruise", "ford-escort"),
        ("snow-slalom", "vw-vanagon"), ("dry-gravel-dry", "vw-vanagon"),
    )
    multibody_durations: dict[str, float] = field(default_factory=dict)

    def describe(self) -> str:
        """One line saying what was shortened or reduced."""
        parts = [f"settings '{self.name}'"]
        parts.append(f"GP-SSM particles: {self.particles or 'default (200)'}")
        short = {k: v for k, v in self.durations.items() if v}
        if short:
            parts.append("durations: " + ", ".join(f"{k} {v:g} s" for k, v in short.items()))
        else:
            parts.append("full scenario durations")
        variants = ", ".join(f"{v} ({_variant_text(v)})" for v in self.gpssm_variants)
        parts.append(f"GP-SSM on snow-slalom: {variants}")
        if self.multibody:
            mbd = ", ".join(
                f"{sc}/{v}" + (f" {self.multibody_durations[sc]:g} s" if sc in self.multibody_durations else "")
                for sc, v in self.multibody
            )
            parts.append(f"multi-body drives: {mbd}")
        parts.append("real data: " + ("yes" if self.real_data else "no"))
        return "; ".join(parts)


def _variant_text(label: str) -> str:
    basis, options = GPSSM_VARIANTS[label]
    return " ".join([basis or "default basis", *(f"{k}={v}" for k, v in options)])


FULL = BenchSettings("full")
QUICK = BenchSettings(
    "quick",
    durations={"snow-slalom": 60.0, "dry-gravel-dry": None, "f1tenth-patches": None,
               "straight-cruise": 30.0},
    particles=50,
    dart_files=1,
    frictionmaps_runs=("DS3", "DS4", "DS5"),
    gpssm_variants=("gpssm-fast", "gpssm-sep", "gpssm-sep-odd"),
    multibody=(("snow-slalom", "ford-escort"), ("dry-gravel-dry", "ford-escort"),
               ("figure-eight", "ford-escort"), ("straight-cruise", "ford-escort")),
    multibody_durations={"snow-slalom": 60.0, "figure-eight": 120.0, "straight-cruise": 30.0},
)
DEMO = BenchSettings(
    "demo",
    scenarios=("snow-slalom", "dry-gravel-dry", "f1tenth-patches"),
    real_data=False,
    gpssm_variants=("gpssm-sep-odd",),
    multibody=(("dry-gravel-dry", "ford-escort"),),
)


@dataclass(frozen=True)
class Case:
    """One estimator on one drive.

    Attributes
    ----------
    drive : str
        Scenario name, or ``'dart:<floor>:<file stem>'`` / ``'frictionmaps:DSn'``.
    label : str
        Row label of the method (``'gpssm-sep'`` for the separable GP-SSM).
    method : str
        Estimator name in :data:`roadgrip.estimators.METHODS`.
    basis : str or None
        GP-SSM basis.
    options : tuple of (name, value)
        Further options of the method's ``Config`` (``Config.from_options``).
    path : str or None
        Real data file or folder.
    format : str or None
        Real data format.
    reference : str or None
        Real data label (``'high'`` / ``'low'``).
    """

    drive: str
    label: str
    method: str
    basis: str | None = None
    options: tuple[tuple[str, Any], ...] = ()
    path: str | None = None
    format: str | None = None
    reference: str | None = None


@dataclass
class RunRecord:
    """Outcome of one :class:`Case`: status, the drive and result, and the scores."""

    case: Case
    status: str
    drive: Any = None
    result: Any = None
    metrics: dict[str, float] = field(default_factory=dict)
    details: list[str] = field(default_factory=list)
    map_cells: pd.DataFrame | None = None
    grid: Any = None
    wall_s: float = float("nan")


MB_TAG = ":mb:"
"""Separator of a multi-body drive name, ``'<scenario>:mb:<vehicle>'``."""


def real_data_root() -> Path | None:
    """The shared real data, if present.

    ``$ROADGRIP_SHARED_DATA`` when set; otherwise ``../shared/data`` beside the
    checkout (for an editable install), then beside the working directory.
    """
    env = os.environ.get("ROADGRIP_SHARED_DATA")
    if env:
        return Path(env).resolve() if Path(env).is_dir() else None
    for root in (Path(__file__).resolve().parents[3] / ".." / "shared" / "data",
                 Path.cwd() / ".." / "shared" / "data"):
        if root.is_dir():
            return root.resolve()
    return None


def default_cases(settings: BenchSettings) -> list[Case]:
    """All (drive, estimator) pairs that apply, in table order."""
    cases: list[Case] = []
    gp = [Case("", v, "gpssm", *GPSSM_VARIANTS[v]) for v in settings.gpssm_variants]
    gp_other = Case("", settings.gpssm_other, "gpssm", *GPSSM_VARIANTS[settings.gpssm_other])
    sim_methods = {
        "snow-slalom": gp,
        "dry-gravel-dry": [gp_other, *[Case("", m, m) for m in CLASSIFIERS]],
        "f1tenth-patches": [Case("", "cascade", "cascade")],
        "straight-cruise": [gp_other, *[Case("", m, m) for m in CLASSIFIERS],
                            Case("", "cascade", "cascade")],
    }
    for sc in settings.scenarios:
        for c in sim_methods.get(sc, []):
            cases.append(replace(c, drive=sc))
    mb_methods = dict(sim_methods, **{"snow-slalom": [gp_other],
                                      "figure-eight": [Case("", "cascade", "cascade")]})
    for sc, vehicle in settings.multibody:
        for c in mb_methods.get(sc, []):
            cases.append(replace(c, drive=f"{sc}{MB_TAG}{vehicle}"))
    root = real_data_root() if settings.real_data else None
    if root is not None:
        for floor, ref in (("high_grip_rubbery_floor", "high"), ("low_grip_tape_and_tiles", "low")):
            files = sorted((root / "dart" / floor).glob("*.csv"))
            if settings.dart_files:
                files = files[: settings.dart_files]
            for f in files:
                stamp = re.search(r"(\d\d)_(\d\d)_\d{4}_(\d\d)_(\d\d)", f.stem)
                name = f"dart:{ref}:" + ("{}{}-{}{}".format(*stamp.groups()) if stamp else f.stem)
                for c in (gp_other, *[Case("", m, m) for m in CLASSIFIERS]):
                    cases.append(replace(c, drive=name, path=str(f), format="dart", reference=ref))
        for ds in settings.frictionmaps_runs:
            p = root / "frictionmaps" / ds
            if p.is_dir():
                cases.append(Case(f"frictionmaps:{ds}", "cascade", "cascade", path=str(p),
                                  format="frictionmaps"))
    return cases


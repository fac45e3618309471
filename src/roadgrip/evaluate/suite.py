"""The scenario suite and ``roadgrip bench``: every estimator on every drive it applies to.

Which estimator runs where
--------------------------
==================  =========================================  ==============================
drive               estimators                                 scored against
==================  =========================================  ==============================
snow-slalom         gpssm (tensor 10x10 exact and fast,        true curves, true peak
                    separable, odd separable)
dry-gravel-dry      brls, slipmap                              true grip class, changes
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

Each run is timed and scored with :mod:`roadgrip.evaluate.metrics`; a method
whose module is not installed is reported as ``not available`` and a run that
raises is reported with its error, so one failing estimator never hides the
others. Everything is seeded: the same seed gives the same table (apart from
the timing columns).
"""

from __future__ import annotations

import importlib.util
import os
import re
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from roadgrip.evaluate import metrics as M
from roadgrip.truth import true_curve

__all__ = [
    "BENCH_COLUMNS",
    "COLUMN_NOTES",
    "DEMO",
    "FULL",
    "QUICK",
    "BenchSettings",
    "Case",
    "RunRecord",
    "bench_cli",
    "bench_table",
    "default_cases",
    "real_data_root",
    "run_suite",
    "table_markdown",
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
        The variant run on straight-cruise and the real data.
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
        Method options (``EstimateRequest.options``).
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


# -- discovery ---------------------------------------------------------------------------
def module_available(name: str) -> bool:
    """Whether a roadgrip module can be imported (without importing it)."""
    try:
        return importlib.util.find_spec(name) is not None
    except ModuleNotFoundError:
        return False


def method_available(method: str) -> bool:
    from roadgrip.estimators import METHODS

    return method in METHODS and module_available(METHODS[method])


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
        "dry-gravel-dry": [Case("", m, m) for m in CLASSIFIERS],
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


# -- running -----------------------------------------------------------------------------
def _load_drive(case: Case, settings: BenchSettings, seed: int, cache: dict):
    key = case.drive
    if key in cache:
        return cache[key]
    if case.path is not None:
        from roadgrip.io import read_drive

        drive = read_drive(case.path, format=case.format)
    else:
        from roadgrip.sim.scenarios import simulate_scenario

        if MB_TAG in case.drive:
            sc, vehicle = case.drive.split(MB_TAG)
            duration = settings.multibody_durations.get(sc)
            drive = simulate_scenario(sc, seed=seed, engine="multibody", vehicle=vehicle,
                                      duration=duration)
        else:
            duration = settings.durations.get(case.drive)
            kwargs = {"duration": duration} if duration else {}
            drive = simulate_scenario(case.drive, seed=seed, **kwargs)
    cache[key] = drive
    return drive


def _request(case: Case, settings: BenchSettings, seed: int, drive):
    from roadgrip.estimators import EstimateRequest

    options = dict(case.options)
    if case.method != "gpssm":
        return EstimateRequest(seed=seed, progress=False, options=options)
    # Curve times are relative to the drive's start: t = 50 s (paper 000) and the end.
    times = [drive.duration]
    if drive.has_truth and drive.duration > 50.0:
        times.insert(0, 50.0)
    return EstimateRequest(seed=seed, particles=settings.particles, basis=case.basis,
                           curve_times=tuple(times), progress=False, options=options)


def run_case(case: Case, settings: BenchSettings, seed: int, cache: dict) -> RunRecord:
    """Load or simulate the drive, run the estimator, score it; never raises."""
    if not method_available(case.method):
        return RunRecord(case, "not available")
    if case.path is None and case.drive not in cache and not module_available("roadgrip.sim.scenarios"):
        return RunRecord(case, "not available (no simulator)")
    try:
        drive = _load_drive(case, settings, seed, cache)
    except Exception as exc:  # reported in the table, never fatal
        return RunRecord(case, _status("error: drive", exc), details=[f"drive: {exc}"])
    from roadgrip.estimators import run_estimator

    try:
        request = _request(case, settings, seed, drive)
        if case.format == "dart" and case.method in CLASSIFIERS:
            # Calibrated on the first halves of every DART run, tested on this run's second half.
            request = replace(request, calibration=_dart_calibration(cache))
            drive = drive.slice_time(drive.t[0] + 0.5 * drive.duration, np.inf)
        _warm_up(case, drive, request)
        t0 = time.perf_counter()
        result = run_estimator(case.method, drive, request)
        wall = time.perf_counter() - t0
    except Exception as exc:  # reported in the table, never fatal
        return RunRecord(case, _status(f"error: {type(exc).__name__}", exc), drive=drive,
                         details=[f"{type(exc).__name__}: {exc}"])
    rec = RunRecord(case, "ok", drive=drive, result=result, wall_s=wall)
    try:
        score(rec)
    except Exception as exc:  # reported in the table, never fatal
        rec.status = _status(f"error: scoring: {type(exc).__name__}", exc)
        rec.details.append(f"scoring failed: {type(exc).__name__}: {exc}")
    return rec


def _warm_up(case: Case, drive, request) -> None:
    """Run the estimator once on the first samples so that compilation is not timed."""
    from roadgrip.estimators import run_estimator

    n = min(drive.n - 1, WARMUP_SAMPLES)
    if n < 2:
        return
    short = drive.slice_time(drive.t[0], drive.t[n])
    try:
        run_estimator(case.method, short, replace(request, curve_times=None))
    except Exception:  # the timed run reports any real problem
        pass


WARMUP_SAMPLES = 60
"""Samples of the untimed warm-up run (just-in-time compilation) before each timed run."""

DART_SETTLING_S = 10.0
"""Settling time [s] at the start of a DART test half left out of its accuracy."""


def _dart_calibration(cache: dict) -> str:
    """Calibrate bRLS and slipmap on the first half of every DART run; the YAML path (cached)."""
    key = "__dart_calibration__"
    if key not in cache:
        import tempfile

        from roadgrip.estimators import brls
        from roadgrip.io import read_drive

        root = real_data_root()
        if root is None:
            raise ValueError("DART data not found")
        labelled = []
        for floor, ref in (("high_grip_rubbery_floor", "high"), ("low_grip_tape_and_tiles", "low")):
            for f in sorted((root / "dart" / floor).glob("*.csv")):
                d = read_drive(f, format="dart")
                labelled.append((d.slice_time(d.t[0], d.t[0] + 0.5 * d.duration), ref))
        path = Path(tempfile.mkdtemp(prefix="roadgrip-bench-")) / "dart-calibration.yaml"
        brls.save_calibration(brls.calibrate(labelled), path)
        cache[key] = str(path)
    return cache[key]


def _status(prefix: str, exc: BaseException, width: int = 100) -> str:
    """One-line status: the prefix and the first line of the message, shortened."""
    first = (str(exc).strip().splitlines() or [""])[0]
    text = f"{prefix}: {first}"
    return text if len(text) <= width else text[: width - 1] + "…"


def run_suite(
    cases: Sequence[Case],
    settings: BenchSettings,
    *,
    seed: int = 0,
    on_case: Callable[[Case], None] | None = None,
    on_done: Callable[[RunRecord], None] | None = None,
    drives: dict | None = None,
) -> list[RunRecord]:
    """Run every case in order (drives are simulated or read once and shared).

    ``drives`` maps a case's ``drive`` name to a ready :class:`~roadgrip.drive.Drive`
    to use instead of simulating or reading it.
    """
    cache: dict = dict(drives or {})
    out = []
    for case in cases:
        if on_case:
            on_case(case)
        rec = run_case(case, settings, seed, cache)
        out.append(rec)
        if on_done:
            on_done(rec)
    return out


# -- scoring -----------------------------------------------------------------------------
def _finite_col(tab: pd.DataFrame, col: str) -> np.ndarray | None:
    if col not in tab.columns:
        return None
    v = pd.to_numeric(tab[col], errors="coerce").to_numpy(float)
    return v if np.isfinite(v).any() else None


def _truth_on(drive, tab: pd.DataFrame, values: np.ndarray) -> np.ndarray:
    """Truth sampled at the estimate times (estimators may drop leading samples)."""
    t_est = tab["t"].to_numpy(float)
    if len(t_est) == drive.n and np.allclose(t_est, drive.t):
        return values
    idx = np.clip(np.searchsorted(drive.t, t_est - 1e-9), 0, drive.n - 1)
    return values[idx]


def score(rec: RunRecord) -> None:
    """Fill ``rec.metrics`` and ``rec.details`` from the drive's truth or reference."""
    drive, res = rec.drive, rec.result
    tab = res.table
    timing = res.meta.get("timing") or {}
    n = len(tab)
    wall = float(timing.get("wall_s", rec.wall_s))
    m = rec.metrics
    m["samples"] = float(n)
    m["wall_s"] = wall
    m["samples_per_s"] = n / wall if wall > 0 else np.nan
    m["rtf"] = drive.duration / wall if wall > 0 else np.nan
    if drive.has_truth:
        _score_friction(rec)
        _score_curves(rec)
        _score_classes(rec)
    elif rec.case.reference is not None:
        _score_reference(rec)
    if rec.case.method == "cascade" and drive.has_pose:
        _score_map(rec)


def _score_friction(rec: RunRecord) -> None:
    drive, tab, m = rec.drive, rec.result.table, rec.metrics
    rates, covs = [], []
    for axle in ("front", "rear"):
        est = _finite_col(tab, f"mu_{axle}")
        if est is None:
            continue
        lo = _finite_col(tab, f"mu_{axle}_lower")
        hi = _finite_col(tab, f"mu_{axle}_upper")
        truth = _truth_on(drive, tab, M.true_peak_series(drive, axle))
        obs = None
        if rec.case.method in PEAK_FLAG_METHODS and f"peak_observed_{axle}" in tab:
            obs = tab[f"peak_observed_{axle}"].to_numpy(bool)
        err = est[-1] - truth[-1]
        final_obs = bool(obs[-1]) if obs is not None else True
        if final_obs:
            m[f"peak_err_{axle[0]}"] = float(err)
            rec.details.append(f"final {axle} peak {est[-1]:.3f} (truth {truth[-1]:.3f}, "
                               f"error {err:+.3f})")
        else:
            # Not a claim about the peak: judge it as the lower bound it says it is.
            holds = est[-1] <= truth[-1] + 0.1
            rec.details.append(
                f"final {axle}: peak not observed, {est[-1]:.3f} reported as a lower bound "
                f"(truth {truth[-1]:.3f}; the bound {'holds' if holds else 'is violated'})"
            )
        if lo is not None and hi is not None:
            covs.append(M.band_coverage(truth, lo, hi))
            rates.append(M.confident_wrong_rate(est, lo, hi, truth, tol=0.1, observed=obs))
    if covs:
        m["mu_band_cov"] = float(np.nanmin(covs)) if np.isfinite(covs).any() else np.nan
    if rates:
        m["conf_wrong"] = float(np.nanmax(rates)) if np.isfinite(rates).any() else np.nan


def _score_curves(rec: RunRecord) -> None:
    curves = rec.result.curves
    if curves is None or len(curves) == 0:
        return
    drive, m = rec.drive, rec.metrics
    maes, covs = [], []
    truths: dict[tuple[str, str | None], Any] = {}
    for t_c in sorted(curves["t"].unique()):
        for axle, col in (("front", "alpha_f_true"), ("rear", "alpha_r_true")):
            c = curves[(curves["t"] == t_c) & (curves["axle"] == axle)].sort_values("alpha")
            if c.empty or col not in drive.data.columns:
                continue
            upto = drive.t - drive.t[0] <= t_c + 1e-9
            visited = drive.col(col)[upto]
            # The true curve of the surface under the vehicle at the curve's time: the
            # parametric tire, or the binned Fy/Fz of the whole drive on that surface in
            # the same slip bins (NaN, hence not scored, where the truth visited no bin).
            surface = str(drive.data["surface"][upto].iloc[-1]) if drive.has("surface") else None
            if (axle, surface) not in truths:
                truths[axle, surface] = true_curve(drive, axle, surface, bin_width=CURVE_BIN_WIDTH)
            truth: Any = truths[axle, surface]
            cm = M.curve_error(c["alpha"].to_numpy(float), c["mu_mean"].to_numpy(float), truth,
                               visited, mu_lower=c["mu_lower"].to_numpy(float),
                               mu_upper=c["mu_upper"].to_numpy(float), min_visits=20,
                               bin_width=CURVE_BIN_WIDTH, at_bin_centres=True)
            if cm.n_points:
                maes.append(cm.mae)
                covs.append(cm.coverage)
                rec.details.append(
                    f"curve {axle} at t = {t_c:.0f} s: MAE {cm.mae:.4f}, 95 % band coverage "
                    f"{100 * cm.coverage:.0f} % over slip {cm.slip_range[0]:+.3f}..{cm.slip_range[1]:+.3f} rad"
                )
    if maes:
        m["curve_mae"] = float(max(maes))
        m["curve_cov"] = float(min(covs))


def _score_classes(rec: RunRecord) -> None:
    tab = rec.result.table
    if "grip_class" not in tab.columns:
        return
    pred = tab["grip_class"].astype(str).to_numpy()
    if rec.case.method not in CLASSIFIERS and (pred == "unknown").all():
        return
    drive, m = rec.drive, rec.metrics
    truth = M.truth_grip_class(_truth_on(drive, tab, M.true_peak_series(drive, "front")))
    t = tab["t"].to_numpy(float)
    excited = _truth_on(drive, tab, M.truth_excitation(drive))
    m["conf_wrong"] = M.confident_wrong_class_rate(pred, truth)
    m["switches"] = float(M.count_switches(pred))
    if not excited.any():
        # Nothing to classify from: only the absence of confident claims is judged.
        rec.details.append(
            f"no sufficiently excited sample; classes: {100 * np.mean(pred == 'unknown'):.0f} % "
            f"unknown, {int(m['switches'])} confident switches"
        )
        return
    m["class_acc"] = M.classification_accuracy(pred, truth).accuracy
    m["class_acc_exc"] = M.classification_accuracy(pred, truth, excited).accuracy
    # Delays count from the first sample after a change that the estimator itself flags as
    # excited (the contract's `excited`); without that flag, from the measured excitation.
    own = tab["excited"].to_numpy(bool) if "excited" in tab.columns else None
    exc_ref = own if own is not None and own.any() else excited
    events = M.detection_delays(t, pred, truth, exc_ref, hold=0.5)
    if events:
        delays = [e.delay_from_excitation for e in events]
        m["detected"] = float(sum(e.detected for e in events)) / len(events)
        m["max_delay_s"] = float(np.max(delays)) if all(np.isfinite(delays)) else np.inf
        for e in events:
            rec.details.append(
                f"change to {e.new_class} at t = {e.t_change:.1f} s: first excited sample "
                f"{e.t_excited:.1f} s, detected {e.t_detected:.1f} s (delay "
                f"{e.delay_from_excitation:.2f} s after excitation, {e.delay_from_change:.2f} s "
                "after the change)"
            )


def _score_reference(rec: RunRecord) -> None:
    ref = rec.case.reference
    tab, m = rec.result.table, rec.metrics
    est = _finite_col(tab, "mu_front")
    if est is not None and rec.case.method in FRICTION_METHODS:
        rear = _finite_col(tab, "mu_rear")
        peak = float(np.nanmax([est[-1], rear[-1] if rear is not None else np.nan]))
        m["peak_ref_err"] = peak - DART_REFERENCE[ref]
        rec.details.append(f"learned peak {peak:.3f} on the {ref}-grip floor "
                           f"(reference about {DART_REFERENCE[ref]})")
    if rec.case.method in CLASSIFIERS and "grip_class" in tab.columns:
        pred = tab["grip_class"].astype(str).to_numpy()
        exc = tab["excited"].to_numpy(bool) if "excited" in tab.columns else np.ones(len(tab), bool)
        t = tab["t"].to_numpy(float)
        settled = t - t[0] > DART_SETTLING_S
        truth = np.full(len(pred), ref)
        m["class_acc"] = M.classification_accuracy(pred, truth).accuracy
        m["class_acc_exc"] = M.classification_accuracy(pred, truth, exc & settled).accuracy
        m["conf_wrong"] = M.confident_wrong_class_rate(pred, truth)
        m["switches"] = float(M.count_switches(pred))
        rec.details.append(
            f"second half of the run ({t[-1] - t[0]:.0f} s), calibrated on the first halves of all "
            f"DART runs: {100 * m['class_acc_exc']:.0f} % of the excited time after "
            f"{DART_SETTLING_S:.0f} s settling classified {ref}"
        )


def _score_map(rec: RunRecord) -> None:
    """Fuse the cascade's estimates into a grid and score its cells against the truth."""
    if not module_available("roadgrip.mapping"):
        rec.details.append("friction grid: roadgrip.mapping not available")
        return
    from roadgrip.evaluate.maps import cells_from_result, true_cell_friction

    cells, cell_size, rec.grid = cells_from_result(rec.result, rec.drive)
    rec.map_cells = cells
    m = rec.metrics
    well = cells["n_obs"].to_numpy() >= 10
    m["map_cells"] = float(well.sum())
    drive = rec.drive
    if well.any() and not drive.has_truth:
        mu = cells["mu_mean"].to_numpy(float)[well]
        sd = cells["mu_std"].to_numpy(float)[well]
        rec.details.append(
            f"friction grid ({cell_size:g} m cells): {int(well.sum())} cells with ≥ 10 excited "
            f"observations, cell μ {np.percentile(mu, 5):.2f}..{np.percentile(mu, 95):.2f} "
            f"(5-95 %), median std {np.median(sd):.3f}"
        )
    if drive.has_truth:
        truth = true_cell_friction(drive, cells, cell_size, table=rec.result.table)
        mm = M.map_metrics(cells["mu_mean"], cells["mu_std"], cells["n_obs"], truth, min_obs=10)
        m["map_cells"] = float(mm.n_cells)
        m["map_mae"] = mm.mae
        m["map_within"] = mm.within_tol
        m["map_cov95"] = mm.coverage95
        if mm.n_cells == 0:
            rec.details.append("friction grid: no cell with ≥ 10 excited observations")
            return
        cal = ", ".join(f"{100 * p:.0f}%→{100 * e:.0f}%" for p, e in mm.calibration)
        rec.details.append(
            f"friction grid: {mm.n_cells} cells with ≥ 10 excited observations, MAE {mm.mae:.3f}, "
            f"{100 * mm.within_tol:.0f} % within 0.1, calibration (nominal→empirical) {cal}; "
            f"never-excited cells with std ≥ 0.2: {100 * mm.unobserved_wide:.0f} %"
        )


# -- the table ---------------------------------------------------------------------------
BENCH_COLUMNS: dict[str, tuple[str, str]] = {
    # key: (header, format)
    "samples": ("samples", "{:.0f}"),
    "samples_per_s": ("samples/s", "{:,.0f}"),
    "rtf": ("real-time ×", "{:,.0f}"),
    "curve_mae": ("curve MAE", "{:.3f}"),
    "curve_cov": ("curve band cov.", "{:.0%}"),
    "peak_err_f": ("peak err. front", "{:+.3f}"),
    "peak_err_r": ("peak err. rear", "{:+.3f}"),
    "peak_ref_err": ("peak − reference", "{:+.3f}"),
    "mu_band_cov": ("μ band cov.", "{:.0%}"),
    "class_acc": ("class acc.", "{:.0%}"),
    "class_acc_exc": ("class acc. (excited)", "{:.0%}"),
    "max_delay_s": ("max delay [s]", "{:.2f}"),
    "switches": ("switches", "{:.0f}"),
    "conf_wrong": ("confident wrong", "{:.1%}"),
    "map_cells": ("map cells", "{:.0f}"),
    "map_mae": ("map MAE", "{:.3f}"),
    "map_cov95": ("map 95 % cov.", "{:.0%}"),
}
"""Metric key -> (column header, format) of the benchmark table."""


COLUMN_NOTES = (
    "Columns: curve MAE / band cov. = worst over axles and times (t = 50 s and end) of the "
    "posterior-mean curve error and 95 % band coverage over 0.5° slip bins visited ≥ 20 times; "
    "peak err. = final peak estimate − true peak (only where the estimator reports the peak as "
    "observed; otherwise it is judged as a lower bound in the notes); peak − reference = largest "
    "final axle peak − the floor's approximate friction (DART: 0.8 high, 0.35 low); μ band cov. = "
    "fraction of time the true peak lies in the 95 % band; class acc. = fraction of time "
    "classified correctly ('unknown' counts as wrong), (excited) = on sufficiently excited "
    "samples (|a| ≥ 2 m/s² for ≥ 0.3 s; DART: the estimator's excited samples after 10 s); max "
    "delay = worst detection delay (the new class held ≥ 0.5 s) after the first sample the "
    "estimator flags as excited following a surface change; confident wrong = fraction of "
    "samples with a confident claim outside tolerance (a band no wider than 0.2 with the "
    "estimate more than 0.1 off, or a wrong 'high'/'low' class; a class held through the "
    "unexcited seconds after a surface change counts); map = cells with ≥ 10 excited "
    "observations, their mean absolute error and the fraction inside mean ± 1.96 std."
)
"""What the benchmark columns mean (shown under the table)."""


def bench_table(records: Sequence[RunRecord]) -> pd.DataFrame:
    """One row per run: drive, method, status and every metric (NaN where it does not apply)."""
    rows = []
    for r in records:
        row: dict[str, Any] = {"drive": r.case.drive, "method": r.case.label, "status": r.status}
        for k in BENCH_COLUMNS:
            row[k] = r.metrics.get(k, np.nan)
        rows.append(row)
    return pd.DataFrame(rows, columns=["drive", "method", "status", *BENCH_COLUMNS])


def format_cell(key: str, value: Any) -> str:
    if key not in BENCH_COLUMNS:
        return str(value)
    if value is None or (isinstance(value, float) and np.isnan(value)):
        return ""
    if isinstance(value, float) and np.isinf(value):
        return "missed"
    return BENCH_COLUMNS[key][1].format(value)


def table_markdown(table: pd.DataFrame) -> str:
    """The benchmark table as GitHub Markdown (columns that are empty everywhere dropped)."""
    keys = ["drive", "method"] + [k for k in BENCH_COLUMNS if table[k].notna().any()] + ["status"]
    head = [BENCH_COLUMNS[k][0] if k in BENCH_COLUMNS else k for k in keys]
    lines = ["| " + " | ".join(head) + " |", "|" + "|".join("---" for _ in keys) + "|"]
    for _, row in table.iterrows():
        lines.append("| " + " | ".join(format_cell(k, row[k]) for k in keys) + " |")
    return "\n".join(lines) + "\n"


_SUMMARY_KEYS = (
    ("curve_mae", "curve MAE"), ("curve_cov", "band"), ("peak_err_f", "peak err f"),
    ("peak_err_r", "r"), ("peak_ref_err", "peak − ref."), ("mu_band_cov", "μ band"), ("class_acc", "acc"),
    ("class_acc_exc", "acc exc."), ("max_delay_s", "delay"), ("switches", "switches"),
    ("conf_wrong", "conf. wrong"), ("map_mae", "map MAE"), ("map_cov95", "map cov"),
)


def accuracy_summary(row) -> str:
    """The accuracy figures of one table row as one short line (for the terminal)."""
    parts = []
    for key, short in _SUMMARY_KEYS:
        v = row.get(key, np.nan)
        if isinstance(v, float) and np.isnan(v):
            continue
        parts.append(f"{short} {format_cell(key, v)}")
    return ", ".join(parts)


def rich_table(table: pd.DataFrame, title: str = "benchmark"):
    """Terminal rendering: per run one line of speed and status, one line of accuracy.

    A wide table does not fit a terminal; this stays readable at 80 columns.
    """
    from rich.console import Group
    from rich.text import Text

    lines = [Text(title, style="bold")]
    for _, row in table.iterrows():
        head = Text(f"{row['drive']} / {row['method']}", style="bold")
        if row["status"] == "ok":
            head.append(f"  {format_cell('samples_per_s', row['samples_per_s'])} samples/s, "
                        f"{format_cell('rtf', row['rtf'])}× real time")
        else:
            head.append(f"  {row['status']}", style="red" if str(row["status"]).startswith("error")
                        else "yellow")
        lines.append(head)
        acc = accuracy_summary(row)
        if acc:
            lines.append(Text("    " + acc))
    return Group(*lines)


def write_outputs(records: Sequence[RunRecord], out_dir: Path, settings: BenchSettings,
                  seed: int) -> pd.DataFrame:
    """Write ``bench.csv`` and ``bench.md`` (table plus the per-run details) to ``out_dir``."""
    out_dir.mkdir(parents=True, exist_ok=True)
    table = bench_table(records)
    table.to_csv(out_dir / "bench.csv", index=False)
    md = [f"# roadgrip benchmark\n\nseed {seed}; {settings.describe()}\n\n", table_markdown(table)]
    md.extend(f"\n{n}\n" for n in suite_notes(records))
    md.append("\n" + COLUMN_NOTES + "\n")
    for r in records:
        if r.details:
            md.append(f"\n**{r.case.drive} / {r.case.label}**\n")
            md.extend(f"- {d}\n" for d in r.details)
    (out_dir / "bench.md").write_text("".join(md))
    return table


def suite_notes(records: Sequence[RunRecord]) -> list[str]:
    """Findings across runs: agreement of the frictionmaps DS3-DS5 maps on common cells."""
    notes = []
    loop = [r for r in records if r.grid is not None and r.case.drive in
            ("frictionmaps:DS3", "frictionmaps:DS4", "frictionmaps:DS5")]
    if len(loop) >= 2:
        from roadgrip.mapping import compare_grids

        cmp = compare_grids([r.grid for r in loop], min_obs=10)
        names = ", ".join(r.case.drive.split(":")[1] for r in loop)
        if len(cmp.cells):
            notes.append(
                f"frictionmaps {names} (same loop): {len(cmp.cells)} common cells with ≥ 10 excited "
                f"observations each; mean spread (std across runs) {cmp.spread_std:.3f}, largest "
                f"difference {cmp.max_abs_diff:.3f}"
            )
        else:
            notes.append(f"frictionmaps {names}: no common cell with ≥ 10 excited observations in every run")
    return notes


def bench_cli(output, *, quick: bool = False, seed: int = 0, console=None,
              settings: BenchSettings | None = None, cases: Sequence[Case] | None = None,
              drives: dict | None = None) -> pd.DataFrame:
    """``roadgrip bench``: run the suite with a progress bar, print and write the table.

    ``settings`` defaults to :data:`QUICK` or :data:`FULL`; ``cases`` to
    :func:`default_cases`; ``drives`` pre-supplies drives by name (see :func:`run_suite`).
    """
    from rich.console import Console
    from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn

    console = console or Console()
    settings = settings or (QUICK if quick else FULL)
    cases = list(cases) if cases is not None else default_cases(settings)
    out_dir = Path(output)
    with Progress(TextColumn("{task.description}"), BarColumn(), TextColumn("{task.completed}/{task.total}"),
                  TimeElapsedColumn(), console=console, transient=True) as progress:
        task = progress.add_task("benchmark", total=len(cases))
        records = run_suite(
            cases, settings, seed=seed,
            on_case=lambda c: progress.update(task, description=f"{c.drive} / {c.label}"),
            on_done=lambda r: progress.advance(task),
            drives=drives,
        )
    table = write_outputs(records, out_dir, settings, seed)
    console.print(rich_table(table, title=f"roadgrip benchmark (seed {seed}, {settings.name})"))
    if real_data_root() is None and settings.real_data:
        console.print("note: ../shared/data not found; real-data rows skipped")
    console.print(f"wrote {out_dir / 'bench.md'} and {out_dir / 'bench.csv'}")
    return table


def with_durations(settings: BenchSettings, **durations: float) -> BenchSettings:
    """Copy of ``settings`` with some scenario durations replaced (keys use '_' for '-')."""
    d = dict(settings.durations)
    d.update({k.replace("_", "-"): v for k, v in durations.items()})
    return replace(settings, durations=d)

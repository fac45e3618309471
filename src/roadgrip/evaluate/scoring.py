"""Scoring one benchmark run against the drive's truth or the data set's reference.

:func:`score` fills a :class:`~roadgrip.evaluate.cases.RunRecord`'s ``metrics``
(the keys of :data:`roadgrip.evaluate.table.BENCH_COLUMNS`) and ``details`` (one
line per finding) with :mod:`roadgrip.evaluate.metrics` and the project's honesty
rule (:func:`roadgrip.evaluate.honesty.score_result`).

One definition of *excited* serves every run: the benchmark's own, measured on the
drive (:func:`roadgrip.evaluate.metrics.truth_excitation`, ``|a| >= 2 m/s²`` held
for 0.3 s), never an estimator's ``excited`` flag. Accuracy on the excited samples
and detection delays both use it.

A sample without a claim is an *abstention*, not an error: the class ``'unknown'``,
or, for a method that flags its peaks (:data:`~roadgrip.evaluate.cases.PEAK_FLAG_METHODS`),
a peak observed on neither axle (its ``mu_*`` is then a lower bound). Accuracy is taken
over the samples with a claim, and the abstained share is reported beside it.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import pandas as pd

from roadgrip.evaluate import metrics as M
from roadgrip.evaluate.cases import (
    CLASSIFIERS,
    CURVE_BIN_WIDTH,
    DART_REFERENCE,
    FRICTION_METHODS,
    PEAK_FLAG_METHODS,
    RunRecord,
)
from roadgrip.evaluate.map_metrics import map_metrics
from roadgrip.evaluate.metrics import truth_at_estimates
from roadgrip.truth import true_curve

__all__ = ["CLASS_HOLD_S", "DART_SETTLING_S", "score"]

DART_SETTLING_S = 10.0
"""Settling time [s] at the start of a DART test half left out of its accuracy."""

CLASS_HOLD_S = 0.5
"""How long [s] a new class must be held to count as the detection of a change."""


def _finite_col(tab: pd.DataFrame, col: str) -> np.ndarray | None:
    if col not in tab.columns:
        return None
    v = pd.to_numeric(tab[col], errors="coerce").to_numpy(float)
    return v if np.isfinite(v).any() else None


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
    _score_honesty(rec)
    if rec.case.method == "cascade" and drive.has_pose:
        _score_map(rec)


def _excitation(drive, tab: pd.DataFrame) -> np.ndarray:
    """The benchmark's excitation (module docstring) at the estimate times, shape (len(tab),)."""
    return truth_at_estimates(drive, tab, M.truth_excitation(drive)).astype(bool)


def _peak_flags(rec: RunRecord) -> dict[str, np.ndarray] | None:
    """Axle -> ``peak_observed_<axle>`` of a method that flags its peaks, else None."""
    tab = rec.result.table
    if rec.case.method not in PEAK_FLAG_METHODS:
        return None
    cols = {a: f"peak_observed_{a}" for a in ("front", "rear")}
    if not all(c in tab.columns for c in cols.values()):
        return None
    return {a: tab[c].to_numpy(bool) for a, c in cols.items()}


def _score_peak_abstention(rec: RunRecord, flags: dict[str, np.ndarray]) -> None:
    """Share of samples whose peak is observed on neither axle (no claim of the peak)."""
    claim = flags["front"] | flags["rear"]
    if claim.size:
        rec.metrics["abstained"] = float(np.mean(~claim))


def _score_friction(rec: RunRecord) -> None:
    drive, tab, m = rec.drive, rec.result.table, rec.metrics
    flags = _peak_flags(rec)
    if flags is not None:
        _score_peak_abstention(rec, flags)
    rates, covs = [], []
    for axle in ("front", "rear"):
        est = _finite_col(tab, f"mu_{axle}")
        if est is None:
            continue
        lo = _finite_col(tab, f"mu_{axle}_lower")
        hi = _finite_col(tab, f"mu_{axle}_upper")
        truth = truth_at_estimates(drive, tab, M.true_peak_series(drive, axle))
        obs = flags[axle] if flags is not None else None
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
    truth = M.truth_grip_class(truth_at_estimates(drive, tab, M.true_peak_series(drive, "front")))
    t = tab["t"].to_numpy(float)
    excited = _excitation(drive, tab)
    m["conf_wrong"] = M.confident_wrong_class_rate(pred, truth)
    m["switches"] = float(M.count_switches(pred))
    m["abstained"] = float(np.mean(pred == "unknown"))
    if not excited.any():
        # Nothing to classify from: only the absence of confident claims is judged.
        rec.details.append(
            f"no excited sample; classes: {100 * m['abstained']:.0f} % unknown, "
            f"{int(m['switches'])} confident switches"
        )
        return
    _score_class_claims(m, pred, truth, excited)
    events = M.detection_delays(t, pred, truth, excited, hold=CLASS_HOLD_S)
    if not events:
        return
    m["detected"] = float(sum(e.detected for e in events)) / len(events)
    m["delay_change_s"] = _worst_delay(events, [e.delay_from_change for e in events])
    m["delay_exc_s"] = _worst_delay(events, [e.delay_from_excitation for e in events])
    ends = [*(e.t_change for e in events[1:]), float(t[-1])]
    for e, t_end in zip(events, ends, strict=True):
        rec.details.append(_event_text(e, "the next change" if t_end < t[-1] else "the end"))


def _score_class_claims(m: dict[str, float], pred: np.ndarray, truth: np.ndarray,
                        excited: np.ndarray) -> None:
    """Accuracy over the samples with a class claim, and the abstained share beside it,
    on all samples and on the excited ones."""
    claim = pred != "unknown"
    m["abstained"] = float(np.mean(~claim))
    m["class_acc"] = M.classification_accuracy(pred, truth, claim).accuracy
    if excited.any():
        m["abstained_exc"] = float(np.mean(~claim[excited]))
        m["class_acc_exc"] = M.classification_accuracy(pred, truth, claim & excited).accuracy


def _worst_delay(events: list[M.DetectionEvent], delays: list[float]) -> float:
    """Largest delay [s]; ``inf`` when a change was not detected; NaN when none is measured."""
    if not all(e.detected for e in events):
        return float("inf")
    finite = [d for d in delays if np.isfinite(d)]
    return float(max(finite)) if finite else float("nan")


def _event_text(e: M.DetectionEvent, until: str) -> str:
    """One line on how the class followed one true change."""
    head = f"change to {e.new_class} at t = {e.t_change:.1f} s: "
    if np.isfinite(e.t_excited):
        exc = f"first excited sample {e.t_excited:.1f} s"
    else:
        exc = f"no excited sample before {until}"
    if not e.detected:
        return (head + f"not detected (the class did not switch to {e.new_class} for "
                f"≥ {CLASS_HOLD_S:g} s before {until}); " + exc)
    text = head + f"detected {e.t_detected:.1f} s, {e.delay_from_change:.2f} s after the change; "
    if not np.isfinite(e.t_excited):
        return text + exc + " (no delay from excitation)"
    if e.t_detected < e.t_excited:
        return text + exc + f", {e.t_excited - e.t_detected:.2f} s after the detection (delay 0)"
    return text + exc + f", delay {e.delay_from_excitation:.2f} s after it"


def _score_reference(rec: RunRecord) -> None:
    ref = rec.case.reference
    tab, m = rec.result.table, rec.metrics
    est = _finite_col(tab, "mu_front")
    if est is not None and rec.case.method in FRICTION_METHODS:
        _score_reference_peak(rec, ref, est, _finite_col(tab, "mu_rear"))
    if rec.case.method in CLASSIFIERS and "grip_class" in tab.columns:
        pred = tab["grip_class"].astype(str).to_numpy()
        t = tab["t"].to_numpy(float)
        settled = t - t[0] > DART_SETTLING_S
        truth = np.full(len(pred), ref)
        _score_class_claims(m, pred, truth, _excitation(rec.drive, tab) & settled)
        m["conf_wrong"] = M.confident_wrong_class_rate(pred, truth)
        m["switches"] = float(M.count_switches(pred))
        if "abstained_exc" in m:
            acc = m.get("class_acc_exc", np.nan)
            on_exc = (f"on the excited time after {DART_SETTLING_S:.0f} s settling: abstained "
                      f"{100 * m['abstained_exc']:.0f} %"
                      + (f", claims {ref} {100 * acc:.0f} %" if np.isfinite(acc) else ""))
        else:
            on_exc = f"no excited sample after {DART_SETTLING_S:.0f} s settling"
        rec.details.append(
            f"second half of the run ({t[-1] - t[0]:.0f} s), calibrated on the first halves of all "
            f"DART runs; {on_exc}"
        )


def _score_reference_peak(rec: RunRecord, ref: str, front: np.ndarray,
                          rear: np.ndarray | None) -> None:
    """The final peak against the floor's reference; a peak observed on neither axle is a
    lower bound, judged as one in the details."""
    finals = {"front": float(front[-1]), "rear": float(rear[-1]) if rear is not None else np.nan}
    finals = {a: v for a, v in finals.items() if np.isfinite(v)}
    if not finals:
        return
    flags = _peak_flags(rec)
    observed = finals
    if flags is not None:
        _score_peak_abstention(rec, flags)
        observed = {a: v for a, v in finals.items() if flags[a][-1]}
    value = DART_REFERENCE[ref]
    if observed:
        peak = max(observed.values())
        rec.metrics["peak_ref_err"] = peak - value
        rec.details.append(f"learned peak {peak:.3f} on the {ref}-grip floor (reference about {value})")
        return
    bound = max(finals.values())
    holds = bound <= value + 0.1
    rec.details.append(
        f"final peak not observed on either axle: {bound:.3f} reported as a lower bound on the "
        f"{ref}-grip floor (reference about {value}; the bound {'holds' if holds else 'is violated'})"
    )


def _score_honesty(rec: RunRecord) -> None:
    """The honesty rule's three columns: wrong claims, informative and diverged shares."""
    from roadgrip.evaluate.honesty import score_result

    res = rec.result
    band = res.meta.get("prior_band")
    h = score_result(res, rec.drive, prior_band=tuple(band) if band is not None else None)
    m = rec.metrics
    m["wrong_claims"] = h.wrong
    m["informative"] = h.informative
    m["diverged"] = h.diverged
    paths = [f"{name} {100 * v:.2f} %" for name, v in (
        ("axle bands", h.wrong_axle), ("VSS lines", h.wrong_vss), ("class", h.wrong_class),
        ("vy band", h.wrong_vy)) if np.isfinite(v)]
    against = "the truth" if rec.drive.has("mu_true") else "the demonstrated friction floor"
    width = f" (median band width {h.width:.3f})" if np.isfinite(h.width) else ""
    rec.details.append(
        f"honesty against {against}: wrong claims {', '.join(paths) or 'none judged'}; "
        f"informative {100 * h.informative:.1f} %{width}; diverged {100 * h.diverged:.1f} %; "
        f"final summary band {'wrong' if h.summary_wrong else 'not wrong'}"
    )


def _score_map(rec: RunRecord) -> None:
    """Fuse the cascade's estimates into a grid and score its cells against the truth."""
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
        mm = map_metrics(cells["mu_mean"], cells["mu_std"], cells["n_obs"], truth, min_obs=10)
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


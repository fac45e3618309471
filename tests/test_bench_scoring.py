"""The benchmark table reads right: one excitation, abstention beside accuracy, delays, honesty.

Each test scores a hand-made run (a short drive with a known surface change and a
stand-in estimate table) and reads the values and strings of the table's row.
"""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from roadgrip.drive import Drive
from roadgrip.estimators.base import EstimateResult, conform
from roadgrip.evaluate.cases import Case, RunRecord
from roadgrip.evaluate.scoring import score
from roadgrip.evaluate.table import COLUMN_NOTES, bench_table, format_cell, table_markdown
from roadgrip.tire import SURFACES
from roadgrip.vehicle import PRESETS

DT = 0.05  # [s], 20 Hz
T_END = 40.0  # [s]
T_CHANGE = 20.0  # dry asphalt -> snow [s]


def _drive(ay, *, truth: bool = True) -> Drive:
    """40 s at 20 Hz: dry asphalt, snow from 20 s; lateral acceleration ``ay(t)`` [m/s²]."""
    t = np.arange(0.0, T_END, DT)
    df = pd.DataFrame({"t": t, "ax": 0.0 * t, "ay": ay(t), "vx": np.full(t.size, 15.0)})
    if not truth:
        return Drive.from_frame(df, PRESETS["sedan"], source="recording")
    surface = np.where(t < T_CHANGE, "dry_asphalt", "snow")
    df["surface"] = surface
    df["mu_true"] = np.where(surface == "snow", SURFACES["snow"].mu_peak, SURFACES["dry_asphalt"].mu_peak)
    tr = {"surfaces": {s: {"front": SURFACES[s].lateral.to_dict(), "rear": SURFACES[s].lateral.to_dict(),
                           "mu": SURFACES[s].mu_peak} for s in ("dry_asphalt", "snow")}}
    return Drive.from_frame(df, PRESETS["sedan"], source="hand-made", truth=tr)


def _classes(t: np.ndarray, spans: list[tuple[float, float, str]]) -> np.ndarray:
    """'unknown' except ``cls`` on each ``[t0, t1)``."""
    out = np.full(t.size, "unknown", dtype=object)
    for t0, t1, cls in spans:
        out[(t >= t0 - 1e-9) & (t < t1 - 1e-9)] = cls
    return out


def _record(drive: Drive, table: dict, method: str = "brls", **case) -> RunRecord:
    res = EstimateResult(method, conform(pd.DataFrame({"t": drive.t, **table})), {})
    rec = RunRecord(Case("hand", method, method, **case), "ok", drive=drive, result=res, wall_s=1.0)
    score(rec)
    return rec


def _cells(rec: RunRecord) -> dict[str, str]:
    """The row's cells as the table prints them."""
    row = bench_table([rec]).iloc[0]
    return {k: format_cell(k, row[k]) for k in row.index}


def _slalom(t):
    return 3.0 * np.sin(0.7 * t)


# -- abstention and accuracy ------------------------------------------------------------------
def test_unknown_is_abstention_beside_an_accuracy_over_the_claims():
    drive = _drive(_slalom)
    pred = _classes(drive.t, [(15.0, 18.0, "high"), (25.0, 40.0, "low")])  # every claim right
    rec = _record(drive, {"grip_class": pred})
    cells = _cells(rec)
    assert cells["class_acc"] == "100%"  # 360 claims, all right (was 45 %: 'unknown' counted wrong)
    assert cells["abstained"] == "55%"  # 440 of 800 samples 'unknown'
    claim_exc = rec.metrics["class_acc_exc"]
    assert claim_exc == 1.0 and 0.0 < rec.metrics["abstained_exc"] < 1.0
    md = table_markdown(bench_table([rec]))
    assert "| abstained | class acc. | abstained (excited) | class acc. (excited) |" in md


def test_excited_is_the_benchmarks_own_for_accuracy_and_delays():
    # Quiet until 24 s, then 3 m/s²: the benchmark's excitation starts at 24.3 s. The
    # estimator's own flag is set only before the change (5-10 s) and must not be used.
    drive = _drive(lambda t: np.where(t >= 24.0, 3.0, 0.0))
    t = drive.t
    pred = _classes(t, [(0.0, 21.0, "high"), (21.0, 30.0, "low"), (35.0, 40.0, "low")])
    own = (t >= 5.0) & (t < 10.0)
    rec = _record(drive, {"grip_class": pred, "excited": own})
    assert "missed" not in table_markdown(bench_table([rec]))  # the estimator's flag: "missed"
    cells = _cells(rec)
    # accuracy on the excited samples: 314 of them (24.3..39.95 s), 100 'unknown' (30-35 s)
    assert rec.metrics["abstained_exc"] == pytest.approx(100 / 314)
    assert cells["abstained_exc"] == "32%" and cells["class_acc_exc"] == "100%"
    # delays: 1 s from the change; the class switched before the first excited sample
    assert cells["delay_change_s"] == "1.00"
    assert cells["delay_exc_s"] == "0.00"  # the estimator's flag gave no delay ("missed")
    assert any("detected 21.0 s, 1.00 s after the change; first excited sample 24.3 s, "
               "3.30 s after the detection (delay 0)" in d for d in rec.details)
    assert "2 m/s²" in COLUMN_NOTES and "not from the estimator's own flag" in COLUMN_NOTES


def test_a_switched_class_is_never_missed_and_an_unswitched_one_is_not_detected():
    # excited only before the change: the switch at 21 s has no excitation to count from
    drive = _drive(lambda t: np.where(t < 10.0, 3.0, 0.0))
    t = drive.t
    late = _record(drive, {"grip_class": _classes(t, [(0.0, 21.0, "high"), (21.0, 40.0, "low")])})
    never = _record(drive, {"grip_class": _classes(t, [(0.0, 40.0, "high")])})
    md = table_markdown(bench_table([late, never]))
    assert "missed" not in md and md.count("not detected") == 2
    cells = _cells(late)
    assert cells["delay_change_s"] == "1.00" and cells["delay_exc_s"] == ""
    assert any("no excited sample before the end (no delay from excitation)" in d for d in late.details)
    cells = _cells(never)
    assert cells["delay_change_s"] == cells["delay_exc_s"] == "not detected"
    assert any("not detected (the class did not switch to low for ≥ 0.5 s before the end)" in d
               for d in never.details)


# -- the GP-SSM's abstention: peaks not observed ----------------------------------------------
def _lower_bounds(drive: Drive) -> dict:
    """A GP-SSM-like table that never observes a peak: mu 0.35 with the band [0.3, 2.0]."""
    n = drive.n
    return {f"{c}_{a}{s}": v for a in ("front", "rear") for c, s, v in (
        ("mu", "", np.full(n, 0.35)), ("mu", "_lower", np.full(n, 0.3)), ("mu", "_upper", np.full(n, 2.0)),
        ("peak_observed", "", np.zeros(n, bool)))} | {"diverged": np.zeros(n, bool)}


def test_gpssm_that_observes_no_peak_abstains_with_lower_bounds_only():
    drive = _drive(_slalom)
    rec = _record(drive, _lower_bounds(drive), method="gpssm")
    cells = _cells(rec)
    assert cells["abstained"] == "100%"
    assert cells["peak_err_f"] == cells["peak_err_r"] == ""  # no claim of the peak, no error
    assert cells["wrong_claims"] == "0.00%" and cells["informative"] == "0%"
    assert any("front: peak not observed, 0.350 reported as a lower bound" in d and "holds" in d
               for d in rec.details)


def test_real_data_peak_error_only_where_a_peak_is_observed():
    drive = _drive(_slalom, truth=False)
    table = _lower_bounds(drive)
    rec = _record(drive, table, method="gpssm", reference="high")
    assert "peak_ref_err" not in rec.metrics and rec.metrics["abstained"] == 1.0
    assert any("final peak not observed on either axle: 0.350 reported as a lower bound on the "
               "high-grip floor" in d for d in rec.details)
    table["peak_observed_front"] = drive.t >= 30.0
    rec = _record(drive, table, method="gpssm", reference="high")
    assert rec.metrics["peak_ref_err"] == pytest.approx(0.35 - 0.8)
    assert rec.metrics["abstained"] == pytest.approx(0.75)


# -- honesty columns ----------------------------------------------------------------------------
def _bands(drive: Drive, offset: float = 0.0, diverged_share: float = 0.0) -> dict:
    """Bands ±0.1 around the true peak (``offset`` added), the first samples flagged diverged."""
    from roadgrip.evaluate.metrics import true_peak_series

    mu = true_peak_series(drive) + offset
    div = np.arange(drive.n) < round(diverged_share * drive.n)
    return {f"{c}_{a}{s}": v for a in ("front", "rear") for c, s, v in (
        ("mu", "", mu), ("mu", "_lower", mu - 0.1), ("mu", "_upper", mu + 0.1),
        ("peak_observed", "", np.ones(drive.n, bool)))} | {"diverged": div}


def test_honesty_columns_in_every_row():
    drive = _drive(_slalom)
    right = _cells(_record(drive, _bands(drive, diverged_share=0.1), method="gpssm"))
    assert (right["wrong_claims"], right["informative"], right["diverged"]) == ("0.00%", "90%", "10.0%")
    wrong = _cells(_record(drive, _bands(drive, offset=0.3), method="gpssm"))
    assert wrong["wrong_claims"] == "100.00%"  # every judged band excludes the truth
    # a classifier's 'low' on dry asphalt for 4 s: 80 of the 600 judged samples (the 10 s
    # after the change are excused: the drive has no utilisation to show the new surface)
    pred = _classes(drive.t, [(0.0, 5.0, "high"), (5.0, 9.0, "low"), (9.0, 20.0, "high"),
                              (20.0, 40.0, "low")])
    cls = _record(drive, {"grip_class": pred})
    assert cls.metrics["wrong_claims"] == pytest.approx(80 / 600)
    assert _cells(cls)["wrong_claims"] == "13.33%" and _cells(cls)["diverged"] == "0.0%"
    md = table_markdown(bench_table([cls]))
    assert "| wrong claims | informative | diverged |" in md
    assert "roadgrip.evaluate.honesty" in COLUMN_NOTES


def test_recordings_are_judged_against_the_demonstrated_floor():
    drive = _drive(lambda t: np.full(t.size, 7.5), truth=False)  # 0.76 g held: 'low' is wrong
    rec = _record(drive, {"grip_class": np.full(drive.n, "low")}, reference="high")
    assert rec.metrics["wrong_claims"] > 0.9 and rec.metrics["abstained"] == 0.0
    assert any("honesty against the demonstrated friction floor" in d for d in rec.details)

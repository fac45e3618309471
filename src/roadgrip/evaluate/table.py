"""The benchmark table: one row per run, its Markdown and CSV files and its notes."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from roadgrip.evaluate.cases import BenchSettings, RunRecord

__all__ = [
    "BENCH_COLUMNS",
    "COLUMN_NOTES",
    "DELAY_KEYS",
    "accuracy_summary",
    "bench_table",
    "format_cell",
    "honesty_summary",
    "suite_notes",
    "table_markdown",
    "write_outputs",
]

BENCH_COLUMNS: dict[str, tuple[str, str]] = {
    # key: (header, format)
    "samples": ("samples", "{:.0f}"),
    "samples_per_s": ("samples/s", "{:,.0f}"),
    "rtf": ("real-time ×", "{:,.0f}"),
    "curve_mae": ("curve MAE", "{:.3f}"),
    "curve_cov": ("curve band cov.", "{:.0%}"),
    "mu_band_cov": ("μ band cov.", "{:.0%}"),
    "peak_err_f": ("peak err. front", "{:+.3f}"),
    "peak_err_r": ("peak err. rear", "{:+.3f}"),
    "peak_ref_err": ("peak − reference", "{:+.3f}"),
    "abstained": ("abstained", "{:.0%}"),
    "class_acc": ("class acc.", "{:.0%}"),
    "abstained_exc": ("abstained (excited)", "{:.0%}"),
    "class_acc_exc": ("class acc. (excited)", "{:.0%}"),
    "delay_change_s": ("max delay from change [s]", "{:.2f}"),
    "delay_exc_s": ("max delay from excitation [s]", "{:.2f}"),
    "switches": ("switches", "{:.0f}"),
    "conf_wrong": ("confident wrong", "{:.1%}"),
    "wrong_claims": ("wrong claims", "{:.2%}"),
    "informative": ("informative", "{:.0%}"),
    "diverged": ("diverged", "{:.1%}"),
    "map_cells": ("map cells", "{:.0f}"),
    "map_mae": ("map MAE", "{:.3f}"),
    "map_cov95": ("map 95 % cov.", "{:.0%}"),
}
"""Metric key -> (column header, format) of the benchmark table."""

DELAY_KEYS = ("delay_change_s", "delay_exc_s")
"""Delay columns: ``inf`` there is a change that was never detected."""


COLUMN_NOTES = (
    "Excited (one definition for the whole table, from the drive, not from the estimator's own "
    "flag): the measured horizontal acceleration sqrt(ax² + ay²) has stayed ≥ 2 m/s² for ≥ 0.3 s "
    "(roadgrip.evaluate.metrics.truth_excitation); it is used by the (excited) columns and the "
    "delays. "
    "Columns: curve MAE / band cov. = worst over axles and times (t = 50 s and end) of the "
    "posterior-mean curve error and 95 % band coverage over 0.5° slip bins visited ≥ 20 times; "
    "μ band cov. = fraction of time the true peak lies in the 95 % band; "
    "peak err. = final peak estimate − true peak (only where the estimator reports the peak as "
    "observed; otherwise it is judged as a lower bound in the notes); peak − reference = largest "
    "final observed axle peak − the floor's approximate friction (DART: 0.8 high, 0.35 low); "
    "abstained = fraction of samples without a claim: class 'unknown', or, for the GP-SSM, the "
    "peak observed on neither axle (its μ is then a lower bound); class acc. = fraction of the "
    "samples with a 'high'/'low' claim that are right (abstaining is not counted as an error); "
    "(excited) = the same on the excited samples (DART: after 10 s settling); max delay from "
    "change / from excitation = worst over the true class changes of the time until the new class "
    "is shown (and held ≥ 0.5 s), counted from the change and from the first excited sample after "
    "it (0 when the class switched before that sample); 'not detected' = the class never switched "
    "to the new one before the next change or the end; confident wrong = fraction of "
    "samples with a confident claim outside tolerance (a band no wider than 0.2 with the "
    "estimate more than 0.1 off, or a wrong 'high'/'low' class; a class held through the "
    "unexcited seconds after a surface change counts); "
    "wrong claims / informative / diverged = the project's honesty rule "
    "(roadgrip.evaluate.honesty): wrong claims = largest share, over the output paths (axle "
    "bands, VSS lines, class, lateral-velocity band), of the samples whose claim is wrong against "
    "the truth (recordings: against the friction the car demonstrably used), claims right after a "
    "true surface change excused until the data show it; informative = fraction of samples with a "
    "band narrower than 0.5 or a class; diverged = fraction the estimator flags diverged (no claim "
    "there); map = cells with ≥ 10 excited observations, their mean absolute error and the "
    "fraction inside mean ± 1.96 std."
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
        return "not detected" if key in DELAY_KEYS else f"{value}"
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
    ("curve_mae", "curve MAE"), ("curve_cov", "band"), ("mu_band_cov", "μ band"),
    ("peak_err_f", "peak err f"), ("peak_err_r", "r"), ("peak_ref_err", "peak − ref."),
    ("abstained", "abstained"), ("class_acc", "acc of claims"), ("abstained_exc", "abstained exc."),
    ("class_acc_exc", "acc exc."), ("delay_change_s", "delay from change"),
    ("delay_exc_s", "from excitation"), ("switches", "switches"), ("conf_wrong", "conf. wrong"),
    ("map_mae", "map MAE"), ("map_cov95", "map cov"),
)
_HONESTY_KEYS = (("wrong_claims", "wrong claims"), ("informative", "informative"),
                 ("diverged", "diverged"))


def _summary(row, keys: Sequence[tuple[str, str]]) -> str:
    parts = []
    for key, short in keys:
        v = row.get(key, np.nan)
        if isinstance(v, float) and np.isnan(v):
            continue
        parts.append(f"{short} {format_cell(key, v)}")
    return ", ".join(parts)


def accuracy_summary(row) -> str:
    """The accuracy figures of one table row as one short line (for the terminal)."""
    return _summary(row, _SUMMARY_KEYS)


def honesty_summary(row) -> str:
    """The honesty-rule figures of one table row as one short line (for the terminal)."""
    return _summary(row, _HONESTY_KEYS)


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


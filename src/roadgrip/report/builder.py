"""Assemble the self-contained HTML report from benchmark run records.

The page needs no network: figures are PNG images embedded as base64
``data:`` URIs, the style sheet is inline and there is no script. Each figure
is also written as a PNG file beside ``index.html``.

Sections (HTML ``id`` in brackets): settings and notes (``settings``), the
benchmark table (``benchmark``), input signals (``signals``), friction traces
with their bands (``friction``), learned tire curves (``curves``),
classification traces (``classification``) and friction maps (``map``). A
section with nothing to show says so.
"""

from __future__ import annotations

import base64
import html
import re
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pandas as pd

from roadgrip.evaluate import metrics as M
from roadgrip.evaluate.cases import CLASSIFIERS, PEAK_FLAG_METHODS, RunRecord
from roadgrip.evaluate.table import BENCH_COLUMNS, COLUMN_NOTES, bench_table, format_cell

__all__ = ["SECTIONS", "Figure", "build_report"]

SECTIONS: dict[str, str] = {
    "settings": "Settings and notes",
    "benchmark": "Benchmark",
    "signals": "Input signals",
    "friction": "Friction estimates with 95 % bands",
    "curves": "Learned tire curves",
    "classification": "Grip classification",
    "map": "Friction map",
}
"""Section id -> heading, in page order."""

_CSS = """
body { font-family: system-ui, -apple-system, 'Segoe UI', sans-serif; margin: 0 auto;
       max-width: 1180px; padding: 1em 2em; color: #212529; background: #fff; }
h1 { font-size: 1.6em; border-bottom: 2px solid #1c7ed6; padding-bottom: .2em; }
h2 { font-size: 1.25em; margin-top: 1.8em; color: #1864ab; }
h3 { font-size: 1.0em; margin-bottom: .3em; }
nav a { margin-right: 1em; }
table { border-collapse: collapse; font-size: .78em; margin: .5em 0; }
th, td { border: 1px solid #ced4da; padding: .25em .5em; text-align: right; }
th { background: #e7f5ff; }
td.l, th.l { text-align: left; }
tr.bad td { background: #fff5f5; }
figure { margin: .5em 0 1.2em 0; }
figure img { max-width: 100%; border: 1px solid #e9ecef; }
figcaption { font-size: .85em; color: #495057; }
.note { color: #868e96; font-style: italic; }
ul.details { font-size: .85em; }
p.legend { font-size: .8em; color: #495057; max-width: 70em; }
"""


@dataclass
class Figure:
    """A rendered figure: section, caption, PNG bytes and file name."""

    section: str
    caption: str
    png: bytes
    filename: str


@dataclass
class _Page:
    figures: list[Figure] = field(default_factory=list)

    def add(self, section: str, caption: str, fig, stem: str) -> None:
        from roadgrip.plots.signals import figure_png

        slug = re.sub(r"[^A-Za-z0-9]+", "-", stem).strip("-").lower()
        name = f"{section}-{slug}.png"
        used = {f.filename for f in self.figures}
        k = 2
        while name in used:
            name = f"{section}-{slug}-{k}.png"
            k += 1
        self.figures.append(Figure(section, caption, figure_png(fig), name))


def _truth_peaks(rec: RunRecord) -> dict[str, np.ndarray] | None:
    drive, tab = rec.drive, rec.result.table
    if drive is None or not drive.has_truth:
        return None
    try:
        return {a: M.truth_at_estimates(drive, tab, M.true_peak_series(drive, a))
                for a in ("front", "rear")}
    except ValueError:
        return None


def _has_mu(tab: pd.DataFrame) -> bool:
    return "mu_front" in tab and np.isfinite(pd.to_numeric(tab["mu_front"], errors="coerce")).any()


def _has_class(rec: RunRecord) -> bool:
    tab = rec.result.table
    if "grip_class" not in tab:
        return False
    return rec.case.method in CLASSIFIERS or (tab["grip_class"].astype(str) != "unknown").any()


def _drawn(fig) -> set[str]:
    """Legend labels of everything drawn in ``fig`` (what a caption may mention)."""
    out = set()
    for ax in fig.axes:
        for artist in (*ax.lines, *ax.collections, *ax.patches, *ax.containers):
            label = str(artist.get_label())
            if label and not label.startswith("_"):
                out.add(label)
    return out


def friction_caption(label: str, fig) -> str:
    """Caption of a friction trace (:func:`roadgrip.plots.signals.plot_friction_trace`):
    the parts the figure draws, and only those."""
    drawn = _drawn(fig)
    parts = [f"{label}: peak friction per axle with its 95 % band"]
    if "excited" in drawn:
        parts.append("excited samples shaded yellow")
    if "peak not observed: μ is a lower bound" in drawn:
        parts.append("grey strip: peak not observed, μ is a lower bound")
    parts.append("true peak dashed" if "true peak" in drawn else "no ground truth")
    return "; ".join(parts)


def curves_caption(label: str, fig) -> str:
    """Caption of learned tire curves (:func:`roadgrip.plots.signals.plot_curves`)."""
    drawn = _drawn(fig)
    parts = [f"{label}: posterior mean curves with 95 % bands at the stored times"]
    parts.append("truth dashed" if "truth" in drawn else "no ground truth")
    if "visited slip angles" in drawn:
        parts.append("grey: histogram of the visited (true) slip angles")
    return "; ".join(parts)


def classification_caption(label: str, fig) -> str:
    """Caption of a classification trace (:func:`roadgrip.plots.signals.plot_classification`)."""
    drawn = _drawn(fig)
    parts = [f"{label}: class (shaded) and grip index"]
    if "excited" in drawn:
        parts.append("excitation (orange bar)")
    if _TRUE_CLASS in drawn:
        parts.append("true class dashed")
    elif _FLOOR_CLASS in drawn:
        parts.append("the floor's label dashed")
    else:
        parts.append("no ground truth")
    return "; ".join(parts)


_TRUE_CLASS = "true class (high/low)"
_FLOOR_CLASS = "floor label (high/low)"


def _figures(records: Sequence[RunRecord], extra_drives: dict) -> _Page:
    from roadgrip.plots import signals as P

    page = _Page()
    seen: dict[str, object] = {}
    for rec in records:
        if rec.drive is not None and rec.case.drive not in seen:
            seen[rec.case.drive] = rec.drive
    for name, drive in extra_drives.items():
        seen.setdefault(name, drive)
    for name, drive in seen.items():
        page.add("signals", f"{name}: {drive.n} samples, {drive.duration:.1f} s at "
                 f"{drive.meta.sample_rate:.0f} Hz ({drive.meta.source})",
                 P.plot_signals(drive, title=f"input signals: {name}"), name)
    for rec in records:
        if rec.result is None:
            continue
        tab = rec.result.table
        label = f"{rec.case.drive} / {rec.case.label}"
        if _has_mu(tab):
            shown = tab if rec.case.method in PEAK_FLAG_METHODS else tab.drop(
                columns=["peak_observed_front", "peak_observed_rear"], errors="ignore")
            fig = P.plot_friction_trace(shown, _truth_peaks(rec), title=label)
            page.add("friction", friction_caption(label, fig), fig, label)
        curves = rec.result.curves
        if curves is not None and len(curves):
            visited = None
            if rec.drive is not None and rec.drive.has("alpha_f_true", "alpha_r_true"):
                visited = {"front": rec.drive.col("alpha_f_true"), "rear": rec.drive.col("alpha_r_true")}
            fig = P.plot_curves(curves, visited, title=label)
            page.add("curves", curves_caption(label, fig), fig, label)
        if _has_class(rec):
            truth, truth_label = None, _TRUE_CLASS
            if rec.drive is not None and rec.drive.has_truth:
                pk = _truth_peaks(rec)
                truth = M.truth_grip_class(pk["front"]) if pk else None
            elif rec.case.reference is not None:
                truth, truth_label = np.full(len(tab), rec.case.reference), _FLOOR_CLASS
            sig = None
            if rec.drive is not None and rec.drive.n == len(tab) and rec.drive.has("ax", "ay"):
                sig = {"ax": rec.drive.col("ax"), "ay": rec.drive.col("ay")}
            fig = P.plot_classification(tab, truth, sig, title=label, truth_label=truth_label)
            page.add("classification", classification_caption(label, fig), fig, label)
        if rec.map_cells is not None and len(rec.map_cells):
            size = float(rec.map_cells.attrs.get("cell_size", 0.5))
            path = None
            if rec.drive is not None and rec.drive.has("x", "y"):
                path = (rec.drive.col("x"), rec.drive.col("y"))
            page.add("map", f"{label}: cell mean friction (absolute) and its standard deviation; "
                     f"cell {size:g} m; hatched grey: no data",
                     P.plot_map(rec.map_cells, size, path, title=label), label)
    return page


def _bench_html(table: pd.DataFrame) -> str:
    keys = ["drive", "method"] + [k for k in BENCH_COLUMNS if k in table and table[k].notna().any()]
    keys.append("status")
    head = "".join(
        f'<th class="l">{html.escape(k)}</th>' if k in ("drive", "method", "status")
        else f"<th>{html.escape(BENCH_COLUMNS[k][0])}</th>" for k in keys
    )
    rows = []
    for _, row in table.iterrows():
        bad = str(row.get("status", "ok")) != "ok"
        cells = "".join(
            f'<td class="l">{html.escape(str(row[k]))}</td>' if k in ("drive", "method", "status")
            else f"<td>{html.escape(format_cell(k, row[k]))}</td>" for k in keys
        )
        rows.append(f'<tr class="bad">{cells}</tr>' if bad else f"<tr>{cells}</tr>")
    return f"<table><thead><tr>{head}</tr></thead><tbody>{''.join(rows)}</tbody></table>"


def build_report(
    records: Sequence[RunRecord],
    out_dir: str | Path,
    *,
    title: str = "roadgrip report",
    notes: Sequence[str] = (),
    bench: pd.DataFrame | None = None,
    extra_drives: dict | None = None,
) -> Path:
    """Write ``index.html`` and the PNG figures into ``out_dir``; return the HTML path.

    Parameters
    ----------
    records : sequence of RunRecord
        Estimator runs (with their drive, result, metrics, details and map cells).
    out_dir : path
        Created if missing.
    title : str
        Page title.
    notes : sequence of str
        Lines for the settings section (demo settings, seeds, skipped items).
    bench : DataFrame, optional
        A benchmark table to show instead of the one built from ``records``.
    extra_drives : dict, optional
        Name -> Drive shown in the signals section without an estimator run.
    """
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    page = _figures(records, extra_drives or {})
    for f in page.figures:
        (out / f.filename).write_bytes(f.png)
    table = bench if bench is not None else bench_table(records)
    parts = [
        "<!DOCTYPE html>",
        '<html lang="en"><head><meta charset="utf-8">',
        '<meta name="viewport" content="width=device-width, initial-scale=1">',
        '<link rel="icon" href="data:,">',
        f"<title>{html.escape(title)}</title><style>{_CSS}</style></head><body>",
        f"<h1>{html.escape(title)}</h1>",
        "<nav>" + "".join(f'<a href="#{k}">{html.escape(v)}</a>' for k, v in SECTIONS.items()) + "</nav>",
    ]
    for sec, heading in SECTIONS.items():
        parts.append(f'<section id="{sec}"><h2>{html.escape(heading)}</h2>')
        if sec == "settings":
            parts.append("<ul>" + "".join(f"<li>{html.escape(n)}</li>" for n in notes) + "</ul>"
                         if notes else '<p class="note">No notes.</p>')
        elif sec == "benchmark":
            if len(table):
                parts.append(_bench_html(table))
                parts.append(f'<p class="legend">{html.escape(COLUMN_NOTES)}</p>')
                for rec in records:
                    if rec.details:
                        parts.append(f"<h3>{html.escape(rec.case.drive)} / {html.escape(rec.case.label)}</h3>")
                        parts.append('<ul class="details">' + "".join(
                            f"<li>{html.escape(d)}</li>" for d in rec.details) + "</ul>")
            else:
                parts.append('<p class="note">No estimator runs in these inputs.</p>')
        else:
            figs = [f for f in page.figures if f.section == sec]
            if not figs:
                parts.append(f'<p class="note">Nothing to show: no {html.escape(heading.lower())} '
                             "in these inputs.</p>")
            for f in figs:
                data = base64.b64encode(f.png).decode("ascii")
                parts.append(
                    f'<figure><img alt="{html.escape(f.caption)}" src="data:image/png;base64,{data}">'
                    f"<figcaption>{html.escape(f.caption)} ({html.escape(f.filename)})</figcaption></figure>"
                )
        parts.append("</section>")
    parts.append("</body></html>")
    path = out / "index.html"
    path.write_text("\n".join(parts), encoding="utf-8")
    return path

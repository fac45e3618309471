"""Terminal summary of one estimator run (a rich table), printed by ``roadgrip estimate``."""

from __future__ import annotations

from rich.table import Table

from roadgrip.estimators.base import EstimateResult
from roadgrip.evaluate.cases import PEAK_FLAG_METHODS


def summary_table(result: EstimateResult) -> Table:
    """A run summary: final estimates with bands, timing, method diagnostics."""
    table = Table(title=f"{result.method}: run summary", show_header=True)
    table.add_column("quantity")
    table.add_column("value", justify="right")
    tab = result.table
    last = tab.iloc[-1] if len(tab) else None
    if last is not None:
        for axle in ("front", "rear"):
            m = last.get(f"mu_{axle}")
            if m is not None and m == m:
                lo, hi = last.get(f"mu_{axle}_lower"), last.get(f"mu_{axle}_upper")
                # only a method that writes the flag reports a lower bound when it is False; the
                # others' band is the friction itself
                obs = last.get(f"peak_observed_{axle}") if result.method in PEAK_FLAG_METHODS else None
                note = "" if obs in (None, True) else "  (peak not observed: lower bound)"
                table.add_row(f"peak friction {axle}", f"{m:.3f}  [{lo:.3f}, {hi:.3f}]{note}")
        gc = last.get("grip_class")
        if gc is not None and gc != "unknown":
            table.add_row("grip class (final)", str(gc))
        if "excited" in tab.columns:
            table.add_row("excited samples", f"{100 * tab['excited'].mean():.1f} %")
    for key, value in (result.meta.get("diagnostics") or {}).items():
        table.add_row(key, f"{value:.4g}" if isinstance(value, float) else str(value))
    timing = result.meta.get("timing")
    if timing:
        table.add_row("wall time", f"{timing['wall_s']:.2f} s")
        table.add_row("throughput", f"{timing['samples_per_s']:.0f} samples/s")
        table.add_row("real-time factor", f"{timing['realtime_factor']:.1f} x")
    return table

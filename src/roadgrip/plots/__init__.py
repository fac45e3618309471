"""Figures. One module per figure family (``plots.gpssm``, ``plots.classification``,
``plots.cascade``, ``plots.maps``, ``plots.signals``); all use the non-interactive
Agg backend and label friction in absolute units (force over load, not normalised).

Shared by the families: the friction colour scales and the look of cells without data
(``plots.scales``), the standstill threshold below which slip angles are not drawn
(``plots.standstill``) and titles shortened to fit their figure (``plots.titles``).

:func:`plot_estimate` draws the figure of one estimator run; each method's module
exposes ``plot_result(drive, result, path)``.
"""

from __future__ import annotations

import importlib
from pathlib import Path
from typing import Any

import matplotlib

matplotlib.use("Agg")

__all__ = ["FIGURES", "plot_estimate"]

FIGURES: dict[str, str] = {
    "gpssm": "roadgrip.plots.gpssm",
    "brls": "roadgrip.plots.classification",
    "slipmap": "roadgrip.plots.classification",
    "cascade": "roadgrip.plots.cascade",
}
"""Method -> module whose ``plot_result`` draws its figure (imported when used)."""


def plot_estimate(method: str, drive: Any, result: Any, path: str | Path) -> None:
    """Write the PNG figure of ``method``'s :class:`~roadgrip.estimators.EstimateResult`."""
    if method not in FIGURES:
        raise ValueError(f"no figure for method {method!r}; figures exist for {', '.join(FIGURES)}")
    importlib.import_module(FIGURES[method]).plot_result(drive, result, path)

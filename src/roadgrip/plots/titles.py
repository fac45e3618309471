"""Titles that fit their figure.

A drive's source is often a long file path; a figure one panel wide cuts it at both
edges. :func:`fit_suptitle` shortens the middle of the text (keeping the start, which
names the figure, and the end, which names the file) until it fits the figure's width.
"""

from __future__ import annotations

from matplotlib.figure import Figure
from matplotlib.text import Text

__all__ = ["fit_suptitle"]

_ELLIPSIS = "…"
_WIDTH = 0.96
"""Widest title [fraction of the figure's width]."""


def fit_suptitle(fig: Figure, text: str, fontsize: float = 10) -> Text:
    """Set ``fig``'s title to ``text``, shortened in the middle until it fits the figure.

    Examples
    --------
    >>> import matplotlib.pyplot as plt
    >>> fig = plt.figure(figsize=(2, 1))
    >>> t = fit_suptitle(fig, "GP-SSM: /a/very/long/path/to/some/recording_file_name.csv")
    >>> "…" in t.get_text() and t.get_text().endswith(".csv")
    True
    >>> plt.close(fig)
    """
    title = fig.suptitle(text, fontsize=fontsize)
    renderer = fig.canvas.get_renderer()
    room = _WIDTH * fig.bbox.width

    def fits(n: int) -> bool:
        title.set_text(_middle(text, n))
        return title.get_window_extent(renderer).width <= room

    if not fits(len(text)):
        lo, hi = 0, len(text) - 1  # the most characters kept that fit: binary search
        while lo < hi:
            mid = (lo + hi + 1) // 2
            lo, hi = (mid, hi) if fits(mid) else (lo, mid - 1)
        title.set_text(_middle(text, lo))
    return title


def _middle(text: str, keep: int) -> str:
    """``text`` with all but ``keep`` characters cut from its middle (an ellipsis marks the cut)."""
    if keep >= len(text):
        return text
    head = (keep + 1) // 2
    return text[:head] + _ELLIPSIS + text[len(text) - (keep - head):]

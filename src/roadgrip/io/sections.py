"""The tables of a drive description (:mod:`roadgrip.io.describe`) and their plain-text
rendering."""

from __future__ import annotations

from dataclasses import dataclass

__all__ = ["Section", "format_text"]


@dataclass(frozen=True)
class Section:
    """One table of a drive description.

    Attributes
    ----------
    title : str
    columns : tuple of str
        Column names.
    rows : tuple of tuple of str
        Formatted cells, one tuple per row.
    right : frozenset of str
        Columns aligned right (numbers).
    header : bool
        Whether the column names are shown (the overview is a key-value list).
    """

    title: str
    columns: tuple[str, ...]
    rows: tuple[tuple[str, ...], ...]
    right: frozenset[str] = frozenset()
    header: bool = True


def format_text(sections: list[Section]) -> str:
    """Plain-text rendering of :func:`describe_drive`: each table titled, columns padded."""
    out = []
    for sec in sections:
        rows = [sec.columns, *sec.rows] if sec.header else list(sec.rows)
        widths = [max((len(r[i]) for r in rows), default=0) for i in range(len(sec.columns))]
        out.append(sec.title)
        for r in rows:
            cells = [c.rjust(w) if name in sec.right else c.ljust(w)
                     for c, w, name in zip(r, widths, sec.columns, strict=True)]
            out.append("  " + "  ".join(cells).rstrip())
        out.append("")
    return "\n".join(out)
